"""The render farm job (issue 44): farm/openjd/*.yaml pass `openjd check`, and `openjd run`
renders a 12-frame range of a real capture's animated scene in 3 chunks, one task each, to
the very frames of one `python -m addon render` of the range; a chunk whose task is killed
and run again leaves every frame whole and the same. openjd-cli is a pinned peer (.ci/peers.sh):
without it these skip, and CI fails (tests/project/test_peers_present.py)."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from testing.measured_cli import cli
from testing.paths import REPO
from testing.peers import missing_reason, openjd

OPENJD = openjd()
pytestmark = pytest.mark.skipif(OPENJD is None, reason=missing_reason("openjd"))
TEMPLATE = REPO / "farm" / "openjd" / "splatline-render.yaml"
COMMAND = f"{sys.executable} -m addon"   # Splatline's command line, several words


def _env():
    # the workers' command line finds the checkout's package (an installed `splatline` would
    # need nothing); openjd runs each task in a session folder of its own
    return {**os.environ, "PYTHONPATH": str(REPO)}


def _run(scene, out, *extra, **popen):
    args = [*OPENJD, "run", str(TEMPLATE), "-p", f"SceneFile={scene}", "-p", "Frames=1-12",
            "-p", "ChunkSize=4", "-p", f"OutputDir={out}", "-p", f"Command={COMMAND}", *extra]
    return subprocess.Popen(args, env=_env(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True, **popen)


def _frames(folder):
    from testing.engine_scene import read_image

    return {p.name: read_image(p) for p in sorted(folder.glob("frame_*.png"))}


@pytest.fixture(scope="module")
def scene(tmp_path_factory, testdata):
    """guitar.ply with its axes, lit by a keyed spot that sweeps it (testing/relit_scene.py):
    every frame differs. Built and saved in a child process (bpy)."""
    path = tmp_path_factory.mktemp("farm") / "relit.blend"
    code = ("import sys; sys.path.insert(0, %r)\n"
            "from pathlib import Path\n"
            "from addon.cli import blender_session\n"
            "bpy = blender_session.start()\n"
            "from testing import relit_scene\n"
            "relit_scene.build(bpy, Path(%r), frames=12)\n"
            "bpy.context.scene.render.resolution_x, bpy.context.scene.render.resolution_y = 64, 48\n"
            "blender_session.save_blend(bpy, %r)\n") % (str(REPO), str(testdata), str(path))
    run = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    return path


@pytest.fixture(scope="module")
def one_run(scene, tmp_path_factory):
    out = tmp_path_factory.mktemp("one") / "frames"
    rc, _, err, _ = cli("render", scene, "--out", out, "--frames", "1-12")
    assert rc == 0, err
    return _frames(out)


@pytest.mark.parametrize("name", ["splatline-render.yaml", "splatline-render-blender.yaml"])
def test_the_templates_pass_openjd_check(name):
    run = subprocess.run([*OPENJD, "check", str(REPO / "farm" / "openjd" / name)],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0 and "passes validation" in run.stdout, run.stdout + run.stderr


def test_openjd_run_in_three_chunks_gives_one_runs_frames(scene, one_run, tmp_path):
    out = tmp_path / "farm"
    job = _run(scene, out)
    log, _ = job.communicate(timeout=900)
    assert job.returncode == 0, log[-3000:]
    assert log.count("render 4 frame(s)") == 3 or "Chunks run: 3" in log, log[-3000:]
    got = _frames(out)
    assert sorted(got) == sorted(one_run) and len(got) == 12
    for name in got:
        np.testing.assert_array_equal(got[name], one_run[name], err_msg=name)
    assert not np.array_equal(got["frame_0001.png"], got["frame_0012.png"])


def test_a_killed_chunk_run_again_leaves_whole_frames(scene, one_run, tmp_path):
    out = tmp_path / "farm"
    chunk = ["--task-param", "Frames=5-8"]
    job = _run(scene, out, *chunk, start_new_session=True)
    deadline = time.monotonic() + 300
    while not (out / "frame_0005.png").exists() and time.monotonic() < deadline and job.poll() is None:
        time.sleep(0.05)
    os.killpg(job.pid, signal.SIGKILL)   # the worker dies: openjd, bash and the render with it
    job.communicate(timeout=60)
    assert (out / "frame_0005.png").exists()
    assert len(list(out.glob("frame_*.png"))) < 4  # killed before its chunk was done
    again = _run(scene, out, *chunk)
    log, _ = again.communicate(timeout=600)
    assert again.returncode == 0, log[-3000:]
    got = _frames(out)
    assert sorted(got) == [f"frame_{f:04d}.png" for f in range(5, 9)]
    for name in got:
        np.testing.assert_array_equal(got[name], one_run[name], err_msg=name)
    assert [p.name for p in out.iterdir() if p.name.startswith(".")] == []  # no temporary left
