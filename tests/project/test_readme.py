"""Every command in README.md is run by a test.

The README's `sh` blocks are read line by line. `python -m addon ...` and `splatline ...`
lines are run here as `python -m addon` (the same command line; tests/project/test_install.py runs
the pip-installed `splatline` itself), in README order, on the real captures under the file names the README
uses (renders at a tiny size and two frames); the `python` block (the bpy snippet) is run on
a .blend that `import` made. Every other command (`make`, `pip`, `blender`) must be listed in
COVERED with the test that runs it or the reason nothing here can, and that test must exist.
Commands quoted inline (`make ...`, `pip ...`) must be one of the block commands, or a prefix
of one. So a command added to the README without a test fails this file.

docs/cli.md's `python -m addon` lines are parsed with the current command line: a flag that
is renamed or removed fails here too. The README stays under 300 lines.
"""
from __future__ import annotations

import ast
import importlib.util
import json
import os
import re
import shlex
import shutil
import subprocess
import sys

import pytest

from testing import readme_snippet
from testing.paths import REPO as ROOT

README = ROOT / "README.md"
CLI_DOC = ROOT / "docs" / "cli.md"
MAX_LINES = 300
COMMAND_WORDS = {"make", "python", "python3", "splatline", "pip", "pipx", "blender", "bash"}
HAS_BPY = importlib.util.find_spec("bpy") is not None

# The README's placeholder file names -> the capture each stands for (in ../shared/testdata).
FILES = {
    "capture.ply": "guitar.ply", "capture.spz": "guitar.spz", "guitar.spz": "guitar.spz",
    "guitar.ply": "guitar.ply", "in.ply": "guitar.ply", "a.ply": "test64.ply",
    "b.spz": "test64.spz",
}

# Commands this file does not run: (test that runs it, or "Makefile:TARGET", why).
COVERED = {
    "make demo": ("tests/blender/demo/test_demo.py::test_prints_paths_and_time_per_frame",
                  "builds a venv first; its recipe, `python -m addon demo`, runs in test_demo"),
    "make test": ("Makefile:test", "runs this suite"),
    "make test BLENDER=4.5": ("Makefile:test", "this suite under another Blender: CI's .ci/run"),
    "make test-matrix": ("Makefile:test-matrix", "this suite under every Blender: CI's .ci/run"),
    "make extension": ("tests/project/test_extension.py::test_one_zip_per_platform",
                       "its recipe, .ci/build_extension.sh, builds the zips test_extension checks"),
    "blender --command extension install-file -r user_default --enable "
    "dist/splatline-0.1.0-linux_x64.zip": (
        "tests/project/test_extension.py::test_install_enable_import_render",
        "no Blender binary here: the test installs the zip through the same extension API in bpy"),
    "pip install .": ("tests/project/test_install.py::test_info_and_convert_without_bpy",
                      "installs into a fresh venv, offline"),
    "pip install .[blender]": ("tests/project/test_install.py::test_import_and_render_with_bpy",
                               "offline: the test installs with --no-deps and adds this venv's bpy"),
    "blender -b scene.blend -E SPLATLINE -a": (
        "tests/blender/render/test_mesh_layer_frames.py::test_cli_and_opened_blend_render_the_meshes",
        "no Blender binary here: the test opens a .blend and renders its range as `blender -b -a`"),
    "blender -b scene.blend -E SPLATLINE -s 1 -e 48 -a": (
        "tests/cli/test_cli_render.py::test_split_frame_ranges_give_identical_files",
        "no Blender binary here: chunks of a range render the same files as the whole range"),
    "blender -b scene.blend -E SPLATLINE -o //frames/f_#### -f 57": (
        "tests/blender/render/test_mesh_layer_frames.py::test_frame_alone_equals_frame_in_range",
        "no Blender binary here: a frame rendered alone equals the same frame of a range"),
}
# Inline mentions that are not block commands: (test or Makefile target, why).
INLINE = {
    "make demo FILE=capture.ply": ("tests/blender/demo/test_demo.py::test_file_replaces_the_knot",
                                   "the recipe's `demo --file`"),
    "pipx install .": ("tests/project/test_install.py::test_info_and_convert_without_bpy",
                       "pipx runs the same install into a venv of its own"),
    "pip install bpy==5.2.3": ("Makefile:test", "the pinned bpy of make test BLENDER=5.2"),
}


def _blocks(text: str) -> list[tuple[str, str]]:
    return re.findall(r"^```(\w*)\n(.*?)^```", text, flags=re.S | re.M)


def _commands(text: str) -> list[list[str]]:
    """Each command of the sh blocks as its words (comments dropped, `&&` splits)."""
    commands = []
    for lang, body in _blocks(text):
        if lang != "sh":
            continue
        for line in body.splitlines():
            # a comment starts at a '#' after a space: f_#### is a frame-number pattern
            words = shlex.split(re.sub(r"(^|\s)#.*$", "", line))
            while words:
                cut = words.index("&&") if "&&" in words else len(words)
                commands.append(words[:cut])
                words = words[cut + 1:]
    return commands


def _inline(text: str) -> list[str]:
    prose = re.sub(r"^```.*?^```", "", text, flags=re.S | re.M)
    spans = re.findall(r"`([^`\n]+)`", prose)
    spans = [s.removeprefix(".venv/bin/") for s in spans]
    return [s for s in spans if s.split() and s.split()[0] in COMMAND_WORDS]


def _is_cli(words: list[str]) -> bool:
    return words[:3] == ["python", "-m", "addon"] or words[:1] == ["splatline"]


def _cli_args(words: list[str]) -> list[str]:
    return words[3:] if words[0] == "python" else words[1:]


def _covered_exists(target: str) -> bool:
    if target.startswith("Makefile:"):
        name = target.split(":", 1)[1]
        return re.search(rf"^{re.escape(name)}:", (ROOT / "Makefile").read_text(), re.M) is not None
    path, func = target.split("::")
    tree = ast.parse((ROOT / path).read_text())
    return any(isinstance(n, ast.FunctionDef) and n.name == func for n in tree.body)


def test_readme_is_short():
    lines = README.read_text().count("\n")
    assert lines < MAX_LINES, f"README.md has {lines} lines; move reference material into docs/"


def test_every_command_is_run_or_covered():
    commands = _commands(README.read_text())
    assert sum(map(_is_cli, commands)) >= 5, "expected the README's command-line examples"
    unknown = [" ".join(w) for w in commands if not _is_cli(w) and " ".join(w) not in COVERED]
    assert not unknown, f"README commands no test runs (run them here or add them to COVERED): {unknown}"
    for command, (target, _why) in {**COVERED, **INLINE}.items():
        assert _covered_exists(target), f"{command!r}: {target} does not exist"


def test_inline_commands_are_block_commands():
    text = README.read_text()
    blocks = [" ".join(w) for w in _commands(text)]
    for span in _inline(text):
        words = " ".join(shlex.split(span.replace("...", "")))
        assert words in INLINE or any(b == words or b.startswith(words + " ") for b in blocks), (
            f"README mentions `{span}`, which is no command of its sh blocks nor in INLINE")


def test_cli_doc_lines_parse():
    from addon.__main__ import _parser

    commands = [w for w in _commands(CLI_DOC.read_text()) if _is_cli(w)]
    assert len(commands) > 30
    for words in commands:
        try:
            _args, unknown = _parser().parse_known_args(_cli_args(words))
        except SystemExit:
            unknown = ["(argparse refused it)"]
        assert not unknown, f"docs/cli.md: {' '.join(words)}: {unknown}"


@pytest.fixture(scope="module")
def workdir(tmp_path_factory, testdata):
    """A folder holding copies of the captures under the README's names (copies: some
    commands write over them), and a generated dynamic capture."""
    from addon.core.dynamic import write_dynamic
    from testing.dynamic_scenes import spacetime_capture

    work = tmp_path_factory.mktemp("readme")
    for name, capture in FILES.items():
        shutil.copyfile(testdata / capture, work / name)
    write_dynamic(work / "dancer.ply", spacetime_capture(800))  # no package ships a 4D capture
    return work


def _tiny(args: list[str]) -> list[str]:
    """A render at 64x36 and at most two frames; everything else as the README has it."""
    args = list(args)
    if "--resolution" in args:
        args[args.index("--resolution") + 1] = "64x36"
    else:
        args += ["--resolution", "64x36"]
    if "--frames" in args:
        i = args.index("--frames") + 1
        start = int(args[i].split("-")[0])
        args[i] = f"{start}-{start + 1}"
    elif "front" not in args:  # an orbit over the default 120 frames
        args += ["--frames", "1-2"]
    return args


def _run(args, cwd, timeout=300):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "addon", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=timeout)


def _check(args, run, cwd):
    from addon.__main__ import _parser

    shown = "python -m addon " + " ".join(args)
    assert run.returncode == 0 and "Traceback" not in run.stderr, f"{shown}:\n{run.stdout}{run.stderr}"
    parsed = _parser().parse_args(args)
    if args[0] == "info" and "--json" in args:
        summary = json.loads(run.stdout)
        assert {"count", "sh_degree", "format", "bbox_min", "bbox_max"} <= set(summary), shown
        assert summary["count"] == 90854, shown
    elif args[0] == "convert":
        assert (cwd / parsed.output).stat().st_size > 0, shown
    elif args[0] == "import":
        assert (cwd / parsed.blend).stat().st_size > 0, shown
    elif args[0] == "render":
        frames = list((cwd / parsed.out).iterdir())
        assert frames and all(f.stat().st_size > 0 for f in frames), shown


def _readme_cli(bpy_commands: bool) -> list[list[str]]:
    return [w for w in _commands(README.read_text())
            if _is_cli(w) and (_cli_args(w)[0] in ("import", "render", "demo")) == bpy_commands]


def test_readme_cli_commands_without_bpy(workdir):
    commands = _readme_cli(bpy_commands=False)
    assert commands
    for words in commands:
        _check(_cli_args(words), _run(_cli_args(words), workdir), workdir)


@pytest.mark.skipif(not HAS_BPY, reason="needs bpy")
def test_readme_cli_commands_with_bpy(workdir):
    """In README order (render g.blend needs the import before it)."""
    commands = _readme_cli(bpy_commands=True)
    assert commands
    for words in commands:
        args = _cli_args(words)
        assert args[0] != "demo", "demo is `make demo`'s (tests/blender/demo/test_demo.py), not run here"
        if args[0] == "render":
            args = [args[0], *_tiny(args[1:])]
        _check(args, _run(args, workdir), workdir)


@pytest.mark.skipif(not HAS_BPY, reason="needs bpy")
def test_readme_bpy_snippet(testdata, tmp_path):
    """The `python` block, from the repo root, on a .blend of guitar.ply (two frames, 64x36);
    tests/project/test_install.py runs it after `pip install`."""
    blend, out = tmp_path / "scene.blend", tmp_path / "out"
    run = _run(["import", str(testdata / "guitar.ply"), "--blend", str(blend)], ROOT)
    assert run.returncode == 0, run.stderr
    readme_snippet.shrink(sys.executable, blend)
    code = readme_snippet.runnable(blend, out, readme_snippet.bpy_major())
    run = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    readme_snippet.check_frames(out)


def _anchors(path) -> set[str]:
    """GitHub's heading anchors: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"^```.*?^```", "", path.read_text(), flags=re.S | re.M)
    return {re.sub(r"[^\w\- ]", "", h.strip().lower()).replace(" ", "-")
            for h in re.findall(r"^#+ (.*)$", text, flags=re.M)}


@pytest.mark.parametrize("page", ["README.md", "docs/cli.md", "docs/benchmarks.md", "docs/formats.md",
                                  "docs/blender-ui.md", "docs/developing.md"])
def test_links_resolve(page):
    """Every relative link and image of the page names a file that exists, and a heading in it."""
    source = ROOT / page
    for target in re.findall(r"\]\(([^)\s]+)\)", source.read_text()):
        if re.match(r"\w+:", target):
            continue  # a URL
        name, _, anchor = target.partition("#")
        path = (source.parent / name).resolve() if name else source
        assert path.exists(), f"{page}: link to {target}: no such file"
        if anchor:
            assert anchor in _anchors(path), f"{page}: link to {target}: no such heading"
