"""F-curves and drivers of a datablock, on every Blender Splatline supports.

Blender 4.4 made actions layered: an action's F-curves live in channel bags, one per slot,
inside the strips of its layers (`is_action_layered`); an older action holds them in
`action.fcurves` (gone in 5.0). Drivers stay on `animation_data.drivers`. Every reader and
writer of keys in the add-on goes through here, so that difference is handled once.
"""
from __future__ import annotations


def action_fcurves(owner) -> list:
    """The F-curves of owner's action for owner's slot ([] without an action)."""
    anim = getattr(owner, "animation_data", None)
    action = anim.action if anim is not None else None
    if action is None:
        return []
    if not getattr(action, "is_action_layered", False):
        return list(getattr(action, "fcurves", ()))
    curves = []
    for bag in _channelbags(anim):
        curves.extend(bag.fcurves)
    return curves


def channel_fcurves(owner) -> list:
    """Every F-curve that animates owner: its drivers and its action's curves."""
    anim = getattr(owner, "animation_data", None)
    if anim is None:
        return []
    return list(anim.drivers) + action_fcurves(owner)


def remove_fcurve(owner, curve) -> None:
    """Delete one of channel_fcurves(owner) (a driver or an action curve)."""
    anim = owner.animation_data
    if curve in list(anim.drivers):
        anim.drivers.remove(curve)
        return
    if not getattr(anim.action, "is_action_layered", False):
        anim.action.fcurves.remove(curve)
        return
    for bag in _channelbags(anim):
        if curve in list(bag.fcurves):
            bag.fcurves.remove(curve)
            return


def set_interpolation(owner, interpolation: str, data_path: str | None = None,
                      frame: int | None = None) -> None:
    """Set the interpolation of owner's keys: of the curves at data_path (None: every
    curve), at `frame` (None: every key)."""
    for curve in action_fcurves(owner):
        if data_path is not None and curve.data_path != data_path:
            continue
        for point in curve.keyframe_points:
            if frame is None or int(round(point.co[0])) == frame:
                point.interpolation = interpolation


def _channelbags(anim):
    if not anim.action_slot:
        return
    for layer in anim.action.layers:
        for strip in layer.strips:
            bag = strip.channelbag(anim.action_slot)
            if bag is not None:
                yield bag
