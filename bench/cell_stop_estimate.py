"""What a per-cell early-termination prepass could save on the final-frame bench's colour
frame (issue 14's llvmpipe goal), estimated in numpy before building it.

    python -m bench.cell_stop_estimate [cell]

The idea: a low-resolution pass composites, for each cell of cell x cell pixels and each
splat in front-to-back order, the splat's least alpha over the cell's pixel centres
(alpha's exponent is convex, so its least value over the cell is at one of the four corner
pixels). The transmittance that leaves is an upper bound for every pixel of the cell, so
the rank where it falls below 1e-4 is a rank after which the whole cell is saturated. Drawn
into the depth buffer with the rank as depth, it would stop every cell in one draw, no
batches; a splat whose footprint lies only in stopped cells could be culled whole.

Printed: the splats and (splat, cell) pairs of the frame; the fragments at alpha >= 1/255
with no early termination; the share of cells that get a stop; the fragments after their
cell's stop (depth-rejected or culled), and of those the ones in splats culled whole; the
pairs with a least alpha >= 1/255 (the prepass's own fragments, at the least).
Compare with `python -m bench colour`'s counts of the renderer as it is.
"""
from __future__ import annotations

import sys

import numpy as np

from addon.core.preprocess import extent_sigmas, project
from bench.common import cell_blocks
from bench.final_frame_bench import COUNT, SIZE
from bench.playbot_scene import scene

T_STOP = 1e-4
ALPHA_MIN, ALPHA_MAX = 1 / 255, 0.99
CHUNK = 4_000_000  # pairs per numpy step (bounds the memory)


def front_to_back(items, cam) -> dict:
    """Centre, conic, opacity of every projected splat of the frame, nearest first."""
    parts = [project(item, cam) for item in items]
    keep = [p.valid & (p.opacity * 255 >= 1) for p in parts]
    depth = np.concatenate([p.depth[k] for p, k in zip(parts, keep)])
    order = np.argsort(depth, kind="stable")
    cat = {name: np.concatenate([getattr(p, name)[k] for p, k in zip(parts, keep)])[order]
           for name in ("means2d", "conic", "opacity")}
    return {"x": cat["means2d"][:, 0], "y": cat["means2d"][:, 1], "A": cat["conic"][:, 0],
            "B": cat["conic"][:, 1], "C": cat["conic"][:, 2], "o": cat["opacity"]}


def pairs(s: dict, cell: int, cols: int, rows: int):
    """(splat, cell column, cell row) for every cell the splat's 1/255 box touches."""
    det = s["A"] * s["C"] - s["B"] ** 2
    e = extent_sigmas(s["o"])
    hx, hy = e * np.sqrt(s["C"] / det), e * np.sqrt(s["A"] / det)
    lo_x, hi_x = np.floor((s["x"] - hx) / cell), np.floor((s["x"] + hx) / cell)
    lo_y, hi_y = np.floor((s["y"] - hy) / cell), np.floor((s["y"] + hy) / cell)
    inside = (hi_x >= 0) & (lo_x < cols) & (hi_y >= 0) & (lo_y < rows)
    x0, x1 = np.clip(lo_x, 0, cols - 1).astype(np.int64), np.clip(hi_x, 0, cols - 1).astype(np.int64)
    y0, y1 = np.clip(lo_y, 0, rows - 1).astype(np.int64), np.clip(hi_y, 0, rows - 1).astype(np.int64)
    nx, ny = np.where(inside, x1 - x0 + 1, 0), np.where(inside, y1 - y0 + 1, 0)
    return cell_blocks(x0, y0, nx, ny)


def cell_alphas(s: dict, sid, cx, cy, cell: int):
    """Per pair: the least alpha over the cell's pixels (0 where any is below 1/255) and
    how many of its pixels reach 1/255 (the fragments the splat adds there)."""
    least = np.empty(len(sid))
    frags = np.empty(len(sid), np.int32)
    for i in range(0, len(sid), CHUNK):
        j = sid[i:i + CHUNK]
        m, f = np.full(len(j), np.inf), np.zeros(len(j), np.int32)
        for py in range(cell):
            dy = cy[i:i + CHUNK] * cell + py + 0.5 - s["y"][j]
            for px in range(cell):
                dx = cx[i:i + CHUNK] * cell + px + 0.5 - s["x"][j]
                q = s["A"][j] * dx * dx + 2 * s["B"][j] * dx * dy + s["C"][j] * dy * dy
                a = np.minimum(ALPHA_MAX, s["o"][j] * np.exp(-0.5 * q))
                a = np.where(a >= ALPHA_MIN, a, 0.0)
                m, f = np.minimum(m, a), f + (a > 0)
        least[i:i + CHUNK], frags[i:i + CHUNK] = m, f
    return least, frags


def late_pairs(sid, cells, least):
    """Per pair (in its given order): True where the splat comes after its cell's stop;
    and the share of cells that stop at all."""
    by = np.lexsort((sid, cells))  # each cell's pairs, front to back
    c, s, log_t = cells[by], sid[by], np.log1p(-least[by])
    total = np.cumsum(log_t)
    starts = np.r_[0, np.nonzero(np.diff(c))[0] + 1]
    before = np.repeat(total[starts] - log_t[starts], np.diff(np.r_[starts, len(c)]))
    crossed = total - before < np.log(T_STOP)
    stop = np.full(int(c.max()) + 1, np.iinfo(np.int64).max)
    np.minimum.at(stop, c[crossed], s[crossed])
    late = np.empty(len(c), bool)
    late[by] = s > stop[c]
    touched = np.unique(c)
    return late, float((stop[touched] < np.iinfo(np.int64).max).mean())


def main(cell: int = 4):
    items, cam = scene(COUNT, *SIZE)
    s = front_to_back(items, cam)
    cols, rows = -(-SIZE[0] // cell), -(-SIZE[1] // cell)
    sid, cx, cy = pairs(s, cell, cols, rows)
    least, frags = cell_alphas(s, sid, cx, cy, cell)
    late, stopped = late_pairs(sid, cy * cols + cx, least)
    whole = np.ones(len(s["o"]), bool)
    np.logical_and.at(whole, sid, late)
    whole &= np.bincount(sid, minlength=len(whole)) > 0
    touching = int((np.bincount(sid, minlength=len(s["o"])) > 0).sum())
    print(f"{touching:,} splats reach the frame, {len(sid) / 1e6:.1f} M (splat, {cell}x{cell} cell) pairs")
    print(f"fragments at alpha >= 1/255, no early termination: {frags.sum() / 1e6:.0f} M")
    print(f"cells (of those any splat reaches) with a stop: {stopped:.0%}; fragments after their cell's stop: "
          f"{frags[late].sum() / 1e6:.0f} M, of them in splats culled whole: "
          f"{frags[whole[sid]].sum() / 1e6:.0f} M ({whole.sum():,} splats)")
    print(f"prepass fragments: pairs with least alpha >= 1/255 {(least > 0).sum() / 1e6:.1f} M")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 4)
