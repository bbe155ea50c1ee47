"""The peers: outside tools and libraries that peer tests check Splatline against, and where a
test finds each. None is a dependency of Splatline. .ci/peers.sh (`make peers`) installs the
tools pinned, outside the repository, and the Makefile passes their paths in the variables
below; fourdgs is a pinned test requirement (requirements/blender-*.txt). A peer test skips,
naming what is missing, when its peer is absent; under CI tests/project/test_peers_present.py
fails the run instead, so that CI never passes with peer tests skipped."""
from __future__ import annotations

import importlib.util
import os
import pathlib
import shutil

from bench.formats_bench import PEER_ENV as SPLAT_TRANSFORM_ENV
from bench.formats_bench import splat_transform_command

GSPLAT_ENV = "SPLATLINE_GSPLAT_JS"  # a node_modules folder that holds gsplat (npm), for node
OPENJD_ENV = "SPLATLINE_OPENJD"     # the openjd executable (PyPI openjd-cli)
GS3D_ENV = "SPLATLINE_GS3D_JS"      # a node_modules folder that holds @mkkellogg/gaussian-splats-3d and three
TOOLS = "make peers (.ci/peers.sh) installs it outside the repository"

# name -> the pinned version (.ci/peers/package-lock.json, .ci/peers/openjd.txt, requirements/)
PINNED = {"splat-transform": "3.7.0", "gsplat": "1.2.9", "openjd": "0.8.0", "fourdgs": "0.6.0",
          "gaussian-splats-3d": "0.4.7"}


def splat_transform() -> list | None:
    """The splat-transform command line, or None ($SPLATLINE_SPLAT_TRANSFORM, else PATH)."""
    return splat_transform_command()


def gsplat_modules() -> pathlib.Path | None:
    """The node_modules folder holding gsplat, or None without it or without node to run it."""
    folder = os.environ.get(GSPLAT_ENV)
    if not folder or shutil.which("node") is None:
        return None
    folder = pathlib.Path(folder)
    return folder if (folder / "gsplat" / "package.json").is_file() else None


def gs3d_modules() -> pathlib.Path | None:
    """The node_modules folder holding GaussianSplats3D (its .ksplat writer), or None without
    it or without node to run it."""
    folder = os.environ.get(GS3D_ENV)
    if not folder or shutil.which("node") is None:
        return None
    folder = pathlib.Path(folder)
    return folder if (folder / "@mkkellogg" / "gaussian-splats-3d" / "package.json").is_file() else None


def openjd() -> list | None:
    """The openjd command line, or None ($SPLATLINE_OPENJD, else `openjd` on PATH)."""
    exe = os.environ.get(OPENJD_ENV) or shutil.which("openjd")
    return [exe] if exe and os.access(exe, os.X_OK) else None


def fourdgs_installed() -> bool:
    return importlib.util.find_spec("fourdgs") is not None


def missing_reason(name: str) -> str:
    """One line for a peer test's skip: which peer is missing, where it is looked for."""
    where = {"splat-transform": f"${SPLAT_TRANSFORM_ENV} or `splat-transform` on PATH; {TOOLS}",
             "gsplat": f"${GSPLAT_ENV} (and node on PATH); {TOOLS}",
             "openjd": f"${OPENJD_ENV} or `openjd` on PATH; {TOOLS}",
             "gaussian-splats-3d": f"${GS3D_ENV} (and node on PATH); {TOOLS}",
             "fourdgs": "this venv; make test rebuilds it from requirements/blender-*.txt"}[name]
    return f"peer {name} {PINNED[name]} not found: looked in {where}"
