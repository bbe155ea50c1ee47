"""Look > Lighting on the Blender side (issue 43): the scene's lights, World colour and camera
read into core parameters (core/lighting), and each drawn item lit at its own place.

Read per frame from the depsgraph, so moving lights and keyed light properties animate and a
frame stays a function of the scene at that frame. The last lit results are kept by a
signature of everything they depend on (the item's key, its world matrix, the lights, World,
camera, meshes and amount): a frame rendered again (F12 twice, a still capture's frames under
still lights) is not relit. Blender 5.3's own engines are handed the unlit splats
(native_handoff uses item_for). The viewport lights in its shader instead (items leave
`lighting` to it, and it is handed lighting_for's lights), without shadows."""
from __future__ import annotations

import hashlib
from collections import OrderedDict
from dataclasses import replace

import numpy as np

from ...core.lighting import shadows
from ...core.lighting.lights import Light
from ...core.lighting.normals import splat_normals
from ...core.lighting.shade import Lighting, lit_splats
from ...core.scene import RenderItem
from ..data.world import world_background
from .holdout_geometry import holdout_for

_LIT: OrderedDict = OrderedDict()   # signature -> lit RenderItem, the last few
_KEEP = 4
_KEEP_BYTES = 1 << 29   # a lit copy holds its colours: 192 MB at 1M, degree 3
_NORMALS: OrderedDict = OrderedDict()   # item, place and camera -> (centres, normals)
_KEEP_NORMALS = 4   # 48 bytes a splat each


def amount(obj_eval) -> float:
    """The object's Look > Lighting at the depsgraph's frame (0 for objects without settings)."""
    look = getattr(getattr(obj_eval, "splatline", None), "look", None)
    return float(getattr(look, "lighting", 0.0))


def scene_lighting(depsgraph) -> Lighting:
    """The lights the depsgraph shows (objects and instances), the World's uniform colour and
    the scene camera's position (the side of each splat that shows; none: both sides)."""
    lights = tuple(_light(inst.object, np.array(inst.matrix_world, np.float64))
                   for inst in depsgraph.object_instances
                   if inst.object.type == "LIGHT" and inst.show_self)
    scene = depsgraph.scene_eval
    camera = scene.camera
    eye = None if camera is None else tuple(float(v) for v in camera.matrix_world.translation)
    return Lighting(tuple(light for light in lights if light is not None),
                    world_background(scene.world), eye)


def lighting_for(items, depsgraph) -> Lighting | None:
    """The scene's lighting where some item leaves its Look > Lighting to the renderer (the
    viewport's items), else None: nothing to read."""
    return scene_lighting(depsgraph) if any(item.lighting > 0 for item in items) else None


def _light(obj, matrix) -> Light | None:
    data = obj.data
    if data.type not in ("POINT", "SPOT", "SUN", "AREA"):
        return None
    shines = -matrix[:3, 2]
    length = float(np.linalg.norm(shines))
    if not length > 1e-12:  # scaled to 0 along its axis: a point light needs no direction,
        if data.type != "POINT":  # the others have none to shine in
            return None
        shines, length = np.array([0.0, 0.0, -1.0]), 1.0
    shines = shines / length
    colour = tuple(float(c) for c in data.color)
    common = dict(position=tuple(matrix[:3, 3]), direction=tuple(shines), color=colour,
                  shadow=bool(getattr(data, "use_shadow", True)), name=obj.name_full)
    if data.type == "SUN":
        return Light("SUN", strength=float(data.energy), angle=float(data.angle), **common)
    if data.type == "AREA":
        return Light("AREA", power=float(data.energy), size=(float(data.size), float(data.size_y)),
                     shape=data.shape, **common)
    spot = dict(spot_size=float(data.spot_size), spot_blend=float(data.spot_blend)) if data.type == "SPOT" else {}
    return Light(data.type, power=float(data.energy), radius=float(data.shadow_soft_size), **spot, **common)


def lit_item(item: RenderItem, lighting: Lighting, level: float, depsgraph) -> RenderItem:
    """The item lit at its world matrix, or the item itself at Lighting 0."""
    if level <= 0.0 or item.splats.count == 0:
        return item
    holdout = holdout_for(depsgraph)
    signature = _signature(item, lighting, level, holdout)
    hit = _LIT.get(signature)
    if hit is not None:
        _LIT.move_to_end(signature)
        return hit
    points, normals = _normals(item, lighting.eye)
    triangles = None if holdout is None else holdout.triangles
    visibility = [shadows.light_visibility(points, light, triangles, item.splats, item.world)
                  for light in lighting.lights]
    splats = lit_splats(item.splats, item.world, lighting, level, visibility, points, normals)
    lit = replace(item, splats=splats, key=(*item.key, ("lit", signature)),
                  base_fields=item.base_fields - {"sh_dc", "sh_rest"})
    _LIT[signature] = lit
    while len(_LIT) > 1 and (len(_LIT) > _KEEP or sum(map(_colour_bytes, _LIT.values())) > _KEEP_BYTES):
        _LIT.popitem(last=False)
    return lit


def _colour_bytes(item: RenderItem) -> int:
    """What a lit item holds of its own: its colours (the rest is the unlit item's)."""
    return item.splats.sh_dc.nbytes + item.splats.sh_rest.nbytes


def _normals(item: RenderItem, eye) -> tuple:
    """The item's world-space centres and normals, kept while only the lights change (frames
    of a moving light over a still capture are not recomputed)."""
    signature = _digest(item, (item.key, item.instance, eye))
    hit = _NORMALS.get(signature)
    if hit is None:
        hit = _NORMALS[signature] = splat_normals(item.splats, item.world, eye)
        while len(_NORMALS) > _KEEP_NORMALS:
            _NORMALS.popitem(last=False)
    _NORMALS.move_to_end(signature)
    return hit


def _signature(item, lighting, level, holdout) -> str:
    return _digest(item, (item.key, item.instance, lighting, level, None if holdout is None else holdout.key))


def _digest(item, parts) -> str:
    """A key of `parts` (their repr) and the item's world matrix (its exact bytes)."""
    h = hashlib.blake2b(digest_size=16)
    h.update(repr(parts).encode())
    h.update(np.asarray(item.world, np.float64).tobytes())
    return h.hexdigest()


def clear() -> None:
    _LIT.clear()
    _NORMALS.clear()
