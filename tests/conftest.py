"""Shared fixtures. Core tests need no bpy; blender tests use the real bpy module."""
from __future__ import annotations

import faulthandler
import os
import pathlib
import shutil
import tempfile

import pytest

from testing.gpu_backend import GPU_BACKEND, GPU_BACKENDS, GPU_MODULE_TESTS
from testing.paths import REPO, SHARED_TESTDATA, TESTS

# The repository root is on sys.path through pytest.ini's `pythonpath = .` (so `addon` and
# `testing` import from any folder under tests/).

# Blender's GPU backend for this run: testing/gpu_backend.GPU_BACKEND. tests/project/
# test_gpu_backend.py fails the run when Blender starts another one, so a silent fallback
# never passes for the backend asked for.
# Choosing it must happen before `import bpy`, and not through the preference: the bpy module
# starts from factory settings (no userpref.blend, no command line, so no --gpu-backend) and
# fixes its backend from preferences.system.gpu_backend at import; setting the preference
# later leaves gpu.platform.backend_type_get() unchanged (measured on bpy 5.3.0). Blender tries
# the preferred backend, then OpenGL, then Vulkan, so OPENGL on 5.3 (whose default is Vulkan)
# is had by hiding the Vulkan drivers from the Vulkan loader; subprocesses inherit that.
# VULKAN needs nothing: 5.3's default, given a Vulkan driver (.ci/sysdeps.sh installs lavapipe).
if GPU_BACKEND == "OPENGL":
    for _var in ("VK_DRIVER_FILES", "VK_ICD_FILENAMES"):  # the loader's name, its older name
        os.environ[_var] = str(REPO / "no-vulkan-driver.json")  # no such file: no driver


@pytest.hookimpl(trylast=True)  # after pytest's faulthandler plugin, which enables it on stderr
def pytest_configure(config):
    _crash_logs(config)
    if GPU_BACKEND is not None and GPU_BACKEND not in GPU_BACKENDS:
        raise pytest.UsageError(f"SPLATLINE_GPU_BACKEND={GPU_BACKEND}: expected one of {GPU_BACKENDS}")
    config.addinivalue_line(
        "markers", "gpu_module: draws through Blender's gpu module (GPU_MODULE_TESTS in conftest)")


# A crashed test process (a signal: SIGSEGV, SIGBUS, SIGABRT) must say which test and which
# signal, with its Python stacks. pytest's own faulthandler plugin writes them to the
# worker's stderr, where xdist's interleaved output buries them, and xdist's report only says
# "worker 'gw1' crashed while running X". So each xdist worker points faulthandler at its own
# log in a folder the controller made (every thread's stack, the signal's name first), and
# the controller appends that log to the crashed test's report (pytest_handlecrashitem).
CRASH_DIR = "SPLATLINE_CRASH_LOGS"


def _crash_logs(config) -> None:
    worker = getattr(config, "workerinput", None)
    if worker is None:
        if not hasattr(config.option, "numprocesses"):
            return  # no xdist: the faulthandler plugin's stderr is the report
        folder = tempfile.mkdtemp(prefix="splatline-crash-")
        os.environ[CRASH_DIR] = folder  # the workers, started after configure, inherit it
        config.add_cleanup(lambda: shutil.rmtree(folder, ignore_errors=True))
    elif os.environ.get(CRASH_DIR):
        log = open(os.path.join(os.environ[CRASH_DIR], f"{worker['workerid']}.log"), "w")
        faulthandler.enable(file=log, all_threads=True)
        config.add_cleanup(log.close)


@pytest.hookimpl(optionalhook=True)
def pytest_handlecrashitem(crashitem, report, sched):
    folder = os.environ.get(CRASH_DIR)
    node = getattr(report, "node", None)
    if not folder or node is None:
        return
    try:
        with open(os.path.join(folder, f"{node.gateway.id}.log"), errors="replace") as f:
            stacks = f.read().strip()
    except OSError:
        return
    if stacks:  # "Fatal Python error: Bus error", then every thread's stack, the crashed one first
        report.longrepr = f"{report.longrepr}\n{stacks}"


def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.path.relative_to(TESTS).as_posix() in GPU_MODULE_TESTS:
            item.add_marker(pytest.mark.gpu_module)


def pytest_report_header(config):
    return f"Blender GPU backend asked for: {GPU_BACKEND or 'default (SPLATLINE_GPU_BACKEND unset)'}"


@pytest.fixture(scope="session")
def testdata() -> pathlib.Path:
    """The read-only real captures (never write here)."""
    if not SHARED_TESTDATA.is_dir():
        pytest.fail(f"missing {SHARED_TESTDATA}: the repo expects ../shared/testdata beside it")
    return SHARED_TESTDATA


@pytest.fixture(scope="module")
def renderer():
    """One offscreen GL renderer per test module (a context and its GL thread); modules
    that need another kind define their own."""
    from addon.gl import OffscreenRenderer

    r = OffscreenRenderer()
    yield r
    r.close()


@pytest.fixture(scope="session")
def _bpy_registered():
    import bpy

    from addon import register

    bpy.ops.wm.read_factory_settings(use_empty=True)
    if not hasattr(bpy.types.Object, "splatline"):
        register()
    return bpy


@pytest.fixture
def bpy_empty(_bpy_registered):
    """Real bpy with Splatline registered and an empty scene for each test."""
    bpy = _bpy_registered
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if not hasattr(bpy.types.Object, "splatline"):
        from addon import register

        register()
    return bpy


@pytest.fixture
def native_bpy(bpy_empty):
    """bpy_empty on a Blender with native splats (PointCloud.type GAUSSIAN_SPLAT, 5.3+);
    elsewhere the test is skipped: there is nothing to test."""
    from addon.blender.data import native

    if not native.has_native_splats():
        pytest.skip("this Blender has no native splats (PointCloud.type GAUSSIAN_SPLAT: 5.3+)")
    return bpy_empty


# Blender's bundled Python packages (OpenImageIO, ...) inside the bpy wheel.
from testing.blender_packages import use_bundled_packages  # noqa: E402

use_bundled_packages()
