"""Seeded fuzzing of the SOG and glTF readers, as test_formats_fuzz.py does for the others.

Mutations are structural, so that they get past the first check: meta.json and glTF JSON
fields set to hostile values (counts of 2^63, NaN, strings, names leaving the folder,
accessors pointing past their buffer, wrong component types, strides, sparse), WebP headers
claiming 16383 x 16383 images, zip members deleted, swapped, stored with an unknown method,
declaring huge sizes, or replaced by a deflate bomb, unbundled SOGs with images missing or
turned into folders, .glb BIN chunks cut short with the lengths kept consistent, and raw bit
flips, special floats and truncations; zips flagged encrypted, NUL bytes in
SOG file names and glTF URIs (a glTF whose primitives reuse one accessor set is measured in
tests/cli/test_one_line_errors.py instead: under the default budget it may legitimately decode
more than this file's allocation cap). Each input is read with bad="fix" (every 4th
"drop") and must either keep the reader promises (finite values, unit quaternions, scales
> 0, opacity in 0..1) or raise SplatFormatError naming the file. Other exceptions are bugs,
and so is a decode whose Python allocations (tracemalloc: numpy's included) peak above
MAX_PEAK, far above what a 64-splat seed needs. A case that runs past HANG_S is reported
as a hang (a liveness guard, not a speed goal: legitimate cases take milliseconds).

Each case has its own generator, default_rng((13, crc32(seed name), case)), so a reported
case rebuilds alone. SOG needs an OpenImageIO that keeps WebP alpha (not Blender 4.5's).
"""
from __future__ import annotations

import contextlib
import io
import json
import math
import pathlib
import resource
import shutil
import signal
import struct
import threading
import time
import tracemalloc
import zipfile
import zlib

import numpy as np
import pytest

from addon.core.errors import SplatFormatError
from addon.core.formats import read, write
from testing.reader_checks import FUZZ_BUDGET as BUDGET, check_promises
from testing.webp_support import needs_straight_webp

CASES = {"sog_zip": 900, "sog_unbundled": 400, "glb": 1200, "gltf": 400,
         "sog_encrypted": 150, "sog_nul_name": 60,  # the last two: zipfile errors found later
         "lcc": 600, "lcc2": 300}
MAX_PEAK = 64 << 20
HANG_S = 30
HOSTILE = [-1, 0, 1, 2, 3, 4, 63, 65, 255, 256, 257, 4096, 65535, 65536, 1 << 28, 1 << 31, 1 << 32,
           1 << 63, 1e308, -1e308, 0.5, math.nan, math.inf, "x", "", None, True, [], {}, [0, 1],
           [1.0] * 3, [0] * 300, "../meta.json", "missing.webp", "/etc/hostname", "a/b.webp",
           "quats.webp", 5120, 5121, 5122, 5123, 5125, 5126, 5124, "VEC3", "VEC4", "SCALAR", "MAT4"]


# ---------------------------------------------------------------- JSON mutations

def _paths(obj, prefix=()):
    """Every (container path) to a value, sampling long lists so codebooks don't dominate."""
    out = []
    items = obj.items() if isinstance(obj, dict) else enumerate(obj) if isinstance(obj, list) else ()
    items = list(items)
    if isinstance(obj, list) and len(items) > 6:
        items = items[:3] + items[-2:]
    for key, value in items:
        out.append(prefix + (key,))
        out += _paths(value, prefix + (key,))
    return out


def _mutate_json(rng, doc, focus=()):
    """Set, delete or duplicate one value, preferring paths under the focus keys."""
    paths = _paths(doc)
    hot = [p for p in paths if p[0] in focus] if focus and rng.random() < 0.8 else []
    path = (hot or paths)[int(rng.integers(len(hot or paths)))]
    parent = doc
    for key in path[:-1]:
        parent = parent[key]
    key, kind = path[-1], int(rng.integers(6))
    if kind == 0 and isinstance(parent, dict):
        del parent[key]
    elif kind == 1 and isinstance(parent[key], (int, float)) and not isinstance(parent[key], bool):
        parent[key] = parent[key] * [-1, 2, 1000, 1 << 20][int(rng.integers(4))] + int(rng.integers(-3, 4))
    elif kind == 2 and isinstance(parent[key], list) and parent[key]:
        parent[key] = parent[key][: int(rng.integers(len(parent[key])))]  # too short
    else:
        parent[key] = HOSTILE[int(rng.integers(len(HOSTILE)))]
    return doc


def _dump(doc) -> bytes:
    return json.dumps(doc, allow_nan=True).encode()


def _raw(rng, data: bytes, lo: int = 0) -> bytes:
    """Bit flips, random bytes or a truncation."""
    out = bytearray(data)
    kind = int(rng.integers(3))
    if kind == 2 or len(out) <= lo + 1:
        return bytes(out[: int(rng.integers(0, len(out)))])
    for _ in range(int(rng.integers(1, 9))):
        i = int(rng.integers(lo, len(out)))
        out[i] = out[i] ^ (1 << int(rng.integers(8))) if kind == 0 else int(rng.integers(256))
    return bytes(out)


# ---------------------------------------------------------------- SOG

def _members(path) -> dict:
    with zipfile.ZipFile(path) as z:
        return {name: z.read(name) for name in z.namelist()}


def _zip(members: dict, deflated=()) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        for name, data in members.items():
            method = zipfile.ZIP_DEFLATED if name in deflated else zipfile.ZIP_STORED
            z.writestr(zipfile.ZipInfo(name, (1980, 1, 1, 0, 0, 0)), data, method)
    return buf.getvalue()


def _webp_size(rng, data: bytes) -> bytes:
    """Rewrite a lossless WebP's 14-bit width and height fields (VP8L header)."""
    if data[12:16] != b"VP8L" or len(data) < 25:
        return _raw(rng, data)
    w, h = (int(rng.choice([1, 2, 3, 64, 1000, 16383])) for _ in range(2))
    bits = struct.unpack_from("<I", data, 21)[0] & ~0x0FFFFFFF | (w - 1) | (h - 1) << 14
    return data[:21] + struct.pack("<I", bits) + data[25:]


def _image_names(members):
    return [n for n in members if n.endswith(".webp")]


def _mutate_members(rng, members: dict, kind: int) -> dict:
    images = _image_names(members)
    pick = images[int(rng.integers(len(images)))]
    if kind == 0:
        members["meta.json"] = _dump(_mutate_json(rng, json.loads(members["meta.json"])))
    elif kind == 1:
        members[pick] = _raw(rng, members[pick], 16)
    elif kind == 2:
        members[pick] = _webp_size(rng, members[pick])
    elif kind == 3:
        other = images[int(rng.integers(len(images)))]
        members[pick], members[other] = members[other], members[pick]
    elif kind == 4:
        del members[pick if rng.random() < 0.8 else "meta.json"]
    return members


def bomb_zips(seed: bytes) -> list:
    """The seed with one member (meta.json or an image) replaced by a deflate bomb: 64 MiB
    of zeros in about 64 KB. Built once per member name (compressing is the slow part)."""
    members = _members(io.BytesIO(seed))
    return [_zip({**members, target: bytes(64 << 20)}, deflated=(target,)) for target in members]


def _patch_central(data: bytes, rng, field: str) -> bytes:
    """Patch one central-directory entry: its declared uncompressed size, or its method."""
    out = bytearray(data)
    starts, i = [], data.find(b"PK\x01\x02")
    while i >= 0:
        starts.append(i)
        i = data.find(b"PK\x01\x02", i + 1)
    if not starts:
        return bytes(out)
    i = starts[int(rng.integers(len(starts)))]
    if field == "size":
        struct.pack_into("<I", out, i + 24, int(rng.choice([0, 1, 1 << 20, 1 << 30, 0xFFFFFFFE])))
    else:
        method = int(rng.choice([1, 6, 9, 12, 14, 99]))
        struct.pack_into("<H", out, i + 10, method)
        local = struct.unpack_from("<I", out, i + 42)[0]
        if local + 10 <= len(out):
            struct.pack_into("<H", out, local + 8, method)
    return bytes(out)


def mutate_sog_zip(rng, seed: bytes, bombs: list) -> bytes:
    members = _members(io.BytesIO(seed))
    kind = int(rng.integers(9))
    if kind <= 4:
        return _zip(_mutate_members(rng, members, kind))
    if kind == 5:
        return _raw(rng, seed)
    if kind == 6:
        return _patch_central(seed, rng, "size")
    if kind == 7:
        return _patch_central(seed, rng, "method")
    bomb = bombs[int(rng.integers(len(bombs)))]
    return _patch_central(bomb, rng, "size") if rng.random() < 0.3 else bomb


def encrypted_zip(rng, seed: bytes) -> bytes:
    """The seed with the "encrypted" flag (general-purpose bit 0) set on some
    members' local and central headers (a RuntimeError from zipfile before), then maybe
    mutated as mutate_sog_zip does."""
    out = bytearray(seed)
    for sig, flag_at in ((b"PK\x03\x04", 6), (b"PK\x01\x02", 8)):
        at = out.find(sig)
        while at >= 0:
            if rng.random() < 0.6:
                out[at + flag_at] |= 1
            at = out.find(sig, at + 4)
    return bytes(out) if rng.random() < 0.5 else _raw(rng, bytes(out), 30)


def nul_name(rng, name: str) -> str:
    """name with a NUL byte put in (a ValueError 'embedded null byte' before)."""
    at = int(rng.integers(0, len(name) + 1))
    return name[:at] + "\0" + name[at:]


def _nul_meta(rng, members: dict) -> dict:
    meta = json.loads(members["meta.json"])
    keys = [k for k, v in meta.items() if isinstance(v, dict) and isinstance(v.get("files"), list)]
    files = meta[keys[int(rng.integers(len(keys)))]]["files"]
    j = int(rng.integers(len(files)))
    files[j] = nul_name(rng, files[j])
    members["meta.json"] = _dump(meta)
    return members


def write_sog_unbundled(rng, folder, seed_folder) -> None:
    """A mutated copy of an unbundled SOG in folder: meta.json plus its images."""
    members = {p.name: p.read_bytes() for p in seed_folder.iterdir()}
    kind = int(rng.integers(7))
    if kind <= 4:
        members = _mutate_members(rng, members, kind)
    for name, data in members.items():
        (folder / name).write_bytes(data)
    images = _image_names(members)
    pick = folder / images[int(rng.integers(len(images)))]
    if kind == 5:
        pick.unlink()
        pick.mkdir()  # an image name that is a folder
    elif kind == 6:
        pick.write_bytes(b"")


# ---------------------------------------------------------------- glTF

GLTF_FOCUS = ("accessors", "bufferViews", "buffers", "meshes", "nodes", "extensionsUsed")


def _split_glb(data: bytes):
    json_len = struct.unpack_from("<I", data, 12)[0]
    return json.loads(data[20:20 + json_len]), data[20 + json_len + 8:]


def _glb(doc, binary: bytes) -> bytes:
    text = _dump(doc)
    text += b" " * (-len(text) % 4)
    binary += b"\0" * (-len(binary) % 4)
    return (struct.pack("<4sII", b"glTF", 2, 28 + len(text) + len(binary))
            + struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(binary), 0x004E4942)
            + binary)


def _special_floats(rng, binary: bytes) -> bytes:
    out = bytearray(binary)
    for _ in range(int(rng.integers(1, 6))):
        i = 4 * int(rng.integers(len(out) // 4))
        out[i:i + 4] = struct.pack("<f", float(rng.choice([np.nan, np.inf, -np.inf, 0.0, -0.0, 1e-45, 3e38, -5.0])))
    return bytes(out)


def mutate_glb(rng, seed: bytes) -> bytes:
    doc, binary = _split_glb(seed)
    kind = int(rng.integers(8))
    if kind <= 2:
        for _ in range(int(rng.integers(1, 3))):
            doc = _mutate_json(rng, doc, GLTF_FOCUS)
        return _glb(doc, binary)
    if kind == 3:  # BIN cut short, every length kept consistent: accessors now point past it
        cut = binary[: int(rng.integers(0, len(binary)))]
        if rng.random() < 0.5:
            doc["buffers"][0]["byteLength"] = len(cut)
        return _glb(doc, cut)
    if kind == 4:
        return _glb(doc, _special_floats(rng, binary))
    if kind == 5:  # a huge count on one accessor, and a buffer claiming to hold it
        acc = doc["accessors"][int(rng.integers(len(doc["accessors"])))]
        acc["count"] = int(rng.choice([65, 1 << 20, 1 << 31, 1 << 40]))
        if rng.random() < 0.5:
            doc["buffers"][0]["byteLength"] = acc["count"] * 16
        return _glb(doc, binary)
    if kind == 6:
        return _raw(rng, seed, 12 if rng.random() < 0.5 else 0)
    out = bytearray(seed)  # header or chunk length fields
    at = int(rng.choice([8, 12, 20 + struct.unpack_from("<I", seed, 12)[0]]))
    struct.pack_into("<I", out, at, int(rng.choice([0, 1, 7, 1 << 31, 0xFFFFFFFF, len(seed) + 4])))
    return bytes(out)


def mutate_gltf(rng, seed: bytes) -> bytes:
    doc = json.loads(seed)
    kind = int(rng.integers(4))
    if kind <= 1:
        return _dump(_mutate_json(rng, doc, GLTF_FOCUS))
    uri = doc["buffers"][0]["uri"]
    if kind == 2:  # a damaged data URI: cut, or with bytes that are not base64
        head, _, body = uri.partition(",")
        cut = int(rng.integers(len(body)))
        body = body[:cut] if rng.random() < 0.5 else body[:cut] + "!*" + body[cut:]
        doc["buffers"][0]["uri"] = head + "," + body
    else:  # an external buffer that is missing, outside the folder or a URL
        doc["buffers"][0]["uri"] = str(rng.choice(["missing.bin", "../x.bin", "/etc/hostname",
                                                   "http://example.com/x.bin", "a%2F..%2F..%2Fx", "",
                                                   "x\0.bin", "\0", "seed.bin\0.txt"]))
    return _dump(doc)


# ---------------------------------------------------------------- the loop

class _Hang(Exception):
    pass


@contextlib.contextmanager
def _hang_guard():
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def alarm(signum, frame):
        raise _Hang()
    old = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, HANG_S)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


FIGURES = {"max_case_s": 0.0, "max_traced": 0}


def outcome(path, bad: str) -> str:
    """'read' or 'refused' when the reader kept its promises, else what went wrong. An
    unbundled SOG's errors name its folder and the image at fault (test_formats_sog.py)."""
    # an XGRIDS scene's errors name its meta file or the sibling at fault: its folder either way
    named = str(path.parent if path.name == "meta.json" or path.suffix in (".lcc", ".lcc2") else path)
    tracemalloc.reset_peak()
    try:
        with _hang_guard():
            s = read(path, bad=bad, max_splats=BUDGET)
    except SplatFormatError as exc:
        result = "refused" if named in str(exc) else f"error does not name the file: {exc}"
    except _Hang:
        return f"hang: still reading after {HANG_S} s"
    except Exception as exc:  # noqa: BLE001 - finding these is the point
        return f"{type(exc).__name__}: {exc}"
    else:
        try:
            check_promises(s)
            result = "read"
        except AssertionError as exc:
            return f"promise broken: {exc}"
    peak = tracemalloc.get_traced_memory()[1]
    FIGURES["max_traced"] = max(FIGURES["max_traced"], peak)
    return result if peak <= MAX_PEAK else f"allocated {peak / 2**20:.0f} MiB ({result})"


def _run(name, cases, make_input, problems, outcomes) -> None:
    for i in range(cases):
        rng = np.random.default_rng((13, zlib.crc32(name.encode()), i))
        path = make_input(rng, i)
        t0 = time.perf_counter()
        problem = outcome(path, "drop" if i % 4 == 3 else "fix")
        FIGURES["max_case_s"] = max(FIGURES["max_case_s"], time.perf_counter() - t0)
        if problem in outcomes:
            outcomes[problem] += 1
        else:
            problems.append(f"{name} case {i}: {problem}")


def _report(start, problems, outcomes, what):
    total = len(problems) + sum(outcomes.values())
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"fuzzed {total} {what} inputs in {time.perf_counter() - start:.1f} s: {outcomes}; slowest "
          f"case {FIGURES['max_case_s']:.2f} s, largest traced peak {FIGURES['max_traced'] / 2**20:.1f} "
          f"MiB, process max RSS {rss:.0f} MiB")
    assert not problems, f"{len(problems)} of {total}:\n" + "\n".join(problems[:20])


@pytest.fixture
def traced():
    tracemalloc.start()
    yield
    tracemalloc.stop()


@needs_straight_webp
def test_fuzz_sog(testdata, tmp_path, traced):
    seed = (testdata / "test64.sog").read_bytes()
    bombs = bomb_zips(seed)
    unbundled = testdata / "test64_sog_unbundled"
    start, problems, outcomes = time.perf_counter(), [], {"read": 0, "refused": 0}

    def sog_file(data: bytes):
        path = tmp_path / "fuzz.sog"
        path.write_bytes(data)
        return path

    def empty_folder(name: str):
        case = tmp_path / name
        shutil.rmtree(case, ignore_errors=True)
        case.mkdir()
        return case

    def zipped(rng, i):
        return sog_file(mutate_sog_zip(rng, seed, bombs))

    def folder(rng, i):
        case = empty_folder(f"un{i % 2}")
        write_sog_unbundled(rng, case, unbundled)
        return case / "meta.json"

    def encrypted(rng, i):
        return sog_file(encrypted_zip(rng, seed))

    def nul_zipped(rng, i):
        return sog_file(_zip(_nul_meta(rng, _members(io.BytesIO(seed)))))

    def nul_folder(rng, i):
        case = empty_folder(f"nul{i % 2}")
        for name, data in _nul_meta(rng, {p.name: p.read_bytes() for p in unbundled.iterdir()}).items():
            (case / name).write_bytes(data)
        return case / "meta.json"

    with np.errstate(all="ignore"):
        _run("sog_zip", CASES["sog_zip"], zipped, problems, outcomes)
        _run("sog_unbundled", CASES["sog_unbundled"], folder, problems, outcomes)
        _run("sog_encrypted", CASES["sog_encrypted"], encrypted, problems, outcomes)
        _run("sog_nul_name_zip", CASES["sog_nul_name"], nul_zipped, problems, outcomes)
        _run("sog_nul_name_unbundled", CASES["sog_nul_name"], nul_folder, problems, outcomes)
    _report(start, problems, outcomes, "SOG")


def test_fuzz_gltf(testdata, tmp_path, traced):
    glb_seed = (testdata / "test64.glb").read_bytes()
    write(tmp_path / "seed.gltf", read(testdata / "test64.glb"))
    gltf_seed = (tmp_path / "seed.gltf").read_bytes()
    start, problems, outcomes = time.perf_counter(), [], {"read": 0, "refused": 0}

    def glb(rng, i):
        path = tmp_path / "fuzz.glb"
        path.write_bytes(mutate_glb(rng, glb_seed))
        return path

    def gltf(rng, i):
        path = tmp_path / "fuzz.gltf"
        path.write_bytes(mutate_gltf(rng, gltf_seed))
        return path

    with np.errstate(all="ignore"):
        _run("glb", CASES["glb"], glb, problems, outcomes)
        _run("gltf", CASES["gltf"], gltf, problems, outcomes)
    _report(start, problems, outcomes, "glTF")


# ---------------------------------------------------------------- XGRIDS LCC / LCC2

def _lcc_case(rng, folder, seed: dict, meta_name: str, focus) -> pathlib.Path:
    """The seed scene's files with one of them mutated (its JSON meta structurally, a binary
    by _raw) or deleted, written into an emptied folder."""
    shutil.rmtree(folder, ignore_errors=True)
    files = dict(seed)
    victim = sorted(files)[int(rng.integers(len(files)))]
    kind = int(rng.integers(5))
    if victim == meta_name and kind < 3:
        files[victim] = _dump(_mutate_json(rng, json.loads(files[victim]), focus))
    elif kind == 4:
        del files[victim]
    else:
        files[victim] = _raw(rng, files[victim])
    for name, data in files.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_bytes(data)
    return folder / meta_name


def _seed_files(folder) -> dict:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_fuzz_lcc(tmp_path, traced):
    """LCC (meta.lcc, index.bin, data.bin, shcoef.bin) and LCC2 (meta.lcc2 over .spz chunks),
    written by testing/lcc_files.py from 64-splat LODs."""
    from testing.lcc_files import write_lcc, write_lcc2
    from testing.synth import random_splats

    lods = [random_splats(64, 3, seed=1), random_splats(16, 3, seed=2)]
    write_lcc(tmp_path / "lcc_seed", lods, units=3)
    write_lcc2(tmp_path / "lcc2_seed", lods, splat_type=".spz")
    lcc_seed, lcc2_seed = _seed_files(tmp_path / "lcc_seed"), _seed_files(tmp_path / "lcc2_seed")
    start, problems, outcomes = time.perf_counter(), [], {"read": 0, "refused": 0}

    def lcc(rng, i):
        return _lcc_case(rng, tmp_path / "lcc", lcc_seed, "meta.lcc", ("splats", "totalLevel", "attributes"))

    def lcc2(rng, i):
        return _lcc_case(rng, tmp_path / "lcc2", lcc2_seed, "meta.lcc2", ("root", "totalLevels"))

    with np.errstate(all="ignore"):
        _run("lcc", CASES["lcc"], lcc, problems, outcomes)
        _run("lcc2", CASES["lcc2"], lcc2, problems, outcomes)
    _report(start, problems, outcomes, "LCC")
