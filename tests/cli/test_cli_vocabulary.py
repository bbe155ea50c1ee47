"""One vocabulary across the sub-commands (issue 42): an option has the same name, values and
default wherever it appears, --help states each option's default and lists the presets and
camera views, and `--version` answers. The parsers are walked as argparse built them, so a
new option or sub-command is held to this without touching the test."""
from __future__ import annotations

import argparse
import subprocess
import sys
import tomllib

import pytest

from addon.__main__ import COMMANDS, _parser
from testing.paths import REPO


def _subparsers():
    parser = _parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return {name: sub.choices[name] for name in COMMANDS}


def _options(parser):
    """long option -> (its action) for every option a user can see or type."""
    return {s: a for a in parser._actions for s in a.option_strings if s.startswith("--")}


def _signature(action):
    choices = None if action.choices is None else tuple(action.choices)
    return (type(action).__name__, action.dest, choices, action.default, action.type, action.nargs,
            action.const)


def test_an_option_means_the_same_in_every_sub_command():
    seen = {}  # option -> (command, signature) first met
    mismatches = []
    for command, parser in _subparsers().items():
        for option, action in _options(parser).items():
            if option in ("--help",):
                continue
            sig = _signature(action)
            if option in seen and seen[option][1] != sig:
                mismatches.append(f"{option}: {seen[option][0]} {seen[option][1]} vs {command} {sig}")
            seen.setdefault(option, (command, sig))
    assert not mismatches, "\n".join(mismatches)
    # the ones the issue named are shared now
    for option, commands in (("--axes", COMMANDS), ("--bad-values", ("import", "convert")),
                             ("--max-sh-degree", ("import", "convert")), ("--frames", ("render", "demo")),
                             ("--seconds", ("render", "import", "demo")), ("--max-splats", ("info", "import", "convert")),
                             ("--lod", ("info", "import", "convert"))):
        have = [c for c, p in _subparsers().items() if option in _options(p)]
        assert set(commands) <= set(have), (option, have)
    assert tuple(_options(_subparsers()["convert"])["--axes"].choices) == ("AUTO", "RDF", "RUB", "RFU")


def test_the_walk_catches_a_difference():
    """The check above can fail: two parsers whose --bad-values differ in default."""
    a, b = argparse.ArgumentParser(), argparse.ArgumentParser()
    a.add_argument("--bad-values", choices=("fix", "drop"), default="fix")
    b.add_argument("--bad-values", choices=("fix", "drop"), default="drop")
    assert _signature(_options(a)["--bad-values"]) != _signature(_options(b)["--bad-values"])


def test_help_states_every_default():
    missing = []
    for command, parser in _subparsers().items():
        for action in parser._actions:
            if not action.option_strings or action.help == argparse.SUPPRESS or action.required:
                continue
            if isinstance(action, (argparse._HelpAction, argparse._VersionAction)):
                continue
            if "default" not in (action.help or "").lower():
                missing.append(f"{command} {action.option_strings[0]}")
    assert not missing, missing


def test_help_lists_presets_and_views():
    parsers = _subparsers()
    effect_help = _options(parsers["import"])["--effect-preset"].help
    for name in ("fade_in", "morph", "explode", "sweep_reveal"):
        assert name in effect_help
    preset_help = _options(parsers["render"])["--preset"].help
    for name in ("exr_half_multilayer", "h264_mp4", "png_16bit", "preview"):
        assert name in preset_help
    for command in ("render", "import"):
        camera = _options(parsers[command])["--camera"].help
        assert all(view in camera for view in ("orbit", "front", "side", "capture"))


def test_old_spellings_still_work_hidden(testdata):
    args = _parser().parse_args(["convert", "a.ply", "b.ply", "--bad", "drop", "--sh-degree", "1"])
    assert (args.bad_values, args.max_sh_degree) == ("drop", 1)
    help_text = _subparsers()["convert"].format_help()
    assert "--bad-values" in help_text and "--bad " not in help_text and "--sh-degree" not in help_text


def test_version():
    want = tomllib.loads((REPO / "blender_manifest.toml").read_text())["version"]
    run = subprocess.run([sys.executable, "-m", "addon", "--version"], cwd=REPO, capture_output=True,
                         text=True, timeout=60)
    assert run.returncode == 0 and run.stdout.strip() == f"python -m addon {want}", run
    pyproject = tomllib.loads((REPO / "pyproject.toml").read_text())
    assert pyproject["project"]["version"] == want  # one version, said twice


@pytest.mark.parametrize("args", [("demo", "--frames", "5-4"), ("demo", "--frames", "1-5"),
                                  ("demo", "--frames", "1-10", "--seconds", "2")])
def test_demo_frames_is_a_range(args):
    run = subprocess.run([sys.executable, "-m", "addon", *args, "--out", "/nonexistent/x"], cwd=REPO,
                         capture_output=True, text=True, timeout=60)
    lines = run.stderr.strip().splitlines()
    assert run.returncode == 2 and len(lines) == 1 and "--frames" in lines[0], run.stderr
