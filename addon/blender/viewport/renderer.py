"""The viewport drawing path: items -> cached texels -> sorted order -> one instanced draw.

`ViewportRenderer.draw` is what the draw handler, the engine's view_draw and the
tests call. It keeps, between calls:
- per-object packed texels, keyed by the item's cache key (object, geometry version);
- the GPU textures of the current object set (rebuilt only when the data changes);
- the last sort and the view it was made for: a still camera sorts and uploads
  nothing, a moving one re-sorts (inline, or on the worker thread with the last
  finished order drawn meanwhile).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ...core.scene import RenderItem
from . import packing
from .sorting import SortInput, SortWorker, visible_order

RESORT_EPS = 1e-5  # matrix change (relative) below which the last order is kept
MODES = {"GAUSSIAN": 0, "POINTS": 1, "OPAQUE": 2}


@dataclass(frozen=True)
class ItemDisplay:
    """Viewport-only display options of one object (DisplaySettings as plain values)."""

    splat_scale: float = 1.0
    max_sh_degree: int = 3
    mode: str = "GAUSSIAN"       # GAUSSIAN, POINTS (centres only), OPAQUE (falloff off)
    sh_only: bool = False        # higher SH bands over grey
    cull: bool = True
    dilation: float = 0.2
    key_bits: int = 16


@dataclass(frozen=True)
class DrawSettings:
    sync_sort: bool = True       # False: sort on the worker thread, draw the last order
    linear_output: bool = False  # convert the sRGB splat colours to scene-linear
    antialiased: bool = False
    opacity_aware_extent: bool = True
    point_size: float = 2.0      # half-size in pixels of a point-cloud-mode dot


@dataclass
class Stats:
    total: int = 0
    drawn: int = 0
    cpu_bytes: int = 0
    gpu_bytes: int = 0
    sort_seconds: float = 0.0    # last finished sort (cull + keys + radix)
    upload_seconds: float = 0.0  # last texture upload of any kind
    draw_seconds: float = 0.0    # last draw call (CPU side)
    sorts: int = 0               # orders computed and uploaded
    uploads: int = 0             # splat data texture uploads
    table_uploads: int = 0       # per-object table uploads (matrices, display options)
    frame_sort: float = 0.0      # this draw's sort time on the drawing thread
    frame_upload: float = 0.0    # this draw's packing + texture uploads (data, order, table)


@dataclass
class _Entry:
    identity: object
    splats: object   # kept so an identity by object id can never be reused
    packed: packing.Packed


@dataclass
class _State:
    data_token: tuple = ()
    sorted_token: object = None
    pending_token: object = None
    objects_token: object = None
    entries: dict = field(default_factory=dict)


def _identity(item: RenderItem):
    """Cache identity: the item's key and its SplatSet object.

    Effects may change colours or opacities under an unchanged key (the key names the
    base geometry), so the key alone is not enough; the draw handler reuses the same
    SplatSet object while an object's data is unchanged, which is what makes a hit.
    The cache entry holds the SplatSet, so its id cannot be reused while cached.
    """
    return (item.key, id(item.splats))


class ViewportRenderer:
    def __init__(self, worker: bool = False, on_sorted=None):
        self.gpu = None  # created on the first draw, inside a GPU context
        self.stats = Stats()
        self.state = _State()
        self.worker = SortWorker(on_sorted) if worker else None

    def close(self) -> None:
        if self.worker is not None:
            self.worker.stop()
            self.worker = None
        self.gpu = None
        self.state = _State()

    # -- data ---------------------------------------------------------------
    def _packed(self, item: RenderItem, display: ItemDisplay) -> packing.Packed:
        ident = (_identity(item), min(item.sh_degree, display.max_sh_degree))
        entry = self.state.entries.get(ident)
        if entry is None or entry.splats is not item.splats:
            entry = _Entry(ident, item.splats, packing.pack(item.splats, ident[1]))
        return entry

    def _update_data(self, items, displays) -> bool:
        start = time.perf_counter()
        entries = [self._packed(i, d) for i, d in zip(items, displays)]
        token = tuple(e.identity for e in entries)
        if token == self.state.data_token and self.gpu.base is not None:
            return False
        parts = [e.packed for e in entries]
        base, sh, stride = packing.concatenate(parts)
        self.gpu.set_data(base, sh, stride)
        self.state.entries = {e.identity: e for e in entries}
        self.state.data_token = token
        self.state.sorted_token = None
        self.stats.total = sum(p.count for p in parts)
        self.stats.cpu_bytes = sum(p.nbytes for p in parts)
        self.stats.upload_seconds = time.perf_counter() - start
        self.stats.frame_upload += self.stats.upload_seconds
        self.stats.uploads += 1
        return True

    # -- view ---------------------------------------------------------------
    def _sort_token(self, l2c, projection, displays):
        flat = np.concatenate([np.asarray(projection, np.float64).ravel()] + [m.ravel() for m in l2c])
        return (self.state.data_token, tuple((d.cull, d.dilation, d.key_bits) for d in displays), flat)

    @staticmethod
    def _same_view(a, b) -> bool:
        if a is None or b is None or a[:2] != b[:2] or a[2].shape != b[2].shape:
            return False
        scale = max(1.0, float(np.abs(b[2]).max(initial=0.0)))
        return float(np.abs(a[2] - b[2]).max(initial=0.0)) <= RESORT_EPS * scale

    def _update_order(self, items, displays, l2c, projection, near, far, settings) -> None:
        token = self._sort_token(l2c, projection, displays)
        if self.worker is not None:
            done = self.worker.take()
            if done is not None and done.token[0] == self.state.data_token:
                self._upload_order(done)
        if self._same_view(token, self.state.sorted_token):
            return
        inputs = [SortInput(self.state.entries[e].packed.positions_soa, m, d.cull, d.dilation)
                  for e, m, d in zip(self.state.data_token, l2c, displays)]
        bits = max(d.key_bits for d in displays)
        have_order = self.state.sorted_token is not None
        if settings.sync_sort or self.worker is None or not have_order:
            result = visible_order(inputs, projection, near, far, bits)
            result.token = token
            self.stats.frame_sort += result.seconds
            self._upload_order(result)
        elif not self._same_view(token, self.state.pending_token):
            self.state.pending_token = token
            self.worker.request(token, inputs, projection, near, far, bits)

    def _upload_order(self, result) -> None:
        start = time.perf_counter()
        self.gpu.set_order(result.order)
        self.stats.upload_seconds = time.perf_counter() - start
        self.stats.frame_upload += self.stats.upload_seconds
        self.stats.sort_seconds = result.seconds
        self.stats.drawn = int(result.order.size)
        self.stats.sorts += 1
        self.state.sorted_token = result.token

    @property
    def sorting(self) -> bool:
        return self.worker is not None and not self.worker.idle

    # -- draw ---------------------------------------------------------------
    def draw(self, items: list[RenderItem], view_matrix, projection_matrix, viewport_size,
             settings: DrawSettings = DrawSettings(), displays: list[ItemDisplay] | None = None) -> None:
        """Draw into the bound framebuffer (the caller sets the depth test)."""
        const = self.prepare(items, view_matrix, projection_matrix, viewport_size, settings, displays)
        if const is None:
            return
        start = time.perf_counter()
        self.gpu.draw(const)
        self.stats.draw_seconds = time.perf_counter() - start

    def prepare(self, items, view_matrix, projection_matrix, viewport_size,
                settings: DrawSettings = DrawSettings(), displays=None) -> dict | None:
        """Everything before the draw call: data, order and object table on the GPU.

        Returns the draw's push constants, or None when there is nothing to draw.
        """
        from .gpu_draw import SplatGPU, view_constants

        self.stats.frame_sort = self.stats.frame_upload = 0.0
        keep = [k for k, i in enumerate(items) if i.splats.count]
        if not keep:
            self.stats.total = self.stats.drawn = 0
            return None
        displays = [displays[k] for k in keep] if displays is not None else [ItemDisplay()] * len(keep)
        items = [items[k] for k in keep]
        if self.gpu is None:
            self.gpu = SplatGPU()
        width, height = int(viewport_size[0]), int(viewport_size[1])
        const = view_constants(projection_matrix, width, height, antialiased=settings.antialiased,
                               opacity_aware=settings.opacity_aware_extent,
                               linear_output=settings.linear_output, point_size=settings.point_size)
        view = np.asarray(view_matrix, np.float64)
        l2c = [view @ np.asarray(i.world, np.float64) for i in items]
        self._update_data(items, displays)
        near, far = const["frame"][2], const["frame"][3]
        self._update_order(items, displays, l2c, projection_matrix, near, far, settings)
        self._update_objects(items, displays, l2c, bool(const["flags"][0]))
        self.stats.gpu_bytes = self.gpu.nbytes
        return const

    def _update_objects(self, items, displays, l2c, ortho) -> None:
        from .gpu_draw import object_rows

        rows = []
        for item, d, m in zip(items, displays, l2c):
            degree = max(0, min(item.effective_sh_degree, d.max_sh_degree))
            rows.append(object_rows(m, item.splat_scale * d.splat_scale, item.opacity_scale, degree,
                                    MODES[d.mode], d.sh_only, item.color_matrix, ortho))
        table = np.concatenate(rows)
        if self.state.objects_token is not None and np.array_equal(self.state.objects_token, table):
            return  # still camera, same transforms: nothing to upload
        start = time.perf_counter()
        self.gpu.set_objects(table)
        self.stats.frame_upload += time.perf_counter() - start
        self.state.objects_token = table
        self.stats.table_uploads += 1
