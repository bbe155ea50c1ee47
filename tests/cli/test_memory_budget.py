"""The memory budget holds for every command (core/budget.py): a command the budget lets run
peaks under it, and what cannot fit is refused before work starts, in one line. Each command
runs as its own child with its peak RSS measured (testing/measured_cli.py), on a 250k-splat
degree-3 capture: once without a budget (its peak P), once with a budget under P (it must be
refused, or peak under the budget), and once with 2 P (it must run: the estimate is not
absurdly high). (`convert --max-memory 700M` of 1M splats to .spz used to run to 1.74 GB.)"""
from __future__ import annotations

import pytest

from testing.measured_cli import cli, one_line
from testing.synth import random_splats, write_ply_variant

SPLATS = 250_000


@pytest.fixture(scope="module")
def capture(tmp_path_factory):
    path = tmp_path_factory.mktemp("budget") / "c.ply"
    write_ply_variant(path, random_splats(SPLATS, degree=3, seed=3))
    return path


CASES = {
    "info": lambda src, out: ["info", src],
    "convert-spz": lambda src, out: ["convert", src, out / "o.spz"],
    "convert-gltf": lambda src, out: ["convert", src, out / "o.gltf"],
    "convert-compressed": lambda src, out: ["convert", src, out / "o.compressed.ply"],
    "import": lambda src, out: ["import", src, "--blend", out / "o.blend"],
    "render-1080p": lambda src, out: ["render", src, "--out", out / "frames", "--frames", "1",
                                      "--resolution", "1920x1080", "--format", "PNG"],
}


@pytest.mark.parametrize("case", CASES)
def test_a_command_within_its_budget_peaks_under_it_or_is_refused_first(tmp_path, capture, case):
    for name in "abc":
        (tmp_path / name).mkdir()
    rc, out, err, peak = cli(*CASES[case](capture, tmp_path / "a"))
    assert rc == 0, err
    low = int(peak * 0.9)
    rc, out, err, low_peak = cli(*CASES[case](capture, tmp_path / "b"), "--max-memory", str(low))
    if rc == 0:
        assert low_peak <= low, f"ran at {low_peak / 2**20:.0f} MiB under a {low / 2**20:.0f} MiB budget"
    else:
        assert rc == 1, err
        one_line(err, "memory budget", "--max-memory")
        assert low_peak < low, "refused only after the work"
        assert list((tmp_path / "b").iterdir()) == []  # nothing written, not even a folder
    rc, out, err, _ = cli(*CASES[case](capture, tmp_path / "c"), "--max-memory", str(2 * peak))
    assert rc == 0, f"refused at twice its peak ({2 * peak / 2**20:.0f} MiB): {err}"
