"""What every splat reader promises, checked on what it returns or raises: finite values, unit
quaternions, positive scales, opacities in 0..1; or a SplatFormatError naming the file."""
from __future__ import annotations

import numpy as np
import pytest

from addon.core.errors import SplatFormatError
from addon.core.formats import read

# Every fuzz seed holds 64 splats: a mutated count past this is refused cheaply.
FUZZ_BUDGET = 200_000


def fails(path, *words, **opts):
    with pytest.raises(SplatFormatError) as info:
        read(path, **opts)
    msg = str(info.value).lower()
    assert str(path).lower() in msg, msg
    for w in words:
        assert w in msg, msg
    return msg


def check_promises(s) -> None:
    for name in ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest"):
        assert np.isfinite(getattr(s, name)).all(), f"non-finite {name}"
    norm = np.linalg.norm(s.rotations.astype(np.float64), axis=1)
    assert (np.abs(norm - 1.0) < 1e-6).all(), f"|q| {norm[np.abs(norm - 1) >= 1e-6][:3]}"
    assert (s.scales > 0).all(), "non-positive scale"
    assert ((s.opacities >= 0) & (s.opacities <= 1)).all(), "opacity outside 0..1"
