"""Blender effect items -> core effect parameters, at one frame of one depsgraph.

Gizmo frames: an Empty's matrix relative to the splat object; without one, world-aligned
axes at the object's origin (so a plane's 'height' is world Z and units are world units).
Morph targets are the target object's base splats mapped into the source object's space.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ...core import effects as fx
from ..data.transforms import evaluated, field_frame, relative_to, world_matrix

POSITION_TYPES = {"DISPLACE", "EXPLODE", "TWIST", "MORPH"}
TIME_TYPES = {"DISPLACE", "EXPLODE"}  # the others depend on time only through keyframes


def gizmo_frame(effect, world: np.ndarray, depsgraph) -> np.ndarray:
    gizmo = world_matrix(effect.gizmo, depsgraph) if effect.gizmo is not None else None
    return field_frame(world, gizmo)


def _stops(effect):
    stops = [(0.0, tuple(effect.color_a)), (1.0, tuple(effect.color_b))]
    if effect.use_color_mid:
        stops.insert(1, (float(effect.mid_position), tuple(effect.color_mid)))
    return tuple(stops)


def build(effect, frame: np.ndarray, fps: float, morph_target=None):
    """Core params for one enabled effect item (morph_target: (SplatSet, Pairing) or None)."""
    common = dict(enabled=bool(effect.enabled), amount=float(effect.amount), frame=frame)
    kind = effect.type
    if kind == "REVEAL":
        return fx.Reveal(**common, shape=effect.reveal_shape, progress=effect.progress,
                         width=effect.edge_width, invert=effect.invert, shrink=effect.shrink,
                         glow_color=tuple(effect.glow_color), glow_strength=effect.glow_strength,
                         frequency=effect.frequency, seed=effect.seed)
    if kind == "DISPLACE":
        return fx.Displace(**common, amplitude=effect.amplitude, frequency=effect.frequency,
                           speed=effect.speed, seed=effect.seed)
    if kind == "EXPLODE":
        return fx.Explode(**common, mode=effect.explode_mode, strength=effect.strength,
                          spread=effect.spread, spin=effect.spin, gravity=effect.gravity,
                          start=effect.start_frame / fps, fade=effect.fade, seed=effect.seed)
    if kind == "TWIST":
        return fx.Twist(**common, twist=effect.twist, swirl=effect.swirl, radius=effect.swirl_radius)
    if kind == "GRADE":
        return fx.Grade(**common, field=effect.grade_field, stops=_stops(effect),
                        low=effect.range_low, high=effect.range_high, mode=effect.grade_mode,
                        frequency=effect.frequency, seed=effect.seed)
    if kind == "MORPH":
        target, pairing = morph_target if morph_target is not None else (None, None)
        return fx.Morph(**common, target=target, pairing=pairing)
    raise ValueError(f"unknown effect type {kind!r}")


def signature(params, extra=()) -> tuple:
    """Everything an effect's output depends on besides the input splats and time: the
    fields of the core parameters the kernel reads (not the panel's property list, which
    can miss a derived value such as Explode's start in seconds = start frame / fps).
    A morph's target and pairing are identified by `extra` (target key, relative matrix)."""
    values = [type(params).__name__]
    for spec in dataclasses.fields(params):
        if spec.name in ("target", "pairing"):
            continue
        value = getattr(params, spec.name)
        values.append(value.tobytes() if isinstance(value, np.ndarray) else value)
    return tuple(values) + tuple(extra)
