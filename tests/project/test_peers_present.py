"""The peers that peer tests check Splatline against (testing/peers.py) are there, at their
pinned versions. Without one, its peer tests skip; under CI (the CI variable set, as .ci/run
does) that fails here instead, so a CI run with peer tests skipped cannot pass. A developer
without the peers sees the skip and its reason (`make peers` installs them)."""
from __future__ import annotations

import importlib.metadata
import json
import os
import subprocess

import pytest

from testing import peers

IN_CI = os.environ.get("CI", "").lower() not in ("", "0", "false", "no")


def _run_version(cmd: list) -> str:
    proc = subprocess.run([*cmd, "--version"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc.stdout + proc.stderr


def _installed_version(name: str) -> str | None:
    """The version of peer `name` that the tests would use, or None when it is absent."""
    if name == "splat-transform":
        cmd = peers.splat_transform()
        return cmd and _run_version(cmd)
    if name == "gsplat":
        folder = peers.gsplat_modules()
        return folder and json.loads((folder / "gsplat" / "package.json").read_text())["version"]
    if name == "gaussian-splats-3d":
        folder = peers.gs3d_modules()
        return folder and json.loads((folder / "@mkkellogg" / "gaussian-splats-3d" / "package.json").read_text())["version"]
    if name == "openjd":
        cmd = peers.openjd()
        return cmd and _run_version(cmd)
    return importlib.metadata.version("fourdgs") if peers.fourdgs_installed() else None


@pytest.mark.parametrize("name", sorted(peers.PINNED))
def test_peer_is_installed_at_its_pinned_version(name):
    found = _installed_version(name)
    if found is None:
        if IN_CI:
            pytest.fail(peers.missing_reason(name) + " (CI fails rather than skip its peer tests)")
        pytest.skip(peers.missing_reason(name))
    # splat-transform prints "splat-transform v3.7.0 (0f60b17)", openjd "openjd 0.8.0"
    assert peers.PINNED[name] in found.replace("v", " ").split(), (name, found)
