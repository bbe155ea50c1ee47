"""Blender's bundled Python packages (OpenImageIO, ...) inside the bpy wheel, for the tests
and benches that read images with them."""
from __future__ import annotations

import sys

from addon.core.formats.webp import _bundled_site_packages


def use_bundled_packages() -> None:
    """Put them on sys.path, found the way the command line finds them (core's webp module),
    appended so the venv's own numpy wins."""
    site = _bundled_site_packages()
    if site is not None and site not in sys.path:
        sys.path.append(site)
