"""Stage "sort": back-to-front order of every splat in the frame.

Keys are core/sort.py's: depth quantised over the visible range to 16 or 32 bits,
key 0 = farthest. The GPU path computes them in a compute shader (float64, like numpy)
and runs a stable LSD radix sort, 8 bits per pass (2 passes for 16-bit keys, 4 for
32-bit). The CPU path reads the depths back and uses core.sort.back_to_front (numpy's
stable argsort). Both put the lower global index in front on equal keys (both sort
the reversed sequence stably), so with the same keys they give the same order.
Which one runs is sorts_on_gpu's choice.
"""
from __future__ import annotations

import numpy as np

from ..core.sort import back_to_front
from . import shaders
from .software import is_software

BLOCK_SIZE = 2048  # elements per work group in the radix passes
B_DEPTH, B_RANGE, B_KEYS, B_VALS, B_HIST, B_KEYS2, B_VALS2 = 6, 7, 8, 9, 10, 11, 12


class RadixSorter:
    def __init__(self, ctx):
        self.ctx = ctx
        defs = {"BLOCK_SIZE": f"{BLOCK_SIZE}u"}
        self.keys_cs = ctx.compute_shader(shaders.source("gl_sort_keys.comp", math=False))
        self.hist_cs = ctx.compute_shader(shaders.source("gl_radix_hist.comp", False, defs))
        self.scan_cs = ctx.compute_shader(shaders.source("gl_radix_scan.comp", False))
        self.scatter_cs = ctx.compute_shader(shaders.source("gl_radix_scatter.comp", False, defs))
        self.hist = None

    def make_keys(self, n: int, bits: int, depth_buf, range_buf, keys_buf, vals_buf):
        depth_buf.bind_to_storage_buffer(B_DEPTH)
        range_buf.bind_to_storage_buffer(B_RANGE)
        keys_buf.bind_to_storage_buffer(B_KEYS)
        vals_buf.bind_to_storage_buffer(B_VALS)
        self.keys_cs["u_count"] = n
        self.keys_cs["u_top"] = 0xFFFF if bits == 16 else 0xFFFFFFFF
        self.keys_cs.run((n + 255) // 256)
        self.ctx.memory_barrier()

    def sort(self, n: int, bits: int, keys, vals, keys2, vals2):
        """Sort (keys, vals) in place by key, stably; keys2/vals2 are scratch."""
        blocks = (n + BLOCK_SIZE - 1) // BLOCK_SIZE
        length = 256 * blocks
        if self.hist is None or self.hist.size < 4 * length:
            if self.hist is not None:
                self.hist.release()
            self.hist = self.ctx.buffer(reserve=4 * length)
        src, dst = (keys, vals), (keys2, vals2)
        for shift in range(0, bits, 8):
            src[0].bind_to_storage_buffer(B_KEYS)
            src[1].bind_to_storage_buffer(B_VALS)
            dst[0].bind_to_storage_buffer(B_KEYS2)
            dst[1].bind_to_storage_buffer(B_VALS2)
            self.hist.bind_to_storage_buffer(B_HIST)
            for cs in (self.hist_cs, self.scatter_cs):
                cs["u_count"] = n
                cs["u_shift"] = shift
                cs["u_num_blocks"] = blocks
            self.scan_cs["u_length"] = length
            self.hist_cs.run(blocks)
            self.ctx.memory_barrier()
            self.scan_cs.run(1)
            self.ctx.memory_barrier()
            self.scatter_cs.run(blocks)
            self.ctx.memory_barrier()
            src, dst = dst, src
        # an even number of passes (bits / 8 is 2 or 4): the result is back in keys, vals

    def release(self):
        for obj in (self.keys_cs, self.hist_cs, self.scan_cs, self.scatter_cs, self.hist):
            if obj is not None:
                obj.release()


def sorts_on_gpu(choice: bool | None, gl_renderer: str) -> bool:
    """Whether a frame's order comes from the compute passes: `choice`
    (RenderOptions.gpu_sort) where it is given; by default yes, unless the GL is a software
    rasteriser. There the compute passes share the CPU with numpy's radix sort and take
    several times as long for the same order (final-frame bench, 500,000 splats on
    llvmpipe: about 90 ms wall against 20 ms, read-back and upload included)."""
    if choice is not None:
        return choice
    return not is_software(gl_renderer)


def cpu_order(depth: np.ndarray, bits: int) -> np.ndarray:
    """Back-to-front global indices of the visible splats (depth is +inf where culled).
    The culled slots are dropped before the sort rather than after (a third of the bench
    frame's): the same keys (their range is the visible depths') and the same order, as
    equal keys still put the lower index in front."""
    visible = np.flatnonzero(np.isfinite(depth)).astype(np.uint32)
    return visible[back_to_front(depth[visible], bits)]
