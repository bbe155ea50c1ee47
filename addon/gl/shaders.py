"""Load the GLSL stages for the moderngl renderer from the shared shaders/ folder.

The splat math (shaders/splat_math.glsl) is written once and has no #version or
declarations, so the viewport can include it in Blender's gpu module too. Here each
stage is built as: #version, #defines, the math (when asked), the stage file.
shaders/ sits beside addon/ both in the repository and in the installed extension.
"""
from __future__ import annotations

import functools
import pathlib

VERSION = "#version 430\n"
MATH = "splat_math.glsl"


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


def source(name: str, math: bool = True, defines: dict | None = None, includes=()) -> str:
    """Complete GLSL source of one stage file (after the math and any includes)."""
    lines = [VERSION]
    for key, value in (defines or {}).items():
        lines.append(f"#define {key} {value}\n")
    if math:
        lines.append(f"#line 1 1\n{read(MATH)}\n")
    for number, include in enumerate(includes, start=3):
        lines.append(f"#line 1 {number}\n{read(include)}\n")
    lines.append(f"#line 1 2\n{read(name)}")
    return "".join(lines)
