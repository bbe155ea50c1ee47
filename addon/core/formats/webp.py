"""Lossless WebP in and out through OpenImageIO, the one WebP codec Blender ships.

Inside Blender `import OpenImageIO` just works. Under `python -m addon` with the PyPI bpy
wheel it lives in the wheel's bundled site-packages, which is not on sys.path, so we find
that folder from bpy's package location without importing bpy (core never imports bpy).
It is appended, not prepended: the venv's own numpy must win.

SOG images are data, not pictures: the alpha channel of sh0.webp is opacity and must come
back as stored. OpenImageIO multiplies straight alpha into the colour on read unless told
`oiio:UnassociatedAlpha`, which would corrupt every codebook index.
"""
from __future__ import annotations

import functools
import importlib.util
import os
import pathlib
import sys
import tempfile

import numpy as np

from ..errors import SplatFormatError


def _bundled_site_packages():
    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        return None
    base = pathlib.Path(list(spec.submodule_search_locations)[0])
    hits = sorted(base.glob("*/python/lib/python3.*/site-packages"))
    return str(hits[0]) if hits else None


def oiio(path=None):
    """The OpenImageIO module; SplatFormatError naming `path` when there is none."""
    try:
        import OpenImageIO
        return OpenImageIO
    except ImportError:
        pass
    site = _bundled_site_packages()
    if site and site not in sys.path:
        sys.path.append(site)
        try:
            import OpenImageIO
            return OpenImageIO
        except ImportError:
            pass
    raise SplatFormatError(path, "reading or writing WebP needs OpenImageIO (bundled with "
                                 "Blender and the bpy module), which is not importable here")


@functools.cache
def keeps_straight_alpha() -> bool:
    """Whether this OpenImageIO writes and reads back RGBA WebP bytes unchanged. Blender
    4.5's (OpenImageIO 3.0.6) multiplies alpha into the colour on read whatever it is told,
    which no unpremultiply can undo exactly (alpha 1 leaves colour 0), so SOG is refused
    there rather than decoded wrong. Probed once, on a 2x1 image."""
    probe = np.array([[[200, 100, 50, 1], [7, 250, 128, 128]]], np.uint8)
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "probe.webp")
        try:
            write_rgba(path, probe, check=False)
            return bool(np.array_equal(read_rgba(path, 2, check=False), probe))
        except SplatFormatError:
            return False


def _check_codec(label) -> None:
    if not keeps_straight_alpha():
        raise SplatFormatError(label, f"this OpenImageIO ({oiio(label).VERSION_STRING}) does not keep "
                                      "WebP alpha as stored, which SOG's data images need; use Blender "
                                      "5.0 or newer (or its bpy module) for SOG")


def read_rgba(path, max_pixels: int, label=None, check=True) -> np.ndarray:
    """(H, W, 4) uint8 pixels of a WebP file, alpha as stored.

    The size comes from the header first and is checked against max_pixels before the
    pixels are decoded, so a tiny file claiming a huge image allocates nothing."""
    label = label or path
    io = oiio(label)
    if check:
        _check_codec(label)
    config = io.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)
    inp = io.ImageInput.open(os.fspath(path), config)
    if inp is None:
        raise SplatFormatError(label, f"not a readable WebP image: {io.geterror().strip() or 'unknown error'}")
    try:
        spec = inp.spec()
        w, h, ch = spec.width, spec.height, spec.nchannels
        if w <= 0 or h <= 0 or w * h > max_pixels:
            raise SplatFormatError(label, f"image is {w}x{h}, outside the 1..{max_pixels} pixels expected")
        if ch not in (3, 4):
            raise SplatFormatError(label, f"image has {ch} channels, expected RGB or RGBA")
        px = inp.read_image(0, 0, 0, ch, io.UINT8)
    finally:
        inp.close()
    if px is None or px.shape != (h, w, ch):
        raise SplatFormatError(label, f"cannot decode image: {io.geterror().strip() or 'short read'}")
    if ch == 3:  # an encoder may drop an all-opaque alpha channel
        px = np.concatenate([px, np.full((h, w, 1), 255, np.uint8)], axis=2)
    return np.ascontiguousarray(px, np.uint8)


def write_rgba(path, pixels: np.ndarray, check=True) -> None:
    """Write (H, W, 4) uint8 pixels as lossless WebP (lossy would break codebook indices)."""
    io = oiio(path)
    if check:
        _check_codec(path)
    h, w, ch = pixels.shape
    spec = io.ImageSpec(w, h, ch, io.UINT8)
    spec.attribute("compression", "lossless")
    spec.attribute("oiio:UnassociatedAlpha", 1)
    out = io.ImageOutput.create(os.fspath(path))
    if out is None or not out.open(os.fspath(path), spec):
        raise SplatFormatError(path, f"cannot write WebP: {io.geterror().strip() or 'no WebP support'}")
    ok = out.write_image(np.ascontiguousarray(pixels, np.uint8))
    out.close()
    if not ok:
        raise SplatFormatError(path, f"cannot write WebP: {io.geterror().strip() or 'write failed'}")
