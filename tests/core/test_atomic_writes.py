"""Every splat writer is atomic (core/atomic.py): fault injection per format.

The write runs in a child process whose os.open / os.replace are wrapped: at a chosen
point inside the output folder (the first file created there, the first rename into it)
the child writes a marker and sleeps; the test then kills it (kill -9, or SIGTERM) and
checks that the old output is byte-identical and, for SIGTERM, that no temporary is
left. A normal run leaves only the outputs."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from addon.core.formats import read, write
from testing.interrupt import finish_or_dump, wait_for_marker
from testing.paths import REPO
from testing.synth import random_splats

ROOT = str(REPO)

OUTPUTS = ["a.ply", "a.splat", "a.spz", "a.compressed.ply", "a.glb", "a.gltf", "a.sog", "meta.json"]

CHILD = textwrap.dedent("""
    import os, sys, time
    sys.path.insert(0, {root!r})
    from addon.core.formats import write
    from testing.synth import random_splats
    out, point, marker, cli = {out!r}, {point!r}, {marker!r}, {cli!r}
    folder = os.path.realpath(os.path.dirname(out))

    def pause():
        with open(marker, "w") as f:
            f.write(str(os.getpid()))
        for _ in range(2400):  # 120 s in slices (testing/interrupt.py says why)
            time.sleep(0.05)

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

    if cli:  # the command line, whose SIGTERM is Ctrl+C: addon/__main__.py
        source = os.path.join(os.path.dirname({marker!r}), "source.ply")
        write(source, random_splats(1500, degree=1, seed=2))
    if point != "none":
        os.open, os.replace = hooked_open, hooked_replace
    if cli:
        from addon.__main__ import main
        sys.exit(main(["convert", source, out]))
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


def _child(out, point, marker, cli=False):
    code = CHILD.format(root=ROOT, out=str(out), point=point, marker=str(marker), cli=cli)
    return subprocess.Popen([sys.executable, "-X", "faulthandler", "-c", code], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)


@pytest.mark.parametrize("name", OUTPUTS)
@pytest.mark.parametrize("point", ["open", "replace"])
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM], ids=["kill9", "sigterm"])
def test_a_killed_write_leaves_the_old_output_intact(tmp_path, name, point, sig):
    folder, before = _old_output(tmp_path, name)
    marker = tmp_path / "paused"
    proc = _child(folder / name, point, marker)
    wait_for_marker(proc, marker)
    proc.send_signal(sig)
    proc.wait(60)
    assert proc.returncode == -sig
    after = _snapshot(folder)
    assert {k: after[k] for k in before if k in after} == before, "an old file changed"
    assert set(before) <= set(after), "an old file is gone"
    if sig == signal.SIGTERM:  # a signal the process can catch: no temporary left behind
        assert sorted(after) == sorted(before), f"left behind: {sorted(set(after) - set(before))}"
    assert read(str(folder / name)).count == 700
    # the next normal write to that output removes what kill -9 left (the writer is gone)
    write(str(folder / name), random_splats(900, degree=1, seed=3))
    assert sorted(os.listdir(folder)) == sorted(before), "a dead writer's temporary stayed"
    assert read(str(folder / name)).count == 900


@pytest.mark.parametrize("name", OUTPUTS)
@pytest.mark.parametrize("point", ["open", "replace"])
def test_sigterm_stops_a_convert_as_ctrl_c_does(tmp_path, name, point):
    """python -m addon convert handles SIGTERM as Ctrl+C: "interrupted", exit 130, the old
    output whole and no temporary or lock left (it ended by the signal, -15, before)."""
    folder, before = _old_output(tmp_path, name)
    marker = tmp_path / "paused"
    proc = _child(folder / name, point, marker, cli=True)
    wait_for_marker(proc, marker)
    proc.send_signal(signal.SIGTERM)
    _, err = finish_or_dump(proc, timeout=60)
    assert proc.returncode == 130, err.decode()[-2000:]
    assert err.decode().strip().splitlines()[-1] == "interrupted"
    assert _snapshot(folder) == before
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


# --- .blend files (python -m addon import --blend) ----------------------------------------
# Blender writes PATH@ and renames it over PATH; its save is C code, so the child's hooks
# are a save_pre handler (nothing written yet) and, for points inside the write, PATH@
# made a named pipe in that handler: Blender's write then blocks once the pipe is full, and
# the test kills it after reading the first bytes, or 128 KiB, of the new file.

BLEND_CHILD = textwrap.dedent("""
    import os, sys, time
    sys.path.insert(0, {root!r})
    import bpy
    from addon.__main__ import main
    out, point, marker, source = {out!r}, {point!r}, {marker!r}, {source!r}

    @bpy.app.handlers.persistent
    def before_save(*_):
        if point != "save_pre":
            os.mkfifo(out + "@")
        with open(marker, "w") as f:
            f.write(str(os.getpid()))
        if point == "save_pre":
            for _ in range(2400):  # 120 s in slices (testing/interrupt.py says why)
                time.sleep(0.05)

    if point != "none":
        bpy.app.handlers.save_pre.append(before_save)
    try:
        rc = main(["import", source, "--blend", out])
    finally:  # bpy 4.5 hangs at exit with a Python handler still registered
        if before_save in bpy.app.handlers.save_pre:
            bpy.app.handlers.save_pre.remove(before_save)
    sys.exit(rc)
""")

_BLEND_OBJECTS = ("import json, sys, bpy; bpy.ops.wm.open_mainfile(filepath=sys.argv[1]); "
                  "print(json.dumps(sorted(o.name for o in bpy.data.objects)))")


def _blend_objects(path):
    res = subprocess.run([sys.executable, "-c", _BLEND_OBJECTS, str(path)], capture_output=True,
                         text=True, timeout=120)
    assert res.returncode == 0, res.stderr[-2000:]
    return json.loads(res.stdout.strip().splitlines()[-1])


def _import_blend(source, out, point="none", marker=None):
    code = BLEND_CHILD.format(root=ROOT, out=str(out), point=point, marker=str(marker),
                              source=str(source))
    return subprocess.Popen([sys.executable, "-X", "faulthandler", "-c", code], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)


@pytest.fixture(scope="module")
def old_blend(testdata, tmp_path_factory):
    """A .blend the CLI wrote from test64.ply: its bytes and its objects."""
    path = tmp_path_factory.mktemp("old_blend") / "x.blend"
    proc = _import_blend(testdata / "test64.ply", path)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err.decode()[-2000:]
    objects = _blend_objects(path)
    assert "test64" in objects
    return path.read_bytes(), objects


def _read_pipe(pipe, nbytes, proc, timeout=120):
    """Read nbytes of what Blender writes into the named pipe (it blocks after ~64 KiB more)."""
    fd = os.open(pipe, os.O_RDONLY | os.O_NONBLOCK)
    got, t0 = 0, time.monotonic()
    try:
        while got < nbytes:
            try:
                chunk = os.read(fd, nbytes - got)
            except BlockingIOError:
                chunk = None
            if chunk:
                got += len(chunk)
            elif proc.poll() is not None or time.monotonic() - t0 > timeout:
                raise AssertionError(f"the save ended or stalled after {got} bytes")
            else:
                time.sleep(0.005)
    except BaseException:
        os.close(fd)
        raise
    return fd


@pytest.mark.parametrize("point, nbytes", [("save_pre", 0), ("begun", 1), ("partway", 128 << 10)],
                         ids=["save_pre", "begun", "partway"])
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM], ids=["kill9", "sigterm"])
def test_a_killed_blend_save_leaves_the_old_blend(testdata, tmp_path, old_blend, point, nbytes, sig):
    """kill -9 at each point: the old .blend byte-identical; SIGTERM: exit 130 and no x.blend@
    (the issue found one left), the .blend whole (the old, or the new when Blender finished
    the save before Python could act). Then a normal import over it leaves only x.blend."""
    old_bytes, old_objects = old_blend
    folder = tmp_path / "out"
    folder.mkdir()
    blend = folder / "x.blend"
    blend.write_bytes(old_bytes)
    marker = tmp_path / "paused"
    proc = _import_blend(testdata / "guitar.ply", blend, point, marker)
    wait_for_marker(proc, marker)
    fd = _read_pipe(str(blend) + "@", nbytes, proc) if point != "save_pre" else None
    try:
        proc.send_signal(sig)
        if fd is not None and sig == signal.SIGTERM:
            os.close(fd)  # the reader gone, Blender's blocked write fails: its error path runs
            fd = None
        _, err = proc.communicate(timeout=120)
    finally:
        if fd is not None:
            os.close(fd)
    if sig == signal.SIGKILL:
        assert proc.returncode == -sig
        assert blend.read_bytes() == old_bytes
        assert _blend_objects(blend) == old_objects
    else:
        assert proc.returncode == 130, err.decode()[-2000:]
        assert sorted(os.listdir(folder)) == ["x.blend"], err.decode()[-2000:]
        objects = _blend_objects(blend)
        assert blend.read_bytes() == old_bytes or "guitar" in objects, objects
    proc = _import_blend(testdata / "guitar.ply", blend)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err.decode()[-2000:]
    assert sorted(os.listdir(folder)) == ["x.blend"], "left behind after a normal run"
    assert "guitar" in _blend_objects(blend)


def test_a_blend_saved_over_keeps_no_backup(testdata, tmp_path, old_blend):
    """Blender's save keeps the old file as x.blend1 by renaming it away first (a moment with
    no x.blend); the CLI saves without versions, as every other writer replaces its output."""
    blend = tmp_path / "x.blend"
    blend.write_bytes(old_blend[0])
    proc = _import_blend(testdata / "test64.ply", blend)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err.decode()[-2000:]
    assert sorted(os.listdir(tmp_path)) == ["x.blend"]
