"""Seeded fuzzing of every reader: a few thousand mutated copies of the real test files
(and of v3-gzip and ascii variants of them), each read with the default bad="fix" (every
4th with "drop"). A read either succeeds and keeps the reader promises, or raises
SplatFormatError naming the file; any other exception is a bug. Each case has its own
generator, default_rng((11, crc32(seed name), case)), so a reported case rebuilds alone.
3,000 inputs take about 15 s on the 2-core CI machine (no time assertion: the machine is
shared, and a slow run is not a reader bug). On the code before the fixes it led to, 160 of
them broke a promise (|q| 1.22 from compressed PLY, NaN or zero quaternions, scales <= 0).
"""
from __future__ import annotations

import gzip
import resource
import struct
import time
import zlib

import numpy as np
import zstandard

from testing.spz_encode import encode
from addon.core.errors import SplatFormatError
from addon.core.formats import read
from testing.synth import write_ply_variant
from testing.reader_checks import FUZZ_BUDGET as BUDGET, check_promises

CASES_PER_SEED = 500
SPECIAL = np.array([np.nan, np.inf, -np.inf, 0.0, -0.0, 1e-30, 3e38, -3e38, -1.0, 1e-45, 1e-23, 100.0,
                    -200.0], np.float32).view(np.uint32).tolist() + [0xFFFFFFFF, 0x80000000]
def _seeds(testdata, tmp_path_factory) -> dict:
    """name -> (extension, bytes): the real files plus variants no testdata file covers."""
    seeds = {name.replace("test64.", "").replace(".", "_"): (name.split(".", 1)[1], (testdata / name).read_bytes())
             for name in ("test64.ply", "test64.compressed.ply", "test64.splat", "test64.spz")}
    splats = read(testdata / "test64.spz")
    seeds["spz_v3"] = ("spz", encode(splats, 3))
    ascii_path = tmp_path_factory.mktemp("seed") / "ascii.ply"
    write_ply_variant(ascii_path, read(testdata / "test64.ply"), encoding="ascii")
    seeds["ascii_ply"] = ("ply", ascii_path.read_bytes())
    # headers claiming 10M splats over a few bytes (a gzip'd v2 of zeros, as the
    # 185 KB file that took 2.76 GB; a v4 whose count says 10M over test64's streams)
    head = struct.pack("<4sIIBBBB", b"NGSP", 2, 10_000_000, 0, 12, 0, 0)
    seeds["spz_v2_zeros_claims_10m"] = ("spz", gzip.compress(head + bytes(19 * 64)))
    v4 = bytearray(seeds["spz"][1])
    struct.pack_into("<I", v4, 8, 10_000_000)
    seeds["spz_v4_claims_10m"] = ("spz", bytes(v4))
    return seeds


def _body_start(data: bytes) -> int:
    end = data.find(b"end_header\n")
    return end + len(b"end_header\n") if end >= 0 else 0


def _flip_bits(rng, data: bytearray, lo: int) -> None:
    for _ in range(rng.integers(1, 9)):
        i = int(rng.integers(lo, len(data)))
        data[i] ^= 1 << int(rng.integers(8))


def _special_floats(rng, data: bytearray, lo: int) -> None:
    for _ in range(rng.integers(1, 6)):
        i = lo + 4 * int(rng.integers(0, max(1, (len(data) - lo) // 4)))
        if i + 4 <= len(data):
            data[i:i + 4] = struct.pack("<I", SPECIAL[int(rng.integers(len(SPECIAL)))])


def _random_bytes(rng, data: bytearray, lo: int) -> None:
    i = int(rng.integers(lo, len(data)))
    n = int(rng.integers(1, 17))
    data[i:i + n] = rng.integers(0, 256, min(n, len(data) - i), dtype=np.uint8).tobytes()


def _splice(rng, data: bytearray, lo: int) -> bytearray:
    i = int(rng.integers(0, len(data)))
    if rng.random() < 0.4:
        return data[:i]  # truncation
    if rng.random() < 0.5:
        return data[:i] + data[i + int(rng.integers(1, 64)):]  # deletion
    return data[:i] + rng.integers(0, 256, int(rng.integers(1, 64)), dtype=np.uint8).tobytes() + data[i:]


def _header_number(rng, data: bytearray, lo: int) -> bytearray:
    """Replace one number or type word in a PLY header (counts, property types)."""
    head, body = bytes(data[:lo]), bytes(data[lo:])
    lines = head.split(b"\n")
    k = int(rng.integers(1, max(2, len(lines) - 1)))
    words = lines[k].split(b" ")
    choice = [b"0", b"1", b"63", b"65", b"257", b"4294967295", b"-1", b"1e9", b"uchar", b"double", b"list"]
    words[int(rng.integers(len(words)))] = choice[int(rng.integers(len(choice)))]
    lines[k] = b" ".join(words)
    return bytearray(b"\n".join(lines) + body)


def _spz_payload(rng, data: bytes) -> bytes:
    """Mutate inside the compression: the decoded attribute bytes, recompressed honestly."""
    if data[:2] == b"\x1f\x8b":
        raw = bytearray(gzip.decompress(data))
        _flip_bits(rng, raw, 0) if rng.random() < 0.5 else _random_bytes(rng, raw, 0)
        return gzip.compress(bytes(raw))
    count = data[15]
    toc = np.frombuffer(data, "<u8", 2 * count, 32).reshape(-1, 2).copy()
    pos, streams = 32 + 16 * count, []
    for csize, _ in toc.tolist():
        streams.append(bytearray(zstandard.ZstdDecompressor().decompressobj().decompress(data[pos:pos + csize])))
        pos += csize
    j = int(rng.integers(count))
    _random_bytes(rng, streams[j], 0)
    packed = [zstandard.ZstdCompressor().compress(bytes(s)) for s in streams]
    toc[:, 0] = [len(p) for p in packed]
    return data[:32] + toc.astype("<u8").tobytes() + b"".join(packed)


def mutate(rng, data: bytes, ext: str) -> bytes:
    lo = _body_start(data) if ext.endswith("ply") else 0
    kind = int(rng.integers(6))
    if kind == 5 and ext == "spz":
        return _spz_payload(rng, data)
    out = bytearray(data)
    if kind == 4 and lo:
        return bytes(_header_number(rng, out, lo))
    if kind == 3:
        return bytes(_splice(rng, out, lo))
    [_flip_bits, _special_floats, _random_bytes, _special_floats, _special_floats, _flip_bits][kind](
        rng, out, lo if kind in (1, 3) or rng.random() < 0.7 else 0)
    return bytes(out)


def _one(path, data: bytes, bad: str) -> str | None:
    """"read" or "refused" when the reader kept its promises, else what went wrong."""
    path.write_bytes(data)
    try:
        s = read(path, bad=bad, max_splats=BUDGET)
    except SplatFormatError as exc:
        return "refused" if str(path) in str(exc) else f"error does not name the file: {exc}"
    except Exception as exc:  # noqa: BLE001 - finding these is the point
        return f"{type(exc).__name__}: {exc}"
    try:
        check_promises(s)
    except AssertionError as exc:
        return f"promise broken: {exc}"
    return "read"


def test_fuzz_readers(testdata, tmp_path, tmp_path_factory):
    seeds = _seeds(testdata, tmp_path_factory)
    start, problems, outcomes = time.perf_counter(), [], {"read": 0, "refused": 0}
    slowest = 0.0
    with np.errstate(all="ignore"):  # overflow warnings on garbage are expected, not findings
        for name, (ext, data) in sorted(seeds.items()):
            path = tmp_path / f"fuzz.{ext}"
            for i in range(CASES_PER_SEED):
                rng = np.random.default_rng((11, zlib.crc32(name.encode()), i))
                case = mutate(rng, data, ext)
                t0 = time.perf_counter()
                problem = _one(path, case, "drop" if i % 4 == 3 else "fix")
                slowest = max(slowest, time.perf_counter() - t0)
                if problem in outcomes:
                    outcomes[problem] += 1
                else:
                    problems.append(f"{name} case {i}: {problem}")
    elapsed = time.perf_counter() - start
    total = len(problems) + sum(outcomes.values())
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"fuzzed {total} inputs in {elapsed:.1f} s: {outcomes}; slowest case {slowest:.2f} s, "
          f"process max RSS {rss:.0f} MiB")
    assert not problems, f"{len(problems)} of {total}:\n" + "\n".join(problems[:20])
