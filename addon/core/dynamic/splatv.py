""".splatv (splaTV by antimatter15; read by the npm package gsplat's SplatvLoader).

File: u32 magic 0x674B, u32 JSON length, a JSON list of chunks; the first chunk's `size`
bytes follow the JSON (gsplat reads only the first chunk, and so does Splatline). That data
is a texture of `texwidth` x `texheight` RGBA32UI texels, 4 texels (64 bytes) a splat,
1024 splats a row, zero-padded to whole rows. Per splat, little endian (gsplat's
VideoRenderProgram shader reads these words):
  words 0-2   float32 centre x, y, z
  words 3-4   half rotation w, x, y, z (normalised after adding omega Delta)
  words 5-6   half linear scale x, y, z, 0
  word  7     RGBA8: plain RGB (Spacetime's f_dc) and the base opacity (after the sigmoid)
  words 8-12  half motion_0..8, 0 (centre + m1 Delta + m2 Delta^2 + m3 Delta^3)
  words 13-14 half omega_0..3
  word  15    half trbf_center, linear trbf scale (opacity x exp(-(Delta / scale)^2))
The Spacetime model; t runs over [0, 1] (splaTV's viewer loops it).
"""
from __future__ import annotations

import json
import math

import numpy as np

from ..errors import SplatFormatError
from ..formats.readfile import OpenedFile
from ..formats._common import check_budget, file_size, write_file
from ..sh import C0
from ..splats import AXES_RDF
from .capture import DynamicCapture
from .ply_read import drop_bad

MAGIC = 0x674B
RECORD = np.dtype([("position", "<f4", 3), ("rotation", "<f2", 4), ("scale", "<f2", 4), ("rgba", "u1", 4),
                   ("motion", "<f2", 10), ("omega", "<f2", 4), ("trbf", "<f2", 2)])
assert RECORD.itemsize == 64
ROW_SPLATS = 1024
MAX_JSON = 16 << 20


def sniff(head: bytes) -> bool:
    return len(head) >= 8 and int.from_bytes(head[:4], "little") == MAGIC


def _chunk(path, size: int) -> tuple[dict, int]:
    """(first chunk, offset of its data), each length checked against the file first."""
    with open(path, "rb") as f:
        head = f.read(8)
        if not sniff(head):
            raise SplatFormatError(path, "not a .splatv file (bad magic)")
        length = int.from_bytes(head[4:8], "little")
        if length > min(size - 8, MAX_JSON):
            raise SplatFormatError(path, f"truncated: its chunk list claims {length} bytes, the file holds {size - 8}")
        text = f.read(length)
    try:
        chunks = json.loads(text.decode("utf-8"))
    except (ValueError, UnicodeDecodeError, RecursionError) as exc:
        raise SplatFormatError(path, f"chunk list is not JSON: {exc}") from None
    if not isinstance(chunks, list) or not chunks or not isinstance(chunks[0], dict):
        raise SplatFormatError(path, "chunk list is not a non-empty JSON list of objects")
    first = chunks[0]
    if first.get("type") != "splat":
        raise SplatFormatError(path, f"first chunk has type {first.get('type')!r}, not 'splat'")
    nbytes = first.get("size")
    if not isinstance(nbytes, int) or isinstance(nbytes, bool) or nbytes < 0 or nbytes % RECORD.itemsize:
        raise SplatFormatError(path, f"chunk size {nbytes!r} is not a whole number of {RECORD.itemsize}-byte splats")
    if nbytes > size - 8 - length:
        raise SplatFormatError(path, f"truncated: the splat chunk claims {nbytes} bytes, the file holds "
                                     f"{size - 8 - length} after its chunk list")
    return first, 8 + length


def read_splatv(path, max_splats=None) -> DynamicCapture:
    size = file_size(path)
    chunk, offset = _chunk(path, size)
    count = chunk["size"] // RECORD.itemsize
    check_budget(path, count, 24, max_splats)
    with OpenedFile(path) as f:  # read, checked block by block and unchanged after
        rec = f.read_array(RECORD, count, offset)
        f.check_unchanged()
    filled = np.flatnonzero(rec.view(np.uint8).reshape(count, -1).any(axis=1))
    rec = rec[:filled[-1] + 1 if filled.size else 0]  # all-zero records after the last splat are row padding
    return decode(path, rec)


def decode(path, rec: np.ndarray) -> DynamicCapture:
    n, f32 = rec.shape[0], np.float32
    rgba = rec["rgba"].astype(np.float64) / 255.0
    capture = DynamicCapture(
        model="spacetime", positions=np.ascontiguousarray(rec["position"]),
        motion=rec["motion"][:, :9].astype(f32).reshape(n, 3, 3),
        rotations=rec["rotation"].astype(f32), omega=rec["omega"].astype(f32),
        scales=rec["scale"][:, :3].astype(f32), opacities=rgba[:, 3].astype(f32),
        sh_dc=((rgba[:, :3] - 0.5) / C0).astype(f32), sh_rest=np.zeros((n, 0, 3), f32),
        t_center=rec["trbf"][:, 0].astype(f32), t_scale=rec["trbf"][:, 1].astype(f32),
        axes=AXES_RDF, source=".splatv")
    negative = capture.t_scale < 0  # the shader squares Delta / scale, so the sign is immaterial
    capture.t_scale[negative] *= -1
    return drop_bad(capture)


def _half(path, what: str, values: np.ndarray) -> np.ndarray:
    """values as float16, refusing finite values that overflow it."""
    with np.errstate(over="ignore"):
        half = values.astype(np.float16)
    over = np.isfinite(values) & ~np.isfinite(half)
    if over.any():
        raise SplatFormatError(path, f"{int(over.any(axis=-1).sum()) if over.ndim > 1 else int(over.sum())} "
                                     f"splats have a {what} beyond the half-float range (65504) of .splatv")
    return half


def encode_splatv(path, capture: DynamicCapture) -> bytes:
    if capture.model == "4dgs" or capture.unit != "segment" or capture.segments != 1:
        raise SplatFormatError(path, "a .splatv holds one Spacetime segment (t in [0, 1]); this capture is "
                                     f"{capture.model}, {capture.segments} segment(s), in {capture.unit}")
    n = capture.count
    rows = math.ceil(n / ROW_SPLATS) if n else 1
    rec = np.zeros(rows * ROW_SPLATS, RECORD)
    rec["position"][:n] = capture.positions
    rec["rotation"][:n] = _half(path, "rotation", capture.rotations)
    rec["scale"][:n, :3] = _half(path, "scale", capture.scales)
    rgb = np.clip(np.rint((C0 * capture.sh_dc.astype(np.float64) + 0.5) * 255.0), 0, 255)
    rec["rgba"][:n, :3] = rgb
    rec["rgba"][:n, 3] = np.clip(np.rint(capture.opacities.astype(np.float64) * 255.0), 0, 255)
    rec["motion"][:n, :3 * capture.motion.shape[1]] = _half(path, "motion", capture.motion.reshape(n, -1))
    if capture.omega is not None:
        rec["omega"][:n] = _half(path, "omega", capture.omega)
    rec["trbf"][:n, 0] = _half(path, "trbf_center", capture.t_center)
    rec["trbf"][:n, 1] = _half(path, "trbf scale", capture.t_scale)
    chunks = [{"type": "splat", "size": rec.nbytes, "texwidth": 4 * ROW_SPLATS, "texheight": rows,
               "cameras": []}]
    text = json.dumps(chunks).encode("utf-8")
    head = np.array([MAGIC, len(text)], "<u4").tobytes()
    return head + text + rec.tobytes()


def write_splatv(path, capture: DynamicCapture) -> None:
    write_file(path, encode_splatv(path, capture))
