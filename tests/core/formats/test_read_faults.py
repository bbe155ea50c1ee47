"""Files that change while they are read (issue 41): every reader either returns the file
as it was when opened or raises one SplatFormatError saying what changed, never a signal.
The change lands at a chosen block of the read through readfile.after_block (testing/
read_faults.py); the command-line cases run in a child, so a SIGBUS would show as its exit
code instead of killing pytest."""
from __future__ import annotations

import os
import shutil
import sys
import subprocess

import numpy as np
import pytest

from addon.core.errors import SplatFormatError
from addon.core.formats import read, read_with_report, readfile
from testing.measured_cli import one_line
from testing.webp_support import needs_straight_webp
from testing.webp_support import needs_straight_webp
from testing.paths import REPO
from testing.read_faults import ACTIONS, REASONS, age, cli_with_fault, hook

# every reader: the copy's name, and its test64 source
READERS = {"ply": "test64.ply", "compressed_ply": "test64.compressed.ply", "splat": "test64.splat",
           "spz": "test64.spz", "sog": "test64.sog", "glb": "test64.glb"}
BLOCK = 256  # every test64 body spans at least 5 blocks of this


def _copy(testdata, tmp_path, fmt):
    src = testdata / READERS[fmt]
    path = tmp_path / src.name.replace("test64", "t")
    shutil.copyfile(src, path)
    age(path)
    return path


def _donor(testdata, tmp_path, fmt):
    """Another valid file of the same format: a copy of guitar's, or test64's own."""
    src = testdata / READERS[fmt].replace("test64", "guitar")
    donor = tmp_path / f"donor{src.suffix}"
    shutil.copyfile(src, donor)
    return donor


@pytest.mark.parametrize("at_block", [0, 3])
@pytest.mark.parametrize("action", ACTIONS)
# a whole SOG read is the comparison: where SOG is refused (4.5's OpenImageIO), the next
# test still changes one under `info` and `convert`, whose zip is read before the refusal
@pytest.mark.parametrize("fmt", [pytest.param(f, marks=needs_straight_webp) if f == "sog" else f
                                 for f in READERS])
def test_a_file_changed_mid_read_is_one_error_or_whole(testdata, tmp_path, monkeypatch, fmt, action, at_block):
    path = _copy(testdata, tmp_path, fmt)
    whole = read(path)
    change = hook(path, action, at_block, _donor(testdata, tmp_path, fmt))
    monkeypatch.setattr(readfile, "BLOCK", BLOCK)
    monkeypatch.setattr(readfile, "after_block", change)
    if REASONS[action] is None:  # deleted after it was opened: the read is whole
        got = read(path)
        np.testing.assert_array_equal(got.positions, whole.positions)
    else:
        with pytest.raises(SplatFormatError, match=REASONS[action]) as info:
            read(path)
        assert info.value.path == os.fspath(path)
    assert change.done == [at_block], "the hook never fired: the read did not go through readfile"


def test_a_short_block_names_the_byte_counts(testdata, tmp_path, monkeypatch):
    path = _copy(testdata, tmp_path, "splat")
    monkeypatch.setattr(readfile, "BLOCK", BLOCK)
    monkeypatch.setattr(readfile, "after_block", hook(path, "truncate", 1))
    with pytest.raises(SplatFormatError) as info:
        read(path)
    # 2048 bytes, cut to 682 after 512 were read
    assert info.value.reason == "file shrank while it was read: expected 2048 bytes, got 682"


def test_info_reports_the_size_it_read_not_a_later_stat(testdata, tmp_path, monkeypatch):
    path = _copy(testdata, tmp_path, "ply")
    monkeypatch.setattr(readfile, "BLOCK", BLOCK)
    monkeypatch.setattr(readfile, "after_block", hook(path, "delete", 2))
    _, report = read_with_report(path)
    assert report.file_bytes == (testdata / "test64.ply").stat().st_size
    assert not path.exists()


# --- the command line, in a child -----------------------------------------------------

def _nothing_left(folder, *keep):
    left = sorted(p.name for p in folder.iterdir() if p.name not in keep)
    assert left == [], left


@pytest.mark.parametrize("fmt", READERS)
def test_info_and_convert_of_a_shrinking_file_exit_1_with_one_line(testdata, tmp_path, fmt):
    path = _copy(testdata, tmp_path, fmt)
    rc, out, err = cli_with_fault(path, "truncate", 2, "info", path)
    assert rc == 1, (rc, err)
    one_line(err, str(path), "shrank while it was read")
    path = _copy(testdata, tmp_path, fmt)
    out_path = tmp_path / "out" / "o.ply"
    out_path.parent.mkdir()
    rc, out, err = cli_with_fault(path, "replace", 1, "convert", path, out_path,
                                  donor=_donor(testdata, tmp_path, fmt))
    assert rc == 1, (rc, err)
    one_line(err, str(path), "replaced while it was read")
    _nothing_left(out_path.parent)  # no output, no temporary


def test_info_of_a_file_deleted_after_the_read(testdata, tmp_path):
    path = _copy(testdata, tmp_path, "spz")
    rc, out, err = cli_with_fault(path, "delete", 3, "info", path, "--json")
    assert rc == 0, err
    import json
    assert json.loads(out)["file_bytes"] == (testdata / "test64.spz").stat().st_size
    assert not path.exists()


# Truncation after the body is read, while it is decoded: the old memory-mapped body raised
# SIGBUS here (exit -7) as the decoder touched a page past the new end. Hooked by name on
# the decoder's first call (sys.setprofile), so it lands at the same point on any code.
_DECODE_CUT = r"""
import os, runpy, sys
target, fn = sys.argv[1], sys.argv[2]
def cut(frame, event, arg):
    if event == "call" and frame.f_code.co_name == fn:
        sys.setprofile(None)
        os.truncate(target, 1000)
sys.setprofile(cut)
sys.argv = ["python -m addon", "info", target]
runpy.run_module("addon", run_name="__main__", alter_sys=True)
"""


@pytest.mark.parametrize("fmt, decoder, rc", [
    ("ply", "decode_vertices", 1),       # decoded as it is read: the cut is met mid-read
    ("compressed_ply", "columns", 0),    # read whole before decoding: the cut comes too late
])
def test_a_file_cut_while_it_is_decoded_never_kills_the_process(testdata, tmp_path, fmt, decoder, rc):
    src = testdata / READERS[fmt].replace("test64", "guitar")  # bodies of many pages
    path = tmp_path / src.name
    shutil.copyfile(src, path)
    res = subprocess.run([sys.executable, "-c", _DECODE_CUT, str(path), decoder], cwd=REPO,
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == rc, (res.returncode, res.stderr)  # the old mmap reader: -7 (SIGBUS)
    if rc:
        one_line(res.stderr, str(path), "shrank while it was read")
    else:
        assert "90,854" in res.stdout
    assert os.path.getsize(path) == 1000
