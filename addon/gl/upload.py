"""Stage "upload": per-object splat data in GPU storage buffers, cached by RenderItem.key.

Unchanged data (same key) is not uploaded again; a transform, opacity or colour change
is only uniforms. SH bands are uploaded only up to the degree actually rendered (none at
degree 0) and re-uploaded only when a higher degree is asked for. An object larger than
one storage block is split into parts that are preprocessed one after another.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.scene import RenderItem
from ..core.splats import sh_coeff_count

GEOM_FLOATS = 16  # position + opacity, scale + pad, quaternion wxyz, SH DC + pad
REST_GROUP = 4  # SH coefficients per 3 vec4 of the rest buffer (gl_preprocess.comp)


@dataclass
class Part:
    start: int
    count: int
    geom: object            # moderngl.Buffer
    rest: object | None = None


@dataclass
class GpuObject:
    key: tuple | None
    count: int
    data_degree: int
    parts: list = field(default_factory=list)
    rest_coeffs: int = 0     # coefficients per channel in each part's rest buffer

    def release(self):
        for part in self.parts:
            for buf in (part.geom, part.rest):
                if buf is not None:
                    buf.release()
        self.parts = []


def pack_geometry(item: RenderItem, start: int, stop: int) -> np.ndarray:
    sp = item.splats
    g = np.zeros((stop - start, GEOM_FLOATS), np.float32)
    g[:, 0:3] = sp.positions[start:stop]
    g[:, 3] = sp.opacities[start:stop]
    g[:, 4:7] = sp.scales[start:stop]
    g[:, 8:12] = sp.rotations[start:stop]
    g[:, 12:15] = sp.sh_dc[start:stop]
    return g


def rest_groups(coeffs: int) -> int:
    return -(-coeffs // REST_GROUP)


def pack_rest(rest: np.ndarray, coeffs: int) -> np.ndarray:
    """(n, coeffs, 3) SH coefficients as whole groups of four (rgb rgb rgb rgb = 3 vec4),
    the last group zero-padded, so gl_preprocess.comp reads them in vec4 loads: on
    llvmpipe each scalar load is its own per-lane gather, and at degree 2 the 24 of them
    took a quarter of the preprocess."""
    out = np.zeros((len(rest), rest_groups(coeffs) * REST_GROUP * 3), np.float32)
    out[:, :coeffs * 3] = rest[:, :coeffs].reshape(len(rest), coeffs * 3)
    return out


class UploadCache:
    """Owns the per-object buffers; call only on the GL thread."""

    def __init__(self, ctx, stats: dict):
        self.ctx = ctx
        self.stats = stats
        self.objects: dict = {}
        self.transient: list = []  # key None: uploaded for one frame, freed at the next
        # a block may not exceed this; 192 bytes/splat (degree-3 SH, padded) sets the part size
        self.max_block = int(ctx.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE") or (1 << 27))

    def _part_size(self) -> int:
        return max(1, self.max_block // (4 * 3 * REST_GROUP * rest_groups(15)))

    def _buffer(self, array: np.ndarray):
        data = np.ascontiguousarray(array, np.float32)
        self.stats["bytes_uploaded"] += data.nbytes
        # zero-size buffers are not allowed: keep one dummy float
        return self.ctx.buffer(data.tobytes() if data.nbytes else b"\0\0\0\0")

    def _upload_geometry(self, item: RenderItem) -> GpuObject:
        sp = item.splats
        obj = GpuObject(item.key, sp.count, sp.sh_degree)
        step = self._part_size()
        for start in range(0, sp.count, step):
            stop = min(start + step, sp.count)
            obj.parts.append(Part(start, stop - start, self._buffer(pack_geometry(item, start, stop))))
        self.stats["geometry_uploads"] += 1
        return obj

    def _upload_rest(self, obj: GpuObject, item: RenderItem, degree: int):
        coeffs = sh_coeff_count(degree)
        for part in obj.parts:
            if part.rest is not None:
                part.rest.release()
            rest = item.splats.sh_rest[part.start:part.start + part.count]
            part.rest = self._buffer(pack_rest(rest, coeffs))
        obj.rest_coeffs = coeffs
        self.stats["sh_uploads"] += 1

    def get(self, item: RenderItem) -> GpuObject:
        """The GPU copy of item's splats, uploading only what is missing."""
        sp = item.splats
        obj = self.objects.get(item.key) if item.key is not None else None
        if obj is not None and (obj.count != sp.count or obj.data_degree != sp.sh_degree):
            obj.release()
            obj = None
        if obj is None:
            obj = self._upload_geometry(item)
            if item.key is not None:
                self.objects[item.key] = obj
            else:
                self.transient.append(obj)
        degree = item.effective_sh_degree
        if degree > 0 and obj.rest_coeffs < sh_coeff_count(degree):
            self._upload_rest(obj, item, degree)
        return obj

    @property
    def resident(self) -> int:
        """Objects whose buffers are alive on the GPU now."""
        return len(self.objects) + len(self.transient)

    def begin_frame(self):
        """Free the uncached (key None) objects of the previous frame."""
        for obj in self.transient:
            obj.release()
        self.transient = []

    def retain(self, keys: set):
        """Free the objects not drawn this frame."""
        for key in [k for k in self.objects if k not in keys]:
            self.objects.pop(key).release()

    def release(self):
        self.begin_frame()
        for obj in self.objects.values():
            obj.release()
        self.objects.clear()
