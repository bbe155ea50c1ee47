"""Every repository path the docs name exists (testing/doc_paths.py says how a doc names
one), so a moved or renamed file fails here until the docs follow it. The paths in
ARCHITECTURE.md's stage table go through the same rule in tests/core/test_render_stages.py,
which checks that table's own shape."""
from __future__ import annotations

import pytest

from testing import doc_paths
from testing.paths import REPO

PAGES = ["README.md", *sorted(p.relative_to(REPO).as_posix() for p in (REPO / "docs").glob("*.md"))]


@pytest.mark.parametrize("page", PAGES)
def test_paths_the_page_names_exist(page):
    names = doc_paths.named_paths((REPO / page).read_text(encoding="utf-8"))
    problems = [f"`{n}`: {p}" for n in dict.fromkeys(names) if (p := doc_paths.problem(n))]
    assert not problems, f"{page}:\n" + "\n".join(problems)


def test_the_rule_finds_each_kind_of_path_and_each_kind_of_miss():
    """Not vacuous: the rule reads each way a doc names a path, and misses each kind of mistake."""
    text = ("`tests/conftest.py`, `core/effects/common.for_blocks`, `viewport/offscreen.py`, "
            "`core/reference`, `shaders/`, `addon/gone.py`, `gl/film.no_such_name`, "
            "`tests/<package>/` `out/demo.mp4` `python -m addon render`\n```\n`bench/x.py`\n```\n")
    names = doc_paths.named_paths(text)
    assert names == ["tests/conftest.py", "core/effects/common.for_blocks", "viewport/offscreen.py",
                     "core/reference", "shaders/", "addon/gone.py", "gl/film.no_such_name"]
    assert [n for n in names if doc_paths.problem(n)] == ["addon/gone.py", "gl/film.no_such_name"]
