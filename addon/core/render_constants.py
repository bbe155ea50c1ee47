"""The numbers every renderer agrees on: the reference (core/preprocess.py,
core/reference.py), the moderngl renderer (gl/) and the viewport (blender/viewport/).

Where a shader needs one, its GLSL twin is a `const float SL_...` in shaders/ holding the
same value; tests/core/test_render_stages.py reads the shader sources and compares each
literal with the value here, so changing one without the other fails.
"""
from __future__ import annotations

LOW_PASS = 0.3            # px^2 added to the 2D covariance's diagonal (SL_LOWPASS)
ALPHA_MIN = 1.0 / 255.0   # a fragment with less alpha is dropped (SL_ALPHA_MIN)
MAX_ALPHA = 0.99          # INRIA's cap on a fragment's alpha (SL_ALPHA_MAX)
T_STOP = 1e-4             # INRIA's early-termination threshold on transmittance (SL_T_STOP)
J_CLAMP_MARGIN = 0.15     # fraction of the frame beyond each edge (INRIA's 1.3 tan(fov/2));
                          # the shaders get the bounds it gives as a uniform (j_clamp_bounds)
DEPTH_FROM_ALPHA = 0.5    # a pixel has a depth where its splats' alpha reaches this; the
                          # Z pass is resolved on the CPU, so no shader holds it

# name here -> its GLSL twin's name (the test's table)
GLSL_TWINS = {"LOW_PASS": "SL_LOWPASS", "ALPHA_MIN": "SL_ALPHA_MIN",
              "MAX_ALPHA": "SL_ALPHA_MAX", "T_STOP": "SL_T_STOP"}
