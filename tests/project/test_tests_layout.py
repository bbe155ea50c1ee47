"""The tests' own layout: tests/ mirrors addon/. Every test file sits in the folder of an
existing addon/ package (tests/core/formats/ for addon/core/formats/, tests/blender/render/
for addon/blender/render/, ...) or in tests/project/ (checks of the whole project), tests/
itself holds only conftest.py, and no test module imports another: what tests share lives in
testing/ (pytest imports test files by path, --import-mode=importlib, so a test module is not
importable by name anyway)."""
from __future__ import annotations

import ast
import pathlib

from testing.paths import REPO, TESTS

PROJECT = "project"  # the one folder that mirrors no package: import rules, zip, install, README


def _imported_modules(source: str) -> set[str]:
    """Every module an import statement names, at any depth (lazy imports included)."""
    names = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module)
    return names


def layout_problems(tests: pathlib.Path, addon: pathlib.Path) -> list[str]:
    """What breaks the layout in the test tree `tests` mirroring the package tree `addon`."""
    problems = []
    test_files = sorted(tests.rglob("test_*.py"))
    test_modules = {p.stem for p in test_files}
    for path in sorted(tests.rglob("*.py")):
        rel = path.relative_to(tests)
        folder = rel.parent
        if path.name == "conftest.py":
            continue
        if not path.name.startswith("test_"):
            problems.append(f"{rel}: not a test module (shared helpers go in testing/)")
        elif folder == pathlib.Path("."):
            problems.append(f"{rel}: directly in tests/ (put it in the folder of the addon/ "
                            f"package it tests, or in tests/{PROJECT}/)")
        elif folder.parts != (PROJECT,) and not (addon / folder / "__init__.py").is_file():
            problems.append(f"{rel}: addon/{folder.as_posix()} is no package")
    for path in test_files:
        for module in sorted(_imported_modules(path.read_text(encoding="utf-8"))):
            top = module.split(".")[0]
            if top in test_modules or top in ("tests", "conftest"):
                problems.append(f"{path.relative_to(tests)}: imports the test module {module} "
                                f"(move what it needs to testing/)")
    return problems


def test_tests_mirror_addon_and_import_no_other_test():
    assert TESTS.is_dir() and (REPO / "addon" / "__init__.py").is_file()
    problems = layout_problems(TESTS, REPO / "addon")
    assert not problems, "\n".join(problems)


def test_the_check_sees_each_kind_of_misplaced_file(tmp_path):
    """Not vacuous: a tree with each mistake gives one problem per mistake."""
    addon, tests = tmp_path / "addon", tmp_path / "tests"
    for package in ("", "core", "core/formats"):
        (addon / package).mkdir(parents=True, exist_ok=True)
        (addon / package / "__init__.py").write_text("")
    files = {
        "conftest.py": "",
        "core/formats/test_ply.py": "import numpy\n",
        f"{PROJECT}/test_rules.py": "",
        "test_flat.py": "",                                    # directly in tests/
        "viewport/test_draw.py": "",                           # no addon/viewport package
        "core/helper_scene.py": "",                            # a helper among the tests
        "core/test_reader.py": "def f():\n    from test_ply import x\n",  # a lazy test import
        "core/test_fixture.py": "from conftest import ROOT\n",
    }
    for name, text in files.items():
        (tests / name).parent.mkdir(parents=True, exist_ok=True)
        (tests / name).write_text(text)
    problems = layout_problems(tests, addon)
    assert len(problems) == 5, problems
    for culprit in ("test_flat.py", "viewport/test_draw.py", "core/helper_scene.py",
                    "core/test_reader.py: imports the test module test_ply",
                    "core/test_fixture.py: imports the test module conftest"):
        assert any(p.startswith(culprit) for p in problems), (culprit, problems)
