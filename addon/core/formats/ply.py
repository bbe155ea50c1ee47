"""INRIA 3DGS .ply: reader (binary little/big endian and ascii) and binary writer.

Vertex properties may come in any order and as any scalar type; normals and
unknown extra properties are ignored. f_rest is channel-major in the file
(f_rest_k, f_rest_{k+K}, f_rest_{k+2K} are r, g, b of coefficient k) and becomes
SplatSet.sh_rest (N, K, 3). Axis convention: RDF (COLMAP camera frame).

Speed: the binary body is read block by block (plyheader.Records: 2048 records into one
reused buffer; never a memory map, which a file shrinking mid-read turns into SIGBUS), and
each block's attribute groups are copied out through strided views while the block is in
the CPU's cache, so a 1M-splat degree-3 file costs a few hundred milliseconds and the body
is never held whole.
Not plyfile: its header parser has no size bound (docs/DESIGN.md, "PLY without plyfile";
bench/plyfile_bench.py).
"""
from __future__ import annotations

import numpy as np

from ..errors import SplatFormatError
from ..splats import AXES_RDF, RENDER_MAX_DEGREE, FILE_MAX_DEGREE, SplatSet, file_sh_degree, sh_coeff_count
from ._common import check_budget, logit, normalize_quats_, sigmoid_, write_file
from . import readfile
from .plyheader import element_records, parse_header, read_body
from .readfile import OpenedFile

POS = ("x", "y", "z")
SCALE = ("scale_0", "scale_1", "scale_2")
ROT = ("rot_0", "rot_1", "rot_2", "rot_3")
DC = ("f_dc_0", "f_dc_1", "f_dc_2")
REQUIRED = POS + SCALE + ROT + ("opacity",) + DC


def _block_view(rec: np.ndarray, names) -> np.ndarray | None:
    """(N, len(names)) view when the fields are adjacent and share one type; else None."""
    fields = rec.dtype.fields
    first_type, start = fields[names[0]][:2]
    for i, name in enumerate(names):
        dt, off = fields[name][:2]
        if dt != first_type or off != start + i * first_type.itemsize:
            return None
    return np.ndarray((rec.shape[0], len(names)), dtype=first_type, buffer=rec,
                      offset=start, strides=(rec.dtype.itemsize, first_type.itemsize))


def columns(rec: np.ndarray, names, dtype=np.float32) -> np.ndarray:
    """Copy the named fields into a contiguous (N, len(names)) array."""
    out = np.empty((rec.shape[0], len(names)), dtype)
    view = _block_view(rec, names) if rec.shape[0] else None
    if view is not None:
        np.copyto(out, view, casting="unsafe")
    else:
        for i, name in enumerate(names):
            np.copyto(out[:, i], rec[name], casting="unsafe")
    return out


def rest_names(rest_count: int) -> list:
    return [f"f_rest_{i}" for i in range(rest_count)]


BLOCK = 2048  # records per block: a block of records (~500 KB at degree 3) stays in cache


def _jobs(rec: np.ndarray, names, out: np.ndarray) -> list:
    """(source, destination) column copies filling out (N, len(names)) from the fields."""
    view = _block_view(rec, names)
    if view is not None:
        return [(view, out)]
    return [(rec[name], out[:, i]) for i, name in enumerate(names)]


def _record_blocks(rec):
    """(first index, records) blocks of a structured array, or of plyheader.Records as they
    are read from the file."""
    if isinstance(rec, np.ndarray):
        return ((i, rec[i:i + BLOCK]) for i in range(0, rec.shape[0], BLOCK))
    return rec.blocks()


def gather(rec, groups, k: int = 0, keep: int = 0):
    """One pass over the records, block by block, filling every group at once.

    rec: a structured array, or plyheader.Records (the file read block by block: the body
    is never held whole). groups: [(field names, dtype)] -> contiguous (N, len(names))
    arrays. With k > 0 also returns the channel-major f_rest (3 * k fields) as (N, keep, 3)
    coefficient-major SH, stored as a view of coefficient planes (keep, N, 3): each
    sh_rest[:, j] is one contiguous (N, 3) array, which Blender's attribute upload takes
    without a copy.
    Why blocks: a separate strided pass per group pulls every cache line of the 248-byte
    records once per group; one blocked pass reads them once (measured 2-4x faster for
    the SH of 1M degree-3 records than a direct strided transpose)."""
    n = rec.shape[0]
    outs = [np.empty((n, len(names)), dtype) for names, dtype in groups]
    rest = np.empty((keep, n, 3), np.float32).transpose(1, 0, 2)
    if n == 0:
        return outs, rest
    names = rest_names(3 * k)
    tmp = None
    for i, block in _record_blocks(rec):
        b = block.shape[0]
        for (group, _), out in zip(groups, outs):
            for src, dst in _jobs(block, group, out[i:i + b]):
                np.copyto(dst, src, casting="unsafe")
        sh_view = _block_view(block, names) if keep else None
        if keep and sh_view is None:
            for c in range(3):
                for j in range(keep):
                    np.copyto(rest[i:i + b, j, c], block[names[c * k + j]], casting="unsafe")
        elif keep:
            tmp = np.empty((b, 3, k), sh_view.dtype) if tmp is None or tmp.shape[0] < b else tmp
            np.copyto(tmp[:b], sh_view.reshape(b, 3, k))
            np.copyto(rest[i:i + b], tmp[:b, :, :keep].transpose(0, 2, 1), casting="unsafe")
    return outs, rest


def sh_rest_from(rec: np.ndarray, k: int, keep: int) -> np.ndarray:
    """Channel-major f_rest (3 * k fields) -> (N, keep, 3) coefficient-major float32,
    as coefficient planes (see gather)."""
    return gather(rec, (), k, keep)[1]


def decode_vertices(path, rec: np.ndarray, max_degree: int = 3) -> SplatSet:
    """INRIA vertex records -> SplatSet with activations applied."""
    present = set(rec.dtype.names)
    missing = [p for p in REQUIRED if p not in present]
    if missing:
        raise SplatFormatError(path, f"vertex element lacks required properties: {', '.join(missing)}")
    rest_count = sum(1 for p in present if p.startswith("f_rest_"))
    if rest_count % 3:
        raise SplatFormatError(path, f"{rest_count} f_rest properties is not a multiple of 3")
    try:
        degree = file_sh_degree(rest_count // 3)
    except ValueError:
        raise SplatFormatError(path, f"{rest_count} f_rest properties match no SH degree "
                                     f"0..{FILE_MAX_DEGREE}") from None
    missing = [p for p in rest_names(rest_count) if p not in present]
    if missing:
        raise SplatFormatError(path, f"f_rest properties are not numbered 0..{rest_count - 1}: lacks {missing[0]}")
    k = rest_count // 3
    # exp and sigmoid in float64, rounded once: the writer's float64 log and logit then
    # invert them to within half a float32 step (cheap: 4 of the 62 values per splat)
    f32, f64 = np.float32, np.float64
    (positions, scales, opacities, rotations, sh_dc), sh_rest = gather(
        rec, [(POS, f32), (SCALE, f64), (("opacity",), f64), (ROT, f32), (DC, f32)],
        k, sh_coeff_count(min(degree, max_degree, RENDER_MAX_DEGREE)))
    return SplatSet(
        positions=positions,
        scales=np.exp(scales, out=scales).astype(np.float32),
        rotations=normalize_quats_(rotations),
        opacities=sigmoid_(opacities[:, 0]).astype(np.float32),
        sh_dc=sh_dc,
        sh_rest=sh_rest,
        axes=AXES_RDF,
        sh_degree_in_file=degree,
    )


def read_ply(path, max_degree: int = 3, max_splats=None) -> SplatSet:
    with OpenedFile(path) as f:
        header = parse_header(f)
        rec = _vertex_records(path, f, header, max_splats)
        splats = decode_vertices(path, rec, max_degree)  # reads a binary body as it decodes
        f.check_unchanged()
    splats.antialiased = antialiased_by_comments(header.comments)
    return splats


def _vertex_records(path, f: OpenedFile, header, max_splats):
    vertex = header.element("vertex")
    if vertex is None:
        raise SplatFormatError(path, "PLY has no vertex element")
    if header.element("chunk") is not None:
        raise SplatFormatError(path, "this is a compressed PLY (chunk element); read it as compressed_ply")
    if "trbf_center" in vertex.names():  # read as a still, its colours and time would be lost
        raise SplatFormatError(path, "a dynamic (4D) capture (trbf_center): import or convert it "
                                     "as one, or bake one moment with `convert --time T`")
    rest = sum(1 for name in vertex.names() if name.startswith("f_rest_"))
    check_budget(path, vertex.count, rest, max_splats)
    if header.encoding == "ascii":
        return read_body(f, header)["vertex"]
    per_block = min(BLOCK, readfile.BLOCK // max(1, vertex.dtype("<").itemsize))  # 0 properties: 0 bytes
    return element_records(f, header, "vertex", per_block)


# The PLY header comments that mark a capture trained with anti-aliasing, as splat-transform
# reads them: Brush's `SplatRenderMode: default | mip | 2dgs` and Postshot's `antialiased 0 | 1`,
# case-insensitive, the last one that says something wins. Written back as Brush's form.
MODE_KEY, POSTSHOT_KEY = "splatrendermode:", "antialiased "
ANTIALIASED_COMMENT = "SplatRenderMode: mip"


def antialiased_by_comments(comments) -> bool:
    flag = False
    for text in comments:
        lower = text.strip().lower()
        if lower.startswith(MODE_KEY):
            mode = lower[len(MODE_KEY):].strip()
            if mode in ("default", "mip"):  # 2dgs is another model, not an anti-aliased one
                flag = mode == "mip"
        elif lower.startswith(POSTSHOT_KEY) and lower[len(POSTSHOT_KEY):].strip() in ("0", "1"):
            flag = lower[len(POSTSHOT_KEY):].strip() == "1"
    return flag


def ply_dtype(degree: int) -> np.dtype:
    """The standard INRIA property order, float32 little endian."""
    names = list(POS) + ["nx", "ny", "nz"] + list(DC) + rest_names(3 * sh_coeff_count(degree))
    names += ["opacity"] + list(SCALE) + list(ROT)
    return np.dtype([(n, "<f4") for n in names])


def encode_vertices(splats: SplatSet) -> np.ndarray:
    """SplatSet -> INRIA vertex records (log scales, logit opacity, channel-major f_rest)."""
    n, k = splats.count, sh_coeff_count(splats.sh_degree)
    rec = np.zeros(n, ply_dtype(splats.sh_degree))
    flat = rec.view(np.float32).reshape(n, len(rec.dtype.names))
    flat[:, 0:3] = splats.positions
    flat[:, 6:9] = splats.sh_dc
    if k:
        flat[:, 9:9 + 3 * k] = splats.sh_rest.transpose(0, 2, 1).reshape(n, 3 * k)
    o = 9 + 3 * k
    flat[:, o] = logit(splats.opacities)
    with np.errstate(divide="ignore"):
        flat[:, o + 1:o + 4] = np.log(splats.scales.astype(np.float64))
    flat[:, o + 4:o + 8] = splats.rotations
    return rec


def write_ply(path, splats: SplatSet) -> None:
    splats.check()
    rec = encode_vertices(splats)
    lines = ["ply", "format binary_little_endian 1.0", "comment written by Splatline"]
    lines += [f"comment {ANTIALIASED_COMMENT}"] if splats.antialiased else []
    lines += [f"element vertex {splats.count}"]
    lines += [f"property float {name}" for name in rec.dtype.names] + ["end_header", ""]
    write_file(path, "\n".join(lines).encode("ascii"), rec)
