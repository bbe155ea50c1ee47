"""Dynamic captures against the peers' own code, found outside the repository:
- fourdgs (PyPI, 0.6.0; imported): Splatline's 4dgs model evaluates as
  `fourdgs.read(path).gaussians.state_at(t)` on files fourdgs wrote, from data made either
  side (Splatline's capture converted with to_fourdgs, or fourdgs' own GaussianSet);
- gsplat (npm, 1.2.9): a .splatv Splatline wrote, parsed by gsplat's SplatvLoader under node
  (testing/splatv_peer.mjs), holds the words Splatline reads, laid out as gsplat's
  VideoRenderProgram shader reads them.
Where the peers are: testing/peers.py (gsplat: $SPLATLINE_GSPLAT_JS, a node_modules folder,
and `node` on PATH; fourdgs importable in this Python).
"""
from __future__ import annotations

import base64
import json
import shutil
import subprocess

import numpy as np
import pytest

from addon.core.dynamic import (from_fourdgs_arrays, read_dynamic, to_fourdgs, to_fourdgs_arrays,
                                write_dynamic)
from addon.core.dynamic.splatv import RECORD
from testing import peers
from testing.dynamic_captures import raw_spacetime, write_raw_ply
from testing.dynamic_checks import fourdgs_state_matches
from testing.paths import REPO



def _linear_capture(tmp_path, n=3000):
    rec = raw_spacetime(n, seed=31)
    for name in [f"motion_{i}" for i in range(3, 9)] + [f"omega_{i}" for i in range(4)]:
        rec[name] = 0.0
    write_raw_ply(tmp_path / "lin.ply", rec)
    return read_dynamic(tmp_path / "lin.ply")


def test_splatline_capture_through_fourdgs(tmp_path):
    fourdgs = pytest.importorskip("fourdgs", reason=peers.missing_reason("fourdgs"))
    ours = to_fourdgs(_linear_capture(tmp_path), seconds_per_unit=50 / 30)
    fourdgs.write(tmp_path / "ours.4dgs", fourdgs.GaussianSet(**to_fourdgs_arrays(ours)), ours.t_end)
    scene = fourdgs.read(str(tmp_path / "ours.4dgs"))
    g = scene.gaussians
    back = from_fourdgs_arrays(g.positions, g.scales, g.rotations, g.colors, g.motions, g.mu_t, g.sigma_t,
                               g.win_lo, g.win_hi, cutoff=scene.header.cutoff, duration=scene.duration_sec)
    assert back.count == ours.count
    # fourdgs reorders splats (Morton order, chunks by lifetime): match them by rest centre
    assert np.abs(np.sort(back.positions, axis=0) - np.sort(ours.positions, axis=0)).max() < 1e-2
    alive = 0
    for t in (0.0, 0.3, 0.8, 1.2, ours.t_end):
        alive += fourdgs_state_matches(back, g.state_at(t, scene.header.cutoff), t)
    assert alive > 0


def test_fourdgs_data_through_splatline(tmp_path):
    fourdgs = pytest.importorskip("fourdgs", reason=peers.missing_reason("fourdgs"))
    rng = np.random.default_rng(32)
    n = 2000
    q = rng.normal(size=(n, 4))
    sigma = rng.uniform(0.05, 1.0, n)
    sigma[::7] = np.inf  # never fades
    lo = np.where(np.arange(n) % 5 == 0, rng.uniform(0, 1, n), -np.inf)
    hi = np.where(np.arange(n) % 3 == 0, lo + rng.uniform(0.5, 2.0, n), np.inf)
    hi = np.where(np.isinf(lo) & (np.arange(n) % 3 == 0), rng.uniform(1, 3, n), hi)
    g = fourdgs.GaussianSet(
        positions=rng.normal(0, 1, (n, 3)).astype(np.float32), scales=rng.uniform(0.01, 0.1, (n, 3)).astype(np.float32),
        rotations=(q / np.linalg.norm(q, axis=1, keepdims=True)).astype(np.float32),
        colors=rng.uniform(0, 1, (n, 4)).astype(np.float32), motions=rng.normal(0, 0.5, (n, 3)).astype(np.float32),
        mu_t=rng.uniform(0, 3, n).astype(np.float32), sigma_t=sigma.astype(np.float32),
        win_lo=lo.astype(np.float32), win_hi=hi.astype(np.float32))
    fourdgs.write(tmp_path / "theirs.4dgs", g, 3.0)
    scene = fourdgs.read(str(tmp_path / "theirs.4dgs"))
    d = scene.gaussians
    capture = from_fourdgs_arrays(d.positions, d.scales, d.rotations, d.colors, d.motions, d.mu_t, d.sigma_t,
                                  d.win_lo, d.win_hi, cutoff=scene.header.cutoff, duration=scene.duration_sec)
    assert (capture.t_start, capture.t_end, capture.unit) == (0.0, 3.0, "seconds")
    for t in (0.0, 0.5, 1.0, 1.7, 2.999, 3.0):
        assert fourdgs_state_matches(capture, scene.state_at(t), t) > 0


@pytest.fixture
def gsplat_node():
    modules = peers.gsplat_modules()
    if modules is None:
        pytest.skip(peers.missing_reason("gsplat"))
    return shutil.which("node"), str(modules / "gsplat" / "dist" / "index.es.js")


def test_splatv_decoded_by_gsplat(tmp_path, gsplat_node):
    rec = raw_spacetime(1500, seed=33)
    write_raw_ply(tmp_path / "st.ply", rec)
    write_dynamic(tmp_path / "st.splatv", read_dynamic(tmp_path / "st.ply"))
    ours = read_dynamic(tmp_path / "st.splatv")
    node, gsplat = gsplat_node
    out = subprocess.run([node, str(REPO / "testing" / "splatv_peer.mjs"), gsplat, str(tmp_path / "st.splatv")],
                         capture_output=True, text=True, timeout=120, check=True)
    peer = json.loads(out.stdout)
    assert peer["vertexCount"] >= ours.count and peer["width"] == 4096  # rows of 1024 splats, zero padded
    words = np.frombuffer(base64.b64decode(peer["words"]), RECORD)[:ours.count]
    np.testing.assert_array_equal(words["position"], ours.positions)
    np.testing.assert_array_equal(words["rotation"].astype(np.float32), ours.rotations)
    np.testing.assert_array_equal(words["motion"][:, :9].astype(np.float32).reshape(-1, 3, 3), ours.motion)
    np.testing.assert_array_equal(words["omega"].astype(np.float32), ours.omega)
    np.testing.assert_array_equal(words["trbf"].astype(np.float32), np.stack([ours.t_center, ours.t_scale], 1))
    np.testing.assert_array_equal(words["rgba"][:, 3] / np.float32(255), ours.opacities)
    # the layout is the one gsplat's shader reads (word 15 = trbf, 8..12 = motion, 13..14 = omega)
    source = open(gsplat, encoding="utf-8").read()
    for line in ("vec2 trbf = unpackHalf2x16(motion1.w);",
                 "vec4 trot = vec4(unpackHalf2x16(motion1.y).xy, unpackHalf2x16(motion1.z).xy) * dt;",
                 "vec4 rot = vec4(unpackHalf2x16(static0.w).xy, unpackHalf2x16(static1.x).xy) + trot;",
                 "float topacity = exp(-1.0 * pow(dt / trbf.y, 2.0));"):
        assert line in source
