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
import weakref
from dataclasses import dataclass, field, replace

import numpy as np

from ...core.lighting.shade import Lighting
from ...core.matrix_inverse import thickened
from ...core.scene import RenderItem
from . import packing
from .light_rows import light_rows
from .effect_rows import displace_layers, displace_of, effect_rows, morph_of
from .effect_textures import EffectTextures
from .pack_cache import (PackCache, data_firsts, data_key, joined, pos_source, positions_key_of, reads_rest,
                         shared_data, upload_if_new)
from .staging import ALL, ALPHA, PosStage, ShapeStage
from ...core.viewport_sort import (LazyArray, SortInput, SortWorker, bounding_radius, centres_layout,
                                   visible_order)

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
    capped_extent: bool = False  # quads cut at 3 sigma (faster), not at the 1/255 contour
    point_size: float = 2.0      # half-size in pixels of a point-cloud-mode dot
    lighting: Lighting | None = None  # the scene's lights, for items with a `lighting` left to draw


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
    alpha_uploads: int = 0       # of the uploads, opacity-only updates of the pos texture
    frame_bytes: int = 0         # this draw's bytes sent to the GPU
    frame_sort_cpu: float = 0.0  # frame_sort in the sorting thread's CPU time
    frame_sort: float = 0.0      # this draw's sort time on the drawing thread
    frame_upload: float = 0.0    # this draw's packing + texture uploads (data, order, table)


@dataclass
class _State:
    tokens: dict = field(default_factory=dict)  # texture name -> identities it was built from
    positions_token: tuple = ()
    radius_token: tuple = ()
    sorted_token: object = None
    sorted_radius_dependent: bool = False  # the last order culled by radius (see SortResult)
    layout: tuple = ()           # per object (name, splat count): what the order's indices index
    sorted_layout: tuple = ()    # the layout the uploaded order was made for
    pending_token: object = None
    objects_token: object = None


def _degree(item: RenderItem, display: ItemDisplay) -> int:
    """The SH degree drawn: the look's and the display's cap, and the data's (with a
    deferred morph, the higher of the two sets', as morph.blend pads the lower)."""
    morph = morph_of(item.deferred)
    data = item.splats.sh_degree if morph is None else max(item.splats.sh_degree, morph.target.sh_degree)
    return max(0, min(item.sh_degree, display.max_sh_degree, data))


def _cull_scales(item: RenderItem) -> tuple:
    """The scales that bound what the preprocess pass draws: the item's own (a deferred
    colour effect only shrinks them), and a deferred morph's target's (a lerp stays
    within the larger of its ends)."""
    morph = morph_of(item.deferred)
    return (item.splats.scales,) if morph is None else (item.splats.scales, morph.target.scales)


def _radius(scales: tuple) -> np.ndarray:
    return bounding_radius(scales[0] if len(scales) == 1 else np.maximum(*scales))


class ViewportRenderer:
    def __init__(self, worker: bool = False, on_sorted=None):
        self.gpu = None  # created on the first draw, inside a GPU context
        self.stats = Stats()
        self.state = _State()
        self.packs = PackCache()
        self.pos, self.shape = PosStage(), ShapeStage()
        self.last_valid, self.next_valid = {}, {}  # per object: the drawable mask last used
        self.effects = EffectTextures()
        self.worker = SortWorker(on_sorted) if worker else None
        self.layers: dict = {}  # per object: its deferred displace's noise layers last frame (weak)

    def close(self) -> None:
        if self.worker is not None:
            self.worker.stop()
            self.worker = None
        self.gpu = None
        self.state = _State()
        self.packs = PackCache()
        self.pos, self.shape = PosStage(), ShapeStage()
        self.effects = EffectTextures()
        self.last_valid, self.next_valid = {}, {}
        self.layers = {}

    # -- data ---------------------------------------------------------------
    def _texture(self, name, items, per_splat, fields, build, extra=()):
        """Upload texture `name` if any object's source fields changed; returns seconds
        spent. per_splat: values per splat of the stream."""
        start = time.perf_counter()
        got = [self.packs.get(name, i, tuple(getattr(i.splats, f) for f in fields), lambda i=i: build(i), extra,
                              key=data_key(i, fields)) for i in items]
        counts = [i.splats.count for i in items]
        if not upload_if_new(self.state.tokens, self.gpu, name, got, lambda: joined(got, counts, per_splat)):
            return 0.0
        self.stats.uploads += 1
        return time.perf_counter() - start

    def _upload_shape(self, items) -> float:
        """The shape texture, its rotation, scale and colour parts rewritten apart."""
        start = time.perf_counter()
        fields = ("rotations", "scales", "sh_dc")
        if not self.shape.update([tuple((data_key(i, (f,)), getattr(i.splats, f)) for f in fields)
                                  for i in items]):
            return 0.0
        self.gpu.set_texture("shape", self.shape.flat)
        self.stats.uploads += 1
        return time.perf_counter() - start

    def _upload_pos(self, items, valid) -> float:
        """The pos texture: kept when its sources are, its alpha channel alone rewritten
        when only opacities (or drawability) changed; returns seconds spent."""
        start = time.perf_counter()
        change = self.pos.update([(*pos_source(i), data_key(i, ("opacities",)), i.splats.opacities, v)
                                  for i, v in zip(items, valid)])
        if change == ALPHA and "pos" in self.gpu.textures:
            self.gpu.set_alpha("pos", self.pos.alpha)
            self.stats.alpha_uploads += 1
        elif change == ALL or (change == ALPHA and "pos" not in self.gpu.textures):
            self.gpu.set_texture("pos", self.pos.flat)
        else:
            return 0.0
        self.stats.uploads += 1
        return time.perf_counter() - start

    def _valid(self, item, degree) -> np.ndarray:
        """packing.drawable, a field at a time: each part is kept while its field is (a
        colour effect recomputes the SH DC test alone), and an unchanged result is the
        previous array itself, so the pos texture's alpha is not rewritten for it."""
        s = item.splats
        tests = (("rotations", packing.rotation_rows), ("scales", packing.finite_rows),
                 ("sh_dc", packing.finite_rows))
        parts = [self.packs.get(f"ok_{f}", item, (getattr(s, f),), lambda f=f, t=t: t(getattr(s, f)),
                                key=data_key(item, (f,)))[1] for f, t in tests]
        parts.append(self.packs.get("ok_sh_rest", item, (s.sh_rest,), lambda: packing.rest_rows(s, degree),
                                    extra=(degree,), key=data_key(item, ("sh_rest",)))[1])
        # the parts are this renderer's own arrays, never written: their identity is their value
        slot = data_key(item, ())
        valid = self.packs.get("valid", item, tuple(parts), lambda: np.logical_and.reduce(parts), key=slot)[1]
        last = self.last_valid.get(slot)
        if last is not None and last is not valid and np.array_equal(last, valid):
            valid = last
        self.next_valid[slot] = valid
        return valid

    def _update_data(self, items, displays) -> list:
        """Upload changed data textures; returns each item's positions (3, N) for sorting."""
        degrees = [_degree(i, d) for i, d in zip(items, displays)]
        values = max(packing.sh_values(g) for g in degrees)
        by_item = dict(zip(map(id, items), degrees))
        start = time.perf_counter()
        valid = [self._valid(i, g) for i, g in zip(items, degrees)]
        self.last_valid, self.next_valid = self.next_valid, {}
        seconds = time.perf_counter() - start
        seconds += self._upload_pos(items, valid)
        seconds += self._upload_shape(items)
        seconds += self._texture("sh", items, values, ("sh_rest",),
                                 lambda i: packing.pack_sh(i.splats, by_item[id(i)], values),
                                 extra=(tuple(degrees), values))
        uploads = self.effects.uploads
        seconds += self.effects.upload(items, degrees, values, self.gpu, self.packs)
        self.stats.uploads += self.effects.uploads - uploads
        self.gpu.sh_values = values
        # Filed under positions_key: a colour, opacity or scale effect changes item.key
        # every frame but not the centres, and must not cost a re-sort.
        # LazyArray: made by the sort that first needs them (the worker's, in the draw
        # handler's mode), so an effect moving or resizing splats costs the drawing thread
        # neither the centres' layout nor the radii.
        soa = [self.packs.get("centres", i, (i.splats.positions,),
                              lambda i=i: LazyArray(centres_layout, i.splats.positions), key=positions_key_of(i))
               for i in items]
        radii = [self.packs.get("radius", i, _cull_scales(i), lambda i=i: LazyArray(_radius, _cull_scales(i)),
                                key=data_key(i, ("scales",)))
                 for i in items]
        token = tuple(ident for ident, _ in soa)
        if token != self.state.positions_token:
            self.state.positions_token = token
        if self.state.sorted_layout != self.state.layout:
            self.state.sorted_token = None  # the old order is not for these splats: sort inline
        self.state.radius_token = tuple(ident for ident, _ in radii)
        self.stats.cpu_bytes = self.packs.end_frame() + self.pos.nbytes + self.shape.nbytes
        if seconds:
            self.stats.upload_seconds = seconds
            self.stats.frame_upload += seconds
        return [(a, r) for (_, a), (_, r) in zip(soa, radii)]

    # -- view ---------------------------------------------------------------
    def _sort_token(self, items, l2c, projection, displays):
        flat = np.concatenate([np.asarray(projection, np.float64).ravel()] + [m.ravel() for m in l2c])
        opts = tuple((d.cull, d.dilation, d.key_bits, d.splat_scale) for d in displays)
        scales = tuple(i.splat_scale for i in items)
        return (self.state.positions_token, opts + scales, flat, self.state.radius_token)

    def _same_view(self, a, b) -> bool:
        """Would the order made for token b serve token a? New radii only matter when
        the last order dropped splats by radius (growing splats may reach the view)."""
        if a is None or b is None or a[:2] != b[:2] or a[2].shape != b[2].shape:
            return False
        if self.state.sorted_radius_dependent and a[3] != b[3]:
            return False
        scale = max(1.0, float(np.abs(b[2]).max(initial=0.0)))
        return float(np.abs(a[2] - b[2]).max(initial=0.0)) <= RESORT_EPS * scale

    def _update_order(self, items, soa, displays, l2c, projection, near, far, settings) -> None:
        token = self._sort_token(items, l2c, projection, displays)
        if self.worker is not None:
            # An order made for earlier centres of the same splats is still a permutation
            # of them, and nearer the truth than the one drawn: while centres move every
            # frame (an effect playing), each finished order is drawn and the next requested.
            done = self.worker.take()
            if done is not None and done.layout == self.state.layout:
                self._upload_order(done)
        if self._same_view(token, self.state.sorted_token):
            return
        inputs = [SortInput(p, m, d.cull, d.dilation, i.splat_scale * d.splat_scale, r)
                  for (p, r), m, d, i in zip(soa, l2c, displays, items)]
        bits = max(d.key_bits for d in displays)
        have_order = self.state.sorted_token is not None
        if settings.sync_sort or self.worker is None or not have_order:
            result = visible_order(inputs, projection, near, far, bits)
            result.token, result.layout = token, self.state.layout
            self.stats.frame_sort += result.seconds
            self.stats.frame_sort_cpu += result.cpu_seconds
            self._upload_order(result)
        elif not self._same_view(token, self.state.pending_token):
            self.state.pending_token = token
            self.worker.request(token, inputs, projection, near, far, bits, self.state.layout)

    def _upload_order(self, result) -> None:
        start = time.perf_counter()
        self.gpu.set_order(result.order)
        self.stats.upload_seconds = time.perf_counter() - start
        self.stats.frame_upload += self.stats.upload_seconds
        self.stats.sort_seconds = result.seconds
        self.stats.drawn = int(result.order.size)
        self.stats.sorts += 1
        self.state.sorted_token, self.state.sorted_layout = result.token, result.layout
        self.state.sorted_radius_dependent = result.radius_dependent

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
        from .gpu_draw import SplatGPU

        self.stats.frame_sort = self.stats.frame_upload = self.stats.frame_sort_cpu = 0.0
        keep = [k for k, i in enumerate(items) if i.splats.count]
        if not keep:
            self.stats.total = self.stats.drawn = 0
            return None
        displays = [displays[k] for k in keep] if displays is not None else [ItemDisplay()] * len(keep)
        items = self._settled([items[k] for k in keep])
        if self.gpu is None:
            self.gpu = SplatGPU()
        uploaded = self.gpu.uploaded
        width, height = int(viewport_size[0]), int(viewport_size[1])
        const = packing.view_constants(projection_matrix, width, height, antialiased=settings.antialiased,
                               capped_extent=settings.capped_extent,
                               linear_output=settings.linear_output, point_size=settings.point_size)
        view = np.asarray(view_matrix, np.float64)
        l2c = [view @ thickened(i.world) for i in items]
        data, slots = shared_data(items)
        # what sorting needs is per instance (its order's indices); the rest is per data
        self.state.layout = tuple((i.key[0] if i.key else None, i.instance, i.splats.count) for i in items)
        soa = self._update_data([items[k] for k in data], [displays[k] for k in data])
        soa = [soa[s] for s in slots]
        self.stats.total = sum(i.splats.count for i in items)
        near, far = const["frame"][2], const["frame"][3]
        self._update_order(items, soa, displays, l2c, projection_matrix, near, far, settings)
        lights = light_rows(settings.lighting if any(i.lighting > 0 for i in items) else None, view)
        self._update_objects(items, displays, l2c, bool(const["flags"][0]), slots, lights)
        self.stats.gpu_bytes = self.gpu.nbytes
        self.stats.frame_bytes = self.gpu.uploaded - uploaded
        return const

    def _settled(self, items) -> list:
        """The items, a deferred displace whose noise layers were not those of the last frame
        left out: its centres are displaced in the item already (deferral.drawn_splats), and
        uploading them costs half of uploading two new layers, which pays only from the
        second frame that blends them (scrubbing within a layer, playing). So a jump
        across the timeline costs what it did before the displace was deferred."""
        seen, out = {}, []
        for item in items:
            d = displace_of(item.deferred)
            if d is not None:
                name = item.key[0] if item.key else None
                layers = displace_layers(d)
                # weak: last frame's layers, if the memo dropped them, go (their pages
                # are the next ones' to reuse)
                seen[name] = tuple(map(weakref.ref, layers))
                last = self.layers.get(name)
                if last is None or any(a is not b() for a, b in zip(layers, last)):
                    item = replace(item, deferred=tuple(e for e in item.deferred if e is not d))
            out.append(item)
        self.layers = seen
        return out

    def _update_objects(self, items, displays, l2c, ortho, slots, lights) -> None:
        rows, effects, first = [], [], 0
        # the light table follows the objects' rows, the effects' rows follow it
        texel = len(items) * packing.OBJECT_TEXELS + len(lights)
        data_first = data_firsts(items, slots)
        for item, d, m, slot in zip(items, displays, l2c, slots):
            starts = self.effects.field_starts[slot]
            morph = morph_of(item.deferred)
            colour = len(item.deferred) - (morph is not None)
            rows.append(packing.object_rows(m, item.splat_scale * d.splat_scale, item.opacity_scale,
                                            _degree(item, d), MODES[d.mode], d.sh_only, item.color_matrix,
                                            ortho, first, (texel, colour, reads_rest(item),
                                                           0.0 if morph is None else morph.amount),
                                            data_first[slot], item.lighting))
            effects.append(effect_rows(item.deferred, starts))
            texel += effects[-1].shape[0]
            first += item.splats.count
        table = np.concatenate(rows + [lights] + effects)
        if self.state.objects_token is not None and np.array_equal(self.state.objects_token, table):
            return  # still camera, same transforms: nothing to upload
        start = time.perf_counter()
        self.gpu.set_objects(table, len(rows))
        self.stats.frame_upload += time.perf_counter() - start
        self.state.objects_token = table
        self.stats.table_uploads += 1

