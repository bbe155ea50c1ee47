"""Load the GLSL stages for the moderngl renderer from the shared shaders/ folder.

The splat math (shaders/splat_math.glsl) is written once and has no #version or
declarations, so the viewport can include it in Blender's gpu module too. Here each
stage is built as: #version, #defines, the math (when asked), the stage file.
shaders/ sits beside addon/ both in the repository and in the installed extension.
"""
from __future__ import annotations

import functools
import pathlib

MATH = "splat_math.glsl"
RECORD_WIDTH = 2048  # texels per row of the GL 3.3 fallback's record textures


def shader_dir() -> pathlib.Path:
    here = pathlib.Path(__file__).resolve()
    for root in (here.parents[2], here.parents[1]):  # <root>/addon/gl/shaders.py
        candidate = root / "shaders"
        if (candidate / MATH).is_file():
            return candidate
    raise FileNotFoundError(f"no shaders/{MATH} beside the add-on package ({here.parents[2]})")


@functools.lru_cache(maxsize=None)
def read(name: str) -> str:
    return (shader_dir() / name).read_text(encoding="utf-8")


def source(name: str, math: bool = True, defines: dict | None = None, includes=(),
           records: str = "ssbo") -> str:
    """Complete GLSL source of one stage file (after the math and any includes).

    records: how a stage reads the frame's splat records where it says #include_records:
    "ssbo" (GL 4.3 storage buffers, sorted on the GPU or CPU) or "texture" (GL 3.3
    fallback: textures already in back-to-front order)."""
    version = 430 if records == "ssbo" else 330
    lines = [f"#version {version}\n"]
    defines = dict(defines or {})
    if records == "texture":
        defines["RECORD_WIDTH"] = RECORD_WIDTH
    for key, value in defines.items():
        lines.append(f"#define {key} {value}\n")
    if math:
        lines.append(f"#line 1 1\n{read(MATH)}\n")
    for number, include in enumerate(includes, start=3):
        lines.append(f"#line 1 {number}\n{read(include)}\n")
    stage = read(name).replace("#include_records", read(f"gl_records_{records}.glsl"))
    lines.append(f"#line 1 2\n{stage}")
    return "".join(lines)
