"""Effect presets on Blender objects: apply one to a splat object, capture an object's stack
as a new preset, and where saved presets go. The format is core/effect_presets; the
operators (ops/effect_presets.py), the menus (ui/presets.py) and the command line use this."""
from __future__ import annotations

import contextlib
import pathlib

import bpy

from ...core import effect_presets as core
from .animation import action_fcurves, set_interpolation
from .pointcloud import read_positions
from .transforms import field_frame, world_matrix

USER_SUBDIR = "presets/splatline/effects"


def apply_preset(obj, preset: core.EffectPreset, frame: float, target=None) -> list:
    """Append the preset's effects to obj's stack and key them relative to frame.

    Returns the new effect items. An effect with a target field (a morph) takes `target`
    (another splat object).
    All or nothing: every problem raises core.PresetError naming the preset, before obj
    changes (the preset is first applied to a scratch object, see _rehearse).
    """
    if preset.needs_target and target is None:
        raise core.PresetError(f"{_name(preset)}: morphs, so select a second splat object "
                               "as the target")
    context = core.bounds_context(read_positions(obj.data), frame, _field(obj))
    _rehearse(preset, frame, target, context)
    return _apply_all(obj, preset, frame, target, context)


def _field(obj):
    """Where a preset's new effects measure their fields: without a gizmo, world-aligned
    axes at the object's origin (transforms.field_frame), at the current frame."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    return field_frame(world_matrix(obj, depsgraph))


# What a bad preset raises from bpy or resolve(): unknown or read-only property (AttributeError,
# ValueError), wrong type or enum value (TypeError), wrong vector length (ValueError), a
# property that can't be keyed (TypeError), an expression dividing by a zero size.
_PRESET_FAULTS = (AttributeError, KeyError, TypeError, ValueError, ZeroDivisionError, RuntimeError)


def _rehearse(preset, frame, target, context) -> None:
    """Apply the preset to a scratch object that no scene holds, so that a bad value
    anywhere in it fails here, before the user's object has half the preset: undoing a
    partial apply would mean restoring F-curves that may have held keys of their own."""
    scratch = bpy.data.objects.new("splatline preset check", None)
    try:
        _apply_all(scratch, preset, frame, target, context)
    except _PRESET_FAULTS as exc:
        raise core.PresetError(f"{_name(preset)}: {one_line(exc)}") from None
    finally:
        anim = scratch.animation_data
        action = anim.action if anim is not None else None
        bpy.data.objects.remove(scratch)
        if action is not None and action.users == 0:
            bpy.data.actions.remove(action)


def _name(preset) -> str:
    return f"effect preset {preset.name!r}"


def one_line(exc) -> str:
    """A bpy or preset error as one line, without bpy's prefix."""
    text = str(exc.args[0]) if isinstance(exc, KeyError) and exc.args else str(exc)
    return " ".join(text.replace("bpy_struct: item.attr = val: ", "").split())


def _apply_all(obj, preset, frame, target, context) -> list:
    added = []
    if preset.look is not None:
        _apply_block(obj, obj.splatline.look, "splatline.look", preset.look, frame, context)
    for block in preset.effects:
        effect = obj.splatline.effects.add()
        index = len(obj.splatline.effects) - 1
        with _where(f"effects[{index}].type"):
            effect.type = block.type
        if block.target_field:
            setattr(effect, block.target_field, target)
        _apply_block(obj, effect, f"splatline.effects[{index}]", block, frame, context)
        added.append(effect)
    obj.splatline.active_effect = len(obj.splatline.effects) - 1
    return added


def _apply_block(obj, group, path, block: core.Block, frame, context):
    for prop, value in block.set.items():
        with _where(f"{path}.{prop}"):
            _assign(group, prop, core.resolve(value, context))
    for prop, points in block.keys.items():
        for offset, value in points:
            with _where(f"{path}.{prop}"):
                _assign(group, prop, core.resolve(value, context))
                obj.keyframe_insert(data_path=f"{path}.{prop}", frame=frame + offset)
        set_interpolation(obj, block.interpolation, f"{path}.{prop}")


@contextlib.contextmanager
def _where(path):
    """Prefix an error with the property it came from (the preset's own words)."""
    try:
        yield
    except core.PresetError:
        raise
    except _PRESET_FAULTS as exc:
        raise core.PresetError(f"{path.removeprefix('splatline.')}: {one_line(exc)}") from None


def _assign(group, prop, value):
    if not hasattr(group, prop):
        raise ValueError(f"{type(group).__name__} has no property {prop!r}")
    setattr(group, prop, value)


def user_dir() -> pathlib.Path:
    """Where saved effect presets go: Blender's user scripts folder (moved, as all of
    Blender's user presets are, by the BLENDER_USER_SCRIPTS environment variable)."""
    folder = bpy.utils.user_resource("SCRIPTS", path=USER_SUBDIR, create=True)
    if not folder:  # Blender gives "" when it cannot create it: never write to the cwd
        raise OSError(f"cannot create the user preset folder {USER_SUBDIR}")
    return pathlib.Path(folder)


def capture_preset(obj, frame: float, label: str) -> dict:
    """The object's effect stack and its keyframes, as preset JSON relative to frame."""
    effects = []
    for index, effect in enumerate(obj.splatline.effects):
        fields = _effect_fields(effect)
        keys = _keys_for(obj, f"splatline.effects[{index}].", frame)
        effects.append({"type": effect.type,
                        "set": {k: v for k, v in fields.items() if k not in keys},
                        "keys": keys})
    return {"label": label, "description": f"Saved from {obj.name}", "effects": effects}


def _effect_fields(effect) -> dict:
    out = {}
    for prop in effect.bl_rna.properties:
        name = prop.identifier
        if name in {"rna_type", "name", "type", "gizmo", "target"} or prop.type == "POINTER":
            continue
        value = getattr(effect, name)
        out[name] = list(value) if hasattr(value, "__len__") and not isinstance(value, str) else value
    return out


def _keys_for(obj, prefix, frame) -> dict:
    """{prop: [[offset, value], ...]} for the keyed properties under prefix; vector
    properties are merged across their array indices (keys on the same frames)."""
    by_prop: dict[str, dict[float, dict[int, float]]] = {}
    for curve in action_fcurves(obj):
        prop = curve.data_path[len(prefix):]
        if not curve.data_path.startswith(prefix) or "[" in prop or "." in prop:
            continue
        for point in curve.keyframe_points:
            by_prop.setdefault(prop, {}).setdefault(point.co[0], {})[curve.array_index] = point.co[1]
    keys = {}
    for prop, frames in by_prop.items():
        keys[prop] = []
        for key_frame in sorted(frames):
            parts = frames[key_frame]
            value = parts[0] if len(parts) == 1 else [parts[i] for i in sorted(parts)]
            keys[prop].append([key_frame - frame, value])
    return keys


def label(path) -> str:
    """A preset file's label for a menu; a file that does not load says so."""
    try:
        return core.load(path).label
    except core.PresetError:
        return path.stem + " (invalid)"
