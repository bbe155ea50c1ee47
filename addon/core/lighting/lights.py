"""The scene's lights as plain, world-space parameters: what the Blender layer reads from
each visible light object at a frame, and all that shading and shadows need.

Units are Cycles': `power` in watts for point, spot and area lights, `strength` in W/m^2
for a sun; `color` is linear scene-referred RGB (Blender's light colour). Directions are
unit vectors in world space; `direction` is the way the light shines (the light object's
local -Z)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

KINDS = ("POINT", "SPOT", "SUN", "AREA")


@dataclass(frozen=True)
class Light:
    kind: str                          # one of KINDS
    position: tuple                    # (3,) world, metres (unused by SUN)
    direction: tuple                   # (3,) unit, world: where it shines (object -Z)
    color: tuple = (1.0, 1.0, 1.0)     # linear RGB
    power: float = 0.0                 # W: POINT, SPOT, AREA
    strength: float = 0.0              # W/m^2: SUN
    radius: float = 0.0                # POINT/SPOT soft radius, metres
    spot_size: float = np.pi / 4       # SPOT full cone angle, radians
    spot_blend: float = 0.15           # SPOT edge softness, 0..1
    size: tuple = (0.0, 0.0)           # AREA size x, y (metres)
    shape: str = "SQUARE"              # AREA shape
    angle: float = 0.0                 # SUN angular diameter, radians
    shadow: bool = True                # the light's "Cast Shadow"
    name: str = ""

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"light kind must be one of {KINDS}, got {self.kind!r}")

    @property
    def direction_array(self) -> np.ndarray:
        return np.asarray(self.direction, dtype=np.float64)

    @property
    def position_array(self) -> np.ndarray:
        return np.asarray(self.position, dtype=np.float64)
