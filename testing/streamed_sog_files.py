"""Streamed SOGs (lod-meta.json) made by splat-transform's own LOD writer, for the tests and
the bench: one float PLY per level (level 0 the finest), written by Splatline, then
`splat-transform -g cpu --lod-chunk-count K l0.ply -l 0 l1.ply -l 1 ... out/lod-meta.json`."""
from __future__ import annotations

import os
import pathlib

import pytest

from addon.core.formats import write
from addon.core.splats import SplatSet
from bench.formats_bench import run_splat_transform
from testing.peers import missing_reason, splat_transform

IN_CI = os.environ.get("CI", "").lower() not in ("", "0", "false", "no")


def peer_or_skip() -> list:
    """The splat-transform command line; without it a test skips, and fails under CI."""
    cmd = splat_transform()
    if cmd is None:
        reason = missing_reason("splat-transform")
        if IN_CI:
            pytest.fail(reason + " (CI fails rather than skip its peer tests)")
        pytest.skip(reason)
    return cmd


def levels_of(splats, strides, count=None) -> list:
    """One SplatSet per level: every stride-th splat of the first `count` (stride 1: the finest)."""
    return [_every(splats, s, count) for s in strides]


def _every(splats, stride, count):
    return SplatSet(**{f: getattr(splats, f)[:count:stride] for f in
                       ("positions", "scales", "rotations", "opacities", "sh_dc", "sh_rest")},
                    axes=splats.axes)


def make_streamed_sog(cmd: list, folder, levels, chunk_k: int = 1) -> pathlib.Path:
    """Write each level as a float PLY, then splat-transform's streamed SOG of them (chunks of
    about chunk_k * 1024 splats); the lod-meta.json path. The PLYs stay beside it (l0.ply ...)."""
    folder = pathlib.Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    args = ["-g", "cpu", "--lod-chunk-count", chunk_k]
    for lod, splats in enumerate(levels):
        ply = folder / f"l{lod}.ply"
        write(ply, splats)
        args += [ply, "-l", lod]
    out = folder / "lod" / "lod-meta.json"
    run_splat_transform(cmd, *args, out)
    return out
