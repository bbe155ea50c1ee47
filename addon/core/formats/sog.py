"""PlayCanvas SOG v2: `meta.json` plus lossless WebP images, either beside each other
(unbundled: the path is the meta.json) or stored in one zip (bundled `.sog`).
Axis convention: RDF (splat-transform writes the PLY frame unchanged).

Per splat i (texel i in row-major order of every image but the SH palette):
  means_l/means_u  RGB = low/high byte of 16-bit x, y, z; t = lerp(mins, maxs, v / 65535)
                   in log space, position = sign(t) * (exp(|t|) - 1)
  quats            RGB = three smallest components c -> (c / 255 * 2 - 1) / sqrt(2); A = 252 + the
                   index (w, x, y, z) of the dropped largest one, rebuilt positive from unit
                   length. Any other A decodes as the identity, as splat-transform does.
  scales           RGB index the 256-entry `scales.codebook` of log scales
  sh0              RGB index `sh0.codebook` (SH DC coefficients); A / 255 is the opacity
  shN_labels       RG = 16-bit palette entry; entries >= shN.count decode as zero SH
  shN_centroids    64 entries a row, K texels an entry (coefficient j at column entry%64*K+j),
                   RGB index `shN.codebook`
Facts from splat-transform's reader (src/lib/readers/read-sog.ts) and checked against its
decodes of the same files (testdata *_sog.peer.ply, tests/core/formats/test_formats_sog.py).
"""
from __future__ import annotations

import io
import math
import os
import tempfile
import zipfile

import numpy as np

from ..errors import SplatFormatError
from ..splats import AXES_RDF, SplatSet, sh_coeff_count
from ._common import check_budget, file_size, json_object, normalize_quats_
from .readfile import OpenedFile
from .webp import read_rgba

MAX_SPLATS = 1 << 28          # WebP's 16383 x 16383 texel ceiling
MAX_META = 1 << 20            # meta.json holds four 256-entry codebooks: ~14 KB in practice;
                              # more is a bomb (a deflated 60 MiB one was inflated whole)
SPLATS_PER_BYTE = 4           # real SOGs spend > 10 bytes a splat; a bomb claims far more
DEFLATE_RATIO = 1032          # the most deflate can expand
IMAGES = ("means_l", "means_u", "quats", "scales", "sh0")


def is_sog_meta(path) -> bool:
    return os.path.basename(os.fspath(path)).lower() == "meta.json"


class _Files:
    """Member files of a SOG by name: a zip's entries or a folder's files. Bounds every
    size before reading, and hands OpenImageIO a real file path (its Python API reads
    files, not memory), extracting zip members into a private temporary folder."""

    def __init__(self, path):
        self.path = path
        self.zip = None
        self.tmp = None
        if not is_sog_meta(path):
            # the zip is read whole into memory first (it is the compressed size), so a file
            # rewritten while its members inflate is one error here, not a half-read member
            with OpenedFile(path) as f:
                self.packed = f.size
                data = f.read_rest(0)
                f.check_unchanged()
            try:
                self.zip = zipfile.ZipFile(io.BytesIO(data))
            except (zipfile.BadZipFile, ValueError) as exc:
                raise SplatFormatError(path, f"not a SOG zip: {_reason(exc)}") from None
            self._check_zip()
            self.tmp = tempfile.TemporaryDirectory(prefix="splatline-sog-")

    def _check_zip(self) -> None:
        packed = self.packed
        total = sum(info.file_size for info in self.zip.infolist())
        if total > DEFLATE_RATIO * packed + (1 << 20):
            raise SplatFormatError(self.path, f"zip entries claim {total} bytes, more than "
                                              f"{packed} compressed bytes can hold (zip bomb?)")

    def close(self) -> None:
        if self.zip is not None:
            self.zip.close()
        if self.tmp is not None:
            self.tmp.cleanup()

    def label(self, name) -> str:
        return f"{self.path}[{name}]" if self.zip else os.path.join(os.path.dirname(self.path), name)

    def _member(self, name, limit: int) -> bytes:
        try:
            info = self.zip.getinfo(name)
        except KeyError:
            raise SplatFormatError(self.path, f"SOG zip lacks {name}") from None
        if info.file_size > limit:
            raise SplatFormatError(self.path, f"{name} claims {info.file_size} bytes (limit {limit})")
        try:  # zipfile stops at the declared size and checks the CRC: a lying entry fails here
            with self.zip.open(info) as f:
                data = f.read(info.file_size + 1)
        except RuntimeError as exc:  # zipfile: "File ... is encrypted, password required"
            raise SplatFormatError(self.path, f"cannot read {name}: {_reason(exc)}") from None
        except (zipfile.BadZipFile, NotImplementedError, OSError, EOFError, ValueError) as exc:
            raise SplatFormatError(self.path, f"cannot inflate {name}: {_reason(exc)}") from None
        return data

    def size(self, name) -> int:
        if self.zip:
            try:
                return self.zip.getinfo(name).file_size
            except KeyError:
                raise SplatFormatError(self.path, f"SOG zip lacks {name}") from None
        return file_size(os.path.join(os.path.dirname(self.path), name))

    def meta(self) -> bytes:
        if self.zip:
            return self._member("meta.json", MAX_META)
        with OpenedFile(self.path) as f:
            if f.size > MAX_META:
                raise SplatFormatError(self.path, f"meta.json is larger than {MAX_META} bytes")
            data = f.read_rest(0)
            f.check_unchanged()
        return bytes(data)

    def image(self, name, max_pixels: int) -> np.ndarray:
        if not self.zip:
            local = os.path.join(os.path.dirname(self.path), name)
            file_size(local)  # names a missing image as such
            return read_rgba(local, max_pixels, self.label(name))
        local = os.path.join(self.tmp.name, "image.webp")
        with open(local, "wb") as f:  # a lossless WebP never needs much over 4 bytes a pixel
            f.write(self._member(name, 8 * max_pixels + 65536))
        return read_rgba(local, max_pixels, self.label(name))


def _reason(exc: Exception) -> str:
    """An exception's text, or what its type means when it has none (zlib's EOFError for a
    member whose compressed data ends early carries no message)."""
    text = str(exc).strip()
    if text:
        return text
    if isinstance(exc, EOFError):
        return "compressed data ends early (the file is truncated or corrupt)"
    return type(exc).__name__


def _number_list(path, meta, key, sub, length=None) -> np.ndarray:
    value = meta.get(key, {}).get(sub) if isinstance(meta.get(key), dict) else None
    ok = isinstance(value, list) and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                         for v in value)
    if ok and length is None:
        ok = 1 <= len(value) <= 256  # indexed by one byte
    elif ok:
        ok = len(value) == length
    arr = np.asarray(value, np.float64) if ok else None
    if arr is None or not np.isfinite(arr).all():
        want = f"{length} finite numbers" if length else "1..256 finite numbers"
        raise SplatFormatError(path, f"meta.json {key}.{sub} must be a list of {want}")
    return arr


def _file_names(path, meta, key, count) -> list:
    files = meta.get(key, {}).get("files") if isinstance(meta.get(key), dict) else None
    if not (isinstance(files, list) and len(files) >= count and all(isinstance(f, str) for f in files)):
        raise SplatFormatError(path, f"meta.json {key}.files must list {count} image name(s)")
    for name in files[:count]:  # names stay inside the SOG: no folders, no '..'
        if not name or name != os.path.basename(name) or name in (".", "..") or "\\" in name or "\0" in name:
            raise SplatFormatError(path, f"meta.json {key}.files names {name!r}, not a plain file name")
    return files[:count]


def _int_field(path, obj, key, lo, hi, where="") -> int:
    value = obj.get(key)
    if not isinstance(value, int) or isinstance(value, bool) or not lo <= value <= hi:
        raise SplatFormatError(path, f"meta.json {where}{key} must be an integer in {lo}..{hi}, "
                                     f"not {value!r}")
    return value


def parse_meta(path, raw: bytes) -> dict:
    meta = json_object(path, raw, "meta.json")
    if "version" not in meta:
        raise SplatFormatError(path, "SOG v1 (meta.json without a version) is not supported; "
                                     "re-export it as SOG v2")
    if meta["version"] != 2:
        raise SplatFormatError(path, f"unsupported SOG version {meta['version']!r} (supported: 2)")
    _int_field(path, meta, "count", 0, MAX_SPLATS)
    return meta


def _pixels(files, name, count, max_pixels) -> np.ndarray:
    img = files.image(name, max_pixels)
    if img.shape[0] * img.shape[1] < count:
        raise SplatFormatError(files.label(name), f"image is {img.shape[1]}x{img.shape[0]}, "
                                                  f"too small for {count} splats")
    return img.reshape(-1, 4)[:count]


def _positions(files, meta, count, max_pixels) -> np.ndarray:
    mins = _number_list(files.path, meta, "means", "mins", 3)
    maxs = _number_list(files.path, meta, "means", "maxs", 3)
    lo_name, hi_name = _file_names(files.path, meta, "means", 2)
    lo = _pixels(files, lo_name, count, max_pixels)[:, :3].astype(np.float64)
    v = lo + 256.0 * _pixels(files, hi_name, count, max_pixels)[:, :3]
    span = np.where(maxs - mins != 0, maxs - mins, 1.0)  # a flat axis decodes to its min
    t = mins + span * (v / 65535.0)
    return (np.sign(t) * np.expm1(np.abs(t))).astype(np.float32)


def _rotations(px: np.ndarray) -> np.ndarray:
    three = (px[:, :3] / 255.0 * 2 - 1) / math.sqrt(2)  # float64, as the reference decoder
    tag = px[:, 3].astype(np.intp) - 252
    valid = (tag >= 0) & (tag <= 3)
    dropped = np.where(valid, tag, 0)
    largest = np.sqrt(np.maximum(0.0, 1.0 - np.einsum("ij,ij->i", three, three)))
    wxyz = np.empty((px.shape[0], 4), np.float32)
    for j in range(4):  # slot j holds the rebuilt one, or stored component j - (j > dropped)
        src = np.clip(j - (j > dropped), 0, 2)
        stored = np.take_along_axis(three, src[:, None], axis=1)[:, 0]
        wxyz[:, j] = np.where(dropped == j, largest, stored)
    wxyz[~valid] = (1.0, 0.0, 0.0, 0.0)
    # three stored components whose squares sum past 1 leave the largest at 0 and |q| > 1
    # (up to sqrt(1.5)): normalise those; unit rows are left bit for bit as decoded
    return normalize_quats_(wxyz)


def _lookup(files, name, codebook: np.ndarray, idx: np.ndarray) -> np.ndarray:
    if idx.size and int(idx.max()) >= len(codebook):
        raise SplatFormatError(files.label(name), f"index {int(idx.max())} is past the "
                                                  f"{len(codebook)}-entry codebook")
    return codebook.astype(np.float32)[idx]


def _sh_rest(files, meta, count, max_pixels, max_degree) -> tuple[np.ndarray, int]:
    """The SH bands up to max_degree, and the degree the file holds (the import reports it)."""
    shn = meta.get("shN")
    if shn is None:
        return np.zeros((count, 0, 3), np.float32), 0
    if not isinstance(shn, dict):
        raise SplatFormatError(files.path, "meta.json shN must be an object")
    bands = _int_field(files.path, shn, "bands", 1, 3, "shN.")
    if max_degree == 0:
        return np.zeros((count, 0, 3), np.float32), bands
    palette = _int_field(files.path, shn, "count", 1, 65536, "shN.")
    codebook = _number_list(files.path, meta, "shN", "codebook")
    cen_name, lab_name = _file_names(files.path, meta, "shN", 2)
    k = sh_coeff_count(bands)
    cen = files.image(cen_name, 64 * k * 1024)
    if cen.shape[1] != 64 * k:
        raise SplatFormatError(files.label(cen_name), f"palette image is {cen.shape[1]} wide, "
                                                      f"expected {64 * k} for SH degree {bands}")
    lab = _pixels(files, lab_name, count, max_pixels)
    label = lab[:, 0].astype(np.intp) | (lab[:, 1].astype(np.intp) << 8)
    valid = (label < palette) & (label // 64 < cen.shape[0])
    label = np.where(valid, label, 0)
    keep = sh_coeff_count(min(bands, max_degree))
    # texel of entry e, coefficient j: row e // 64, column (e % 64) * k + j
    flat = ((label // 64) * cen.shape[1] + (label % 64) * k)[:, None] + np.arange(keep)
    idx = cen.reshape(-1, 4)[flat][..., :3]              # (N, keep, 3) codebook indices
    rest = _lookup(files, cen_name, codebook, idx)
    rest[~valid] = 0.0
    return rest, bands


def read_sog(path, max_degree: int = 3, max_splats=None) -> SplatSet:
    files = _Files(path)
    try:
        meta = parse_meta(path, files.meta())
        # the palette's band count is checked later; budget for the most a SOG can hold
        check_budget(files.path, meta["count"], 3 * sh_coeff_count(3) if meta.get("shN") else 0, max_splats)
        return _decode(files, meta, max_degree)
    finally:
        files.close()


def _decode(files, meta, max_degree) -> SplatSet:
    count = meta["count"]
    names = {key: _file_names(files.path, meta, key, 1)[0] for key in ("quats", "scales", "sh0")}
    packed = sum(files.size(n) for n in _file_names(files.path, meta, "means", 2) + list(names.values()))
    if count > SPLATS_PER_BYTE * packed + 4096:
        raise SplatFormatError(files.path, f"meta.json claims {count} splats, more than its "
                                           f"{packed} bytes of images can hold")
    # the writer's images are the smallest multiple-of-4 rectangle holding count texels
    max_pixels = 2 * count + 65536
    s = SplatSet.allocate(0, 0, AXES_RDF)
    s.positions = _positions(files, meta, count, max_pixels)
    s.rotations = _rotations(_pixels(files, names["quats"], count, max_pixels))
    idx = _pixels(files, names["scales"], count, max_pixels)[:, :3]
    s.scales = np.exp(_lookup(files, names["scales"], _number_list(files.path, meta, "scales", "codebook"), idx))
    sh0 = _pixels(files, names["sh0"], count, max_pixels)
    s.sh_dc = _lookup(files, names["sh0"], _number_list(files.path, meta, "sh0", "codebook"), sh0[:, :3])
    s.opacities = sh0[:, 3].astype(np.float32) / np.float32(255)
    s.sh_rest, s.sh_degree_in_file = _sh_rest(files, meta, count, max_pixels, max_degree)
    return s
