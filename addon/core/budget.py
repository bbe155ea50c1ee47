"""The one memory budget: what a file or an option would make Splatline allocate, checked
before allocating it.

The budget is `--max-memory` (set_max_memory) where given, else what fits in available
memory (MemAvailable, or free physical pages) with HEADROOM kept back. An estimate counts
what the process already holds (its resident set), so the budget bounds the peak, not only
the new allocation. Estimates (each the caller's, from the counts a header claims, before
anything is decompressed or allocated):
- splats: count x (BASE_BYTES_PER_SPLAT + SH_BYTES_PER_FLOAT x higher-SH floats), formats/_common;
- frame buffers: width x height x passes x bytes per pixel (frame_bytes);
- what the command does with the splats once read, while it holds them (`after_read`, set by
  the command before it reads, counted by the read's own check): a writer's encoding
  (Format.write_bytes), Blender's copy (import), Blender's copy and the renderer's buffers
  (render: RENDER_BYTES_PER_SPLAT). So a file that cannot be converted, imported or rendered
  within the budget is refused at its header, before any work.
Each figure is an upper bound of peaks measured on bpy 5.0 at 1M splats, degrees 0 and 3
(bench/memory_budget_bench.py prints estimate against measured peak per command).
A refusal is one line (BudgetError, a SplatFormatError): the file or option, what it would
take, the budget, and the flag that allows it.
"""
from __future__ import annotations

import os
import re

from .errors import SplatFormatError

HEADROOM = 0.8  # of available memory, the default budget
_max_memory: int | None = None
_after_read = [None]  # (count, rest_floats) -> bytes: what follows the read (after_read)
_largest = [0]  # the largest peak an estimate has foreseen in this process (bench/memory_budget_bench)


class BudgetError(SplatFormatError):
    """An input or option that would need more memory than the budget."""


def set_max_memory(nbytes: int | None) -> None:
    """The budget in bytes for this process (the --max-memory flag); None: the default."""
    global _max_memory
    _max_memory = nbytes


def parse_size(text: str) -> int:
    """'1.5G', '800M', '2GiB', '123456' (bytes) -> bytes. ValueError on anything else."""
    match = re.fullmatch(r"\s*(\d+(?:\.\d*)?|\.\d+)\s*([KMGT]?)(?:i?B)?\s*", text or "", re.IGNORECASE)
    if match is None:
        raise ValueError(f"{text!r} is not a size (e.g. 1.5G, 800M)")
    scale = 1 << (10 * " KMGT".index(match.group(2).upper() or " "))
    value = int(float(match.group(1)) * scale)
    if value <= 0:
        raise ValueError(f"{text!r} is not a positive size")
    return value


def after_read(cost) -> None:
    """What the command will allocate while it holds the splats it reads: a function of
    (count, higher-SH floats per splat) -> bytes, or None. The read's check adds it."""
    _after_read[0] = cost


def planned(count: int, rest_floats: int) -> int:
    cost = _after_read[0]
    return 0 if cost is None else int(cost(count, rest_floats))


# The renderer's share per splat of a frame (measured, bench/memory_budget_bench.py: 1M splats,
# 1080p-4K, peak minus Blender's copy and the frame buffers): the engine's gathered arrays, its
# preprocessed and sorted copies, the GL buffers; and per higher-SH float.
RENDER_BYTES_PER_SPLAT = 420
RENDER_BYTES_PER_SH_FLOAT = 8


def render_bytes(count: int, rest_floats: int) -> int:
    return int(count) * (RENDER_BYTES_PER_SPLAT + RENDER_BYTES_PER_SH_FLOAT * int(rest_floats))


def human(nbytes: float) -> str:
    for unit, scale in (("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if nbytes >= scale:
            return f"{nbytes / scale:.1f} {unit}"
    return f"{int(nbytes)} bytes"


def available_memory() -> int | None:
    """Bytes the system could give this process now: MemAvailable on Linux, free physical
    pages on other POSIX systems; None where neither is known (then no default budget)."""
    try:
        with open("/proc/meminfo", "rb") as f:
            for line in f:
                if line.startswith(b"MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):
        return None


def resident() -> int:
    """This process's resident set now (0 where unknown)."""
    try:
        with open("/proc/self/statm", "rb") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError, AttributeError):
        return 0


def limit() -> tuple[int | None, str]:
    """(bytes the process may hold at its peak, where that figure comes from)."""
    if _max_memory is not None:
        return _max_memory, "--max-memory"
    avail = available_memory()
    if avail is None:
        return None, "unknown"
    return resident() + int(avail * HEADROOM), f"{HEADROOM:.0%} of available memory"


def check(what, nbytes: int, allow: str, detail: str = "") -> None:
    """Refuse `what` (a file path or an option) when holding `nbytes` more would pass the
    budget. `allow` names the flag that raises it; `detail` says what the estimate counts."""
    held = resident()
    _largest[0] = max(_largest[0], held + int(nbytes))
    budget, source = limit()
    if budget is None:
        return
    if held + nbytes > budget:
        counted = f" ({detail})" if detail else ""
        in_use = f", {human(held)} of it in use" if held else ""
        raise BudgetError(what, f"would take {human(nbytes)}{counted}, more than the memory budget "
                                f"of {human(budget)} ({source}{in_use}); allow it with {allow}")


FRAME_BYTES_PER_PIXEL = 4 * 4 + 4  # RGBA float32 + a float32 depth
# the renderer's target and its film target (gl/film.py), their read-backs, Blender's render
# result and the file's buffer (without a film pass, the CPU conversion's output stands in
# for the film's two)
FRAME_COPIES = 8  # measured: 4K costs 150 bytes a pixel more than 1080p (bench/memory_budget_bench)


def largest_estimate() -> int:
    """The largest peak (resident set + what a check allowed) foreseen so far in this process."""
    return _largest[0]


def frame_bytes(width: int, height: int, passes: int = 1) -> int:
    """What one frame of width x height costs in buffers, for each pass held."""
    return int(width) * int(height) * FRAME_BYTES_PER_PIXEL * FRAME_COPIES * max(1, passes)
