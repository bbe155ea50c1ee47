"""The repository paths the docs name, and where each one should be: one rule for
tests/project/test_docs_paths.py (every page) and tests/core/test_render_stages.py (the
stage table). A doc names a path in backticks, from the repository root (`tests/...`,
`shaders/...`, `bench/...`), from addon/ (`core/...`, `gl/...`, `blender/...`, `cli/...`) or
from addon/blender/ (`viewport/...`, `evaluate/...`, ...), and a module may be followed by
one of its names (`core/effects/common.for_blocks`, `render/film.result_rect`)."""
from __future__ import annotations

import pathlib
import re

from testing.paths import REPO

ROOTS = ("addon", "shaders", "tests", "bench", "testing", "presets", "docs", ".ci", "requirements", "farm")
# a path's first folder -> the folder it is relative to, for paths written without addon/
SHORT = {"core": "addon", "gl": "addon", "blender": "addon", "cli": "addon",
         "formats": "addon/core", "effects": "addon/core",
         **{p: "addon/blender" for p in ("data", "evaluate", "ops", "props", "ui", "viewport", "render")}}


def named_paths(text: str) -> list[str]:
    """Every backticked path of a Markdown text outside fenced blocks: one word with a
    slash, starting at a folder of ROOTS or SHORT; placeholders (`<name>`, `*`) left out."""
    text = re.sub(r"^```.*?^```", "", text, flags=re.S | re.M)
    return [span for span in re.findall(r"`([^`\s]+/[^`\s]*)`", text)
            if not re.search(r"[<>*{]", span) and span.split("/")[0] in (*ROOTS, *SHORT)]


def resolve(name: str) -> pathlib.Path:
    """The file or folder `name` stands for (it may not exist)."""
    top = name.split("/")[0]
    return REPO / name if top in ROOTS else REPO / SHORT[top] / name


def problem(name: str) -> str | None:
    """Why `name` names nothing in the repository, or None when it does: a file or folder,
    a module without its .py, or a module's name (def, class or assignment)."""
    path = resolve(name)
    if path.exists() or path.with_name(path.name + ".py").is_file():
        return None
    module, _, attr = path.name.partition(".")
    source = path.with_name(module + ".py")
    if not attr or not source.is_file():
        return f"no such file or folder: {path.relative_to(REPO)}"
    pattern = rf"^\s*(def|class)\s+{re.escape(attr)}\b|^{re.escape(attr)}\s*[:=]"
    if not re.search(pattern, source.read_text(encoding="utf-8"), re.M):
        return f"{source.relative_to(REPO)} defines no {attr}"
    return None
