"""The textures of the effects the preprocess pass applies itself (effect_rows.py): a
morph's target, noise fields' values, a displace's noise layers, the rest centres. Each is
uploaded when its sources change (the target's arrays, the core's memoized noise: once
while scrubbing, or once a layer for a displace; the base's centres) and dropped when no
object needs it (no bpy; the gpu object is handed in)."""
from __future__ import annotations

import time

import numpy as np

from ...core.effects import noise
from ...core.effects.kind import COLOUR_PROGRAMS
from ...core.scene import RenderItem
from . import packing
from .effect_rows import displace_layers, displace_of, is_noise, morph_of
from .pack_cache import joined, reads_rest, upload_if_new


class EffectTextures:
    def __init__(self):
        self.tokens: dict = {}   # texture name -> identities it was built from
        self.field_starts = []   # per object: its noise effects' first texels (fields)
        self.uploads = 0

    def upload(self, items, degrees, values, gpu, packs) -> float:
        """Upload what changed; returns the seconds spent."""
        return (self._morph(items, degrees, values, gpu, packs) + self._fields(items, gpu, packs)
                + self._displace(items, gpu, packs) + self._rest(items, gpu, packs))

    def _drop(self, gpu, name: str) -> None:
        gpu.drop(name)
        self.tokens.pop(name, None)

    def _put(self, gpu, name: str, got: list, flat) -> float:
        """upload_if_new, counted; returns the seconds spent."""
        start = time.perf_counter()
        if not upload_if_new(self.tokens, gpu, name, got, flat):
            return 0.0
        self.uploads += 1
        return time.perf_counter() - start

    def _morph(self, items, degrees, values, gpu, packs) -> float:
        """A deferred morph's target data, in the pos, shape and sh layouts, and its centres
        (uploaded once: the target's arrays are the same every frame); zeros for objects
        without one."""
        targets = [morph_of(i.deferred) for i in items]
        if all(t is None for t in targets):
            for name in packing.MORPH:
                self._drop(gpu, name)
            return 0.0
        counts = [i.splats.count for i in items]
        builds = {
            "morph_pos": (4, lambda t, g, q: packing.pack_morph_target(q, t.target, g)),
            "morph_shape": (packing.SHAPE_VALUES, lambda t, g, q: packing.pack_shape(t.target)),
            "morph_sh": (values, lambda t, g, q: packing.pack_sh(t.target, g, values)),
            "morph_centres": (4, lambda t, g, q: packing.pack_xyz(t.target.positions, t.target.count))}
        seconds = 0.0
        for name, (per_splat, build) in builds.items():
            got = [packs.get(name, i, _morph_sources(t) + (i.splats.rotations,), extra=(g, values),
                             key=i.base_key,
                             build=lambda i=i, t=t, g=g, b=build, k=per_splat:
                             packing.stream(i.splats.count * k) if t is None else b(t, g, i.splats.rotations))
                   for i, t, g in zip(items, targets, degrees)]
            seconds += self._put(gpu, name, got, lambda got=got, k=per_splat: joined(got, counts, k))
        return seconds

    def _fields(self, items, gpu, packs) -> float:
        """Deferred noise effects' values: the core's memoized noise at the rest centres
        (noise.field_rows: the same array while memoized, so uploaded once), a segment per
        object and effect; self.field_starts: each object's segments' first texels."""
        got, self.field_starts, texel = [], [], 0
        for i in items:
            starts = []
            for d in i.deferred:
                if d.program in COLOUR_PROGRAMS and is_noise(d.params):
                    rows = noise_rows(i, d.params)
                    got.append(packs.get("fields", i, (rows,), lambda rows=rows: rows.reshape(-1),
                                         key=i.base_key))
                    starts.append(texel)
                    texel += i.splats.count
            self.field_starts.append(starts)
        if not got:
            self._drop(gpu, "fields")
            return 0.0

        def flat():
            out = np.zeros(packing.padded(texel), np.float32)
            np.concatenate([values for _, values in got], out=out[:texel])
            return out

        return self._put(gpu, "fields", got, flat)

    def _displace(self, items, gpu, packs) -> float:
        """A deferred displace's two noise layers (the core's memoized rows at the rest
        centres, the same arrays until the layer changes), a texel a splat in each of
        displace_a and displace_b; zeros for objects without one."""
        deferred = [displace_of(i.deferred) for i in items]
        layers = [None if d is None else displace_layers(d) for d in deferred]
        if all(pair is None for pair in layers):
            for name in packing.DISPLACE:
                self._drop(gpu, name)
            return 0.0
        counts = [i.splats.count for i in items]
        seconds = 0.0
        for slot, name in enumerate(packing.DISPLACE):
            rows = [None if pair is None else pair[slot] for pair in layers]
            got = [packs.get(name, i, (r,), lambda i=i, r=r: packing.pack_xyz(r, i.splats.count),
                             key=i.base_key) for i, r in zip(items, rows)]
            seconds += self._put(gpu, name, got, lambda got=got: joined(got, counts, 4))
        return seconds

    def _rest(self, items, gpu, packs) -> float:
        """The effects' input centres, for deferred effects measured there while others
        move the splats (the base's positions: uploaded once, not per frame)."""
        reads = [reads_rest(i) for i in items]
        if not any(reads):
            self._drop(gpu, "rest")
            return 0.0
        got = [packs.get("rest", i, (i.rest_positions if r else None,),
                         lambda i=i, r=r: packing.pack_xyz(i.rest_positions if r else None, i.splats.count),
                         key=i.base_key) for i, r in zip(items, reads)]
        return self._put(gpu, "rest", got, lambda: joined(got, [i.splats.count for i in items], 4))


def noise_rows(item: RenderItem, params) -> np.ndarray:
    """The memoized noise a deferred effect's field reads: at the stack's input centres
    while the count is theirs, else at the drawn ones (as deferral.apply_deferred)."""
    rest = item.rest_positions
    positions = rest if rest is not None and rest.shape[0] == item.splats.count else item.splats.positions
    return noise.field_rows(positions, params.frame, params.frequency, params.seed)


def _morph_sources(params) -> tuple:
    t = None if params is None else params.target
    return (None,) if t is None else (t.positions, t.opacities, t.rotations, t.scales, t.sh_dc, t.sh_rest)
