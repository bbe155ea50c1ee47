"""Every splat writer is atomic (core/atomic.py): fault injection per format.

The write runs in a child process whose os.open / os.replace are wrapped: at a chosen
point inside the output folder (the first file created there, the first rename into it)
the child writes a marker and sleeps; the test then kills it (kill -9, or SIGTERM) and
checks that the old output is byte-identical and, for SIGTERM, that no temporary is
left. A normal run leaves only the outputs."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from addon.core.formats import read, write  # noqa: E402
from testing.synth import random_splats  # noqa: E402

OUTPUTS = ["a.ply", "a.splat", "a.spz", "a.compressed.ply", "a.glb", "a.gltf", "a.sog", "meta.json"]

CHILD = textwrap.dedent("""
    import os, sys, time
    sys.path.insert(0, {root!r})
    from addon.core.formats import write
    from testing.synth import random_splats
    out, point, marker = {out!r}, {point!r}, {marker!r}
    folder = os.path.realpath(os.path.dirname(out))

    def pause():
        with open(marker, "w") as f:
            f.write(str(os.getpid()))
        time.sleep(120)

    real_open, real_replace = os.open, os.replace

    def hooked_open(path, *a, **k):
        fd = real_open(path, *a, **k)
        if point == "open" and os.path.dirname(os.path.realpath(path)) == folder \\
                and str(path).endswith(".tmp"):
            pause()  # a file exists in the folder, nothing written to it yet
        return fd

    def hooked_replace(src, dst, *a, **k):
        if point == "replace" and os.path.dirname(os.path.realpath(dst)) == folder:
            pause()  # every byte written, nothing renamed yet
        return real_replace(src, dst, *a, **k)

    if point != "none":
        os.open, os.replace = hooked_open, hooked_replace
    write(out, random_splats(1500, degree=1, seed=2))
""")


def _sog_ok():
    from addon.core.formats.webp import keeps_straight_alpha
    try:
        return keeps_straight_alpha()
    except Exception:
        return False


def _snapshot(folder):
    return {name: (folder / name).read_bytes() for name in sorted(os.listdir(folder))}


def _old_output(tmp_path, name):
    if name in ("a.sog", "meta.json") and not _sog_ok():
        pytest.skip("this OpenImageIO cannot write SOG")
    folder = tmp_path / "out"
    folder.mkdir()
    write(str(folder / name), random_splats(700, degree=1, seed=1))
    return folder, _snapshot(folder)


def _child(out, point, marker):
    code = CHILD.format(root=ROOT, out=str(out), point=point, marker=str(marker))
    return subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)


def _wait_marker(proc, marker, timeout=120):
    t0 = time.monotonic()
    while not marker.exists():
        if proc.poll() is not None:
            raise AssertionError(f"the child ended (rc {proc.returncode}) before the point: "
                                 f"{proc.stderr.read().decode()[-2000:]}")
        if time.monotonic() - t0 > timeout:
            proc.kill()
            raise AssertionError("the child never reached the point")
        time.sleep(0.02)


@pytest.mark.parametrize("name", OUTPUTS)
@pytest.mark.parametrize("point", ["open", "replace"])
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM], ids=["kill9", "sigterm"])
def test_a_killed_write_leaves_the_old_output_intact(tmp_path, name, point, sig):
    folder, before = _old_output(tmp_path, name)
    marker = tmp_path / "paused"
    proc = _child(folder / name, point, marker)
    _wait_marker(proc, marker)
    proc.send_signal(sig)
    proc.wait(60)
    assert proc.returncode == -sig
    after = _snapshot(folder)
    assert {k: after[k] for k in before if k in after} == before, "an old file changed"
    assert set(before) <= set(after), "an old file is gone"
    if sig == signal.SIGTERM:  # a signal the process can catch: no temporary left behind
        assert sorted(after) == sorted(before), f"left behind: {sorted(set(after) - set(before))}"
    assert read(str(folder / name)).count == 700


@pytest.mark.parametrize("name", OUTPUTS)
def test_a_normal_write_replaces_the_output_and_leaves_no_temporary(tmp_path, name):
    folder, before = _old_output(tmp_path, name)
    proc = _child(folder / name, "none", tmp_path / "unused")
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err.decode()[-2000:]
    assert sorted(os.listdir(folder)) == sorted(before)
    assert read(str(folder / name)).count == 1500


def test_overwriting_keeps_permissions_and_links(tmp_path):
    target = tmp_path / "real.ply"
    write(str(target), random_splats(10, degree=0, seed=1))
    os.chmod(target, 0o640)
    link = tmp_path / "link.ply"
    link.symlink_to(target)
    write(str(link), random_splats(20, degree=0, seed=1))
    assert link.is_symlink() and read(str(target)).count == 20
    assert (os.stat(target).st_mode & 0o777) == 0o640
    assert sorted(os.listdir(tmp_path)) == ["link.ply", "real.ply"]


def test_unbundled_sog_into_a_missing_folder_says_so(tmp_path):
    if not _sog_ok():
        pytest.skip("this OpenImageIO cannot write SOG")
    from addon.core.errors import SplatFormatError
    with pytest.raises(SplatFormatError, match="folder does not exist"):
        write(str(tmp_path / "nope" / "meta.json"), random_splats(50, degree=0, seed=1))
