"""PlayCanvas SOG v2 writer: bundled `.sog` (a zip) or unbundled (`meta.json` beside its
WebP images). The inverse of sog.py (layout in its docstring). Encoder facts from
splat-transform's src/lib/writers/write-sog.ts:
  - splats go in Morton order of their positions (neighbours share texel rows: smaller WebPs)
  - images are W x H texels, W = ceil(sqrt(N) / 4) * 4, H = ceil(N / W / 4) * 4
  - means: t = sign(x) * log(|x| + 1) per axis, mins/maxs of t in meta, 16 bits across them
  - quats: normalised, the largest |w x y z| made positive, the other three in w x y z order
    as 255 * (c * sqrt(2) * 0.5 + 0.5), A = 252 + the dropped index
  - scales (log), sh0 (DC) and the shN centroids each pool their columns into one
    256-entry codebook; sh0's A is round(opacity * 255)
  - shN: k-means palette of min(64, 2^floor(log2(N / 1024))) * 1024 entries over the
    splats' higher-SH vectors; labels as 16-bit RG; centroids 64 entries a row
We round where splat-transform truncates (same decoder, half the error), and keep sh0's
alpha >= 1: Blender's OpenImageIO writes RGB as zero under a zero alpha, which would turn
that splat's colour indices into index 0.
"""
from __future__ import annotations

import io
import json
import math
import os
import zipfile

import numpy as np

from ..errors import SplatFormatError
from ..quantize import codebook_1d, kmeans, nearest_1d
from ..splats import SplatSet
from ..atomic import sigterm_cleans_up, temporary_folder
from ._common import write_file, write_files
from .compressed_ply_write import _morton_order
from .webp import write_rgba

GENERATOR = "splatline"


def image_size(n: int) -> tuple[int, int]:
    width = max(4, math.ceil(math.sqrt(n) / 4) * 4)
    return width, max(4, math.ceil(n / width / 4) * 4)


def palette_size(n: int) -> int:
    """splat-transform's shN palette size (64 for tiny sets, 64K from 64K splats up)."""
    return 0 if n == 0 else int(min(64, 2.0 ** math.floor(math.log2(n / 1024))) * 1024)


def sog_order(positions: np.ndarray) -> np.ndarray:
    """The texel order write_sog stores splats in (texel i holds splat order[i])."""
    return _morton_order(positions) if len(positions) else np.zeros(0, np.int64)


def _texels(n: int, channels: list) -> np.ndarray:
    """(H, W, 4) uint8 image whose first n texels hold the given per-splat channels."""
    w, h = image_size(n)
    img = np.zeros((w * h, 4), np.uint8)
    img[:, 3] = 255
    for c, values in enumerate(channels):
        img[:n, c] = values
    return img.reshape(h, w, 4)


def log_transform(p: np.ndarray) -> np.ndarray:
    return np.sign(p) * np.log1p(np.abs(p))


def _means(p: np.ndarray):
    t = log_transform(p.astype(np.float64))
    lo, hi = t.min(axis=0), t.max(axis=0)
    v = np.rint(65535 * (t - lo) / np.where(hi > lo, hi - lo, 1.0)).astype(np.uint32)
    low = _texels(len(p), [v[:, a] & 0xFF for a in range(3)])
    high = _texels(len(p), [v[:, a] >> 8 for a in range(3)])
    return {"mins": lo.tolist(), "maxs": hi.tolist()}, low, high


def _quats(wxyz: np.ndarray) -> np.ndarray:
    q = wxyz.astype(np.float64)
    norm = np.linalg.norm(q, axis=1, keepdims=True)
    q = np.where(norm > 0, q / np.where(norm > 0, norm, 1.0), [1.0, 0.0, 0.0, 0.0])  # zero -> identity
    largest = np.argmax(np.abs(q), axis=1)
    rows = np.arange(len(q))
    q *= (np.where(q[rows, largest] < 0, -1.0, 1.0) * math.sqrt(2))[:, None]
    others = np.array([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]])[largest]
    three = np.take_along_axis(q, others, axis=1)
    bytes3 = np.clip(np.rint(255 * (three * 0.5 + 0.5)), 0, 255).astype(np.uint8)
    return _texels(len(q), [bytes3[:, 0], bytes3[:, 1], bytes3[:, 2], 252 + largest])


def _codebook_image(values: np.ndarray, extra=()):
    """A pooled 256-entry codebook over the columns of values (N, C), and the image of indices."""
    book = codebook_1d(values)
    idx = nearest_1d(values.astype(np.float32), book)
    return book, _texels(len(values), [idx[:, c] for c in range(values.shape[1])] + list(extra))


def _sh_palette(rest: np.ndarray, iterations: int, seed: int):
    """meta shN entry, centroid image and label image for (N, K, 3) coefficients."""
    n, k = rest.shape[:2]
    cen, labels = kmeans(rest.reshape(n, k * 3), palette_size(n), iterations, seed)
    book = codebook_1d(cen)
    idx = nearest_1d(cen, book).reshape(len(cen), k, 3)
    rows = math.ceil(len(cen) / 64)
    img = np.zeros((rows * 64 * k, 4), np.uint8)
    img[:, 3] = 255
    img[: len(cen) * k, :3] = idx.reshape(-1, 3)  # entry e, coefficient j at texel e * K + j
    lab = _texels(n, [labels & 0xFF, labels >> 8, np.zeros(n, np.uint8)])
    meta = {"count": palette_size(n), "bands": int(round(math.sqrt(k + 1))) - 1,
            "codebook": book.tolist(), "files": ["shN_centroids.webp", "shN_labels.webp"]}
    return meta, img.reshape(rows, 64 * k, 4), lab


def encode_sog(splats: SplatSet, iterations: int = 10, seed: int = 0) -> tuple[dict, dict]:
    """(meta.json object, {file name: (H, W, 4) uint8 image})."""
    splats.check()
    s = splats.subset(sog_order(splats.positions))
    n = s.count
    means, low, high = _means(s.positions)
    scales_book, scales = _codebook_image(np.log(np.maximum(s.scales, 1e-30)))
    alpha = np.clip(np.rint(s.opacities.astype(np.float64) * 255), 1, 255).astype(np.uint8)
    sh0_book, sh0 = _codebook_image(s.sh_dc, [alpha])
    images = {"means_l.webp": low, "means_u.webp": high, "quats.webp": _quats(s.rotations),
              "scales.webp": scales, "sh0.webp": sh0}
    meta = {"version": 2, "asset": {"generator": GENERATOR}, "count": n,
            "means": {**means, "files": ["means_l.webp", "means_u.webp"]},
            "scales": {"codebook": scales_book.tolist(), "files": ["scales.webp"]},
            "quats": {"files": ["quats.webp"]},
            "sh0": {"codebook": sh0_book.tolist(), "files": ["sh0.webp"]}}
    if s.sh_degree > 0:
        meta["shN"], cen, lab = _sh_palette(s.sh_rest, iterations, seed)
        images.update({"shN_centroids.webp": cen, "shN_labels.webp": lab})
    return meta, images


def _entry(name) -> zipfile.ZipInfo:
    """A zip entry with a fixed date, so the same splats give the same bytes."""
    return zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))


def _webp_files(images: dict, folder: str) -> dict:
    """{name: lossless WebP bytes}: OpenImageIO writes files, not memory, so each image is
    encoded into the private scratch folder and read back."""
    out = {}
    for name, img in images.items():
        local = os.path.join(folder, name)
        write_rgba(local, img)
        with open(local, "rb") as f:
            out[name] = f.read()
    return out


def write_sog(path, splats: SplatSet, iterations: int = 10, seed: int = 0) -> None:
    """`.sog` (or any name but meta.json): one zip; `meta.json`: the images beside it.

    Both are atomic (core/atomic.py): the bundle is one renamed file; unbundled, every
    image and meta.json is written whole under a temporary name beside its target, then
    each is renamed in, meta.json last. A failure or kill before the renames leaves the
    old SOG as it was; only in the renames' window (microseconds) could a reader see new
    images beside the old meta.json."""
    if splats.count == 0:
        raise SplatFormatError(path, "SOG cannot hold 0 splats (its images would be empty)")
    meta, images = encode_sog(splats, iterations, seed)
    meta_bytes = json.dumps(meta, separators=(",", ":")).encode()
    unbundled = os.path.basename(os.fspath(path)).lower() == "meta.json"
    with sigterm_cleans_up(), temporary_folder("splatline-sog-") as tmp:
        webps = _webp_files(images, tmp)
    if unbundled:
        folder = os.path.dirname(os.path.abspath(path))
        if not os.path.isdir(folder):
            raise SplatFormatError(path, "cannot write: its folder does not exist")
        write_files([(os.path.join(folder, name), (data,)) for name, data in webps.items()]
                    + [(path, (meta_bytes,))])
        return
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_STORED) as z:  # WebP is compressed already
        z.writestr(_entry("meta.json"), meta_bytes, zipfile.ZIP_DEFLATED)
        for name, data in webps.items():
            z.writestr(_entry(name), data)
    write_file(path, buf.getvalue())
