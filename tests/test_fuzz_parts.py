"""Seeded fuzzing of the part readers (issue #18): geomdl JSON and YAML, STL, STEP and IGES files
damaged by byte flips, inserted and deleted bytes and lines, truncation, numbers replaced by
NaN, 1e308, -0 or huge integers and (JSON/YAML) structural changes, each read by a real
`pathcheck info FILE` (every 10th geomdl and STL case also by `map --grid 3x3` or a check of a
real job, which reach the engine; STEP/IGES parts take minutes in the engine, so only `info`).
Every run must hold `part_runs.problems`: no traceback, no signal, exit 0/1/2, an exit-2
message of one line naming the file, under 60 s and 2 GB.

`make test` runs a small sample per family; PATHCHECK_FUZZ=nightly runs 500 per family
(PATHCHECK_FUZZ=N: N per family). Case i of a family is the same on every run (seeded by
family and i; PATHCHECK_SEED=S: a fresh set, seeded by S too); a failure names the case, its
mutation and the base file."""

from __future__ import annotations

import copy
import json
import os
import random
import re
import struct
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import yaml
from part_runs import problems, run_pathcheck
from requires import require_extra

REPO = Path(__file__).resolve().parents[1]
_QUICK = {"json": 8, "yaml": 6, "stl": 6, "step": 2, "iges": 4}
_NIGHTLY = 500
_ENGINE_SHARE = 10  # every 10th case of a family also runs the engine (map or check)
_NUMBERS = [b"NaN", b"1e308", b"-1e308", b"-0", b"99999999999999999999999999", b"Infinity",
            b"1e-300", b"0", b"-1", b"9223372036854775808", b"1e999"]
_NUMBER = re.compile(rb"-?\d+\.?\d*(?:[eE][-+]?\d+)?")


def _cases(family: str) -> int:
    mode = os.environ.get("PATHCHECK_FUZZ", "")
    if mode == "nightly":
        return _NIGHTLY
    return int(mode) if mode.isdigit() else _QUICK[family]


# pytest-timeout's 600 s per test fits the sample; a larger run gets 20 s per case
_TIMEOUT = pytest.mark.timeout(max(600, 20 * max(_cases(f) for f in _QUICK)))


# --- mutations: (rng, bytes) -> (bytes, description) -------------------------------------

def _flip(rng: random.Random, raw: bytes) -> tuple[bytes, str]:
    i, bit = rng.randrange(len(raw)), rng.randrange(8)
    out = bytearray(raw)
    out[i] ^= 1 << bit
    return bytes(out), f"bit {bit} of byte {i} flipped"


def _insert_byte(rng, raw):
    i, b = rng.randrange(len(raw) + 1), rng.randrange(256)
    return raw[:i] + bytes([b]) + raw[i:], f"byte {b:#04x} inserted at {i}"


def _delete_byte(rng, raw):
    i = rng.randrange(len(raw))
    return raw[:i] + raw[i + 1 :], f"byte {i} deleted"


def _delete_line(rng, raw):
    lines = raw.split(b"\n")
    i = rng.randrange(len(lines))
    return b"\n".join(lines[:i] + lines[i + 1 :]), f"line {i + 1} deleted"


def _insert_line(rng, raw):
    lines = raw.split(b"\n")
    i, j = rng.randrange(len(lines) + 1), rng.randrange(len(lines))
    new = lines[j] if rng.random() < 0.5 else bytes(rng.randrange(32, 127) for _ in range(40))
    return b"\n".join(lines[:i] + [new] + lines[i:]), f"line inserted before line {i + 1}"


def _truncate(rng, raw):
    i = rng.randrange(len(raw))
    return raw[:i], f"truncated at byte {i}"


def _number(rng, raw):
    """A number in the text replaced by NaN, 1e308, -0, a huge integer, ..."""
    found = list(_NUMBER.finditer(raw))
    if not found:
        return _flip(rng, raw)
    m, new = rng.choice(found), rng.choice(_NUMBERS)
    return raw[: m.start()] + new + raw[m.end() :], f"number at byte {m.start()} -> {new.decode()}"


def _float32(rng, raw):
    """Binary STL: one float of a facet (normal or vertex) replaced."""
    n = (len(raw) - 84) // 50
    if n <= 0:
        return _flip(rng, raw)
    t, k = rng.randrange(n), rng.randrange(12)
    at = 84 + 50 * t + 4 * k
    value = rng.choice([np.nan, np.inf, -np.inf, 3e38, -0.0, 1e15, 1e6 + 1, 1e-38])
    out = bytearray(raw)
    out[at : at + 4] = struct.pack("<f", value)
    return bytes(out), f"float {k} of facet {t} -> {value}"


def _stl_count(rng, raw):
    """Binary STL: the facet count in the header changed."""
    n = struct.unpack("<I", raw[80:84])[0]
    new = rng.choice([0, 1, n - 1, n + 1, 2**31 - 1, 2**32 - 1])
    return raw[:80] + struct.pack("<I", new) + raw[84:], f"facet count {n} -> {new}"


_DEEP = "__pathcheck_deep__"


def _dump(doc: object, suffix: str) -> bytes:
    return (json.dumps(doc) if suffix == ".json" else yaml.safe_dump(doc)).encode()


def _structural(rng: random.Random, doc: object, suffix: str) -> tuple[bytes, str]:
    """A JSON/YAML document with one node replaced, deleted, duplicated or nested deeply."""
    doc = copy.deepcopy(doc)
    parent, key, path = None, None, "$"
    node = doc
    for _ in range(rng.randrange(1, 9)):  # walk down a random path
        if isinstance(node, dict) and node:
            k = rng.choice(sorted(node, key=str))
        elif isinstance(node, list) and node:
            k = rng.randrange(len(node))
        else:
            break
        parent, key, node, path = node, k, node[k], f"{path}.{k}"
    small = len(json.dumps(node)) < 2000
    replace = [(None, "null"), ([], "[]"), ({}, "{}"), ("x", "'x'"), (True, "true"),
               (rng.choice([1e308, -1e308, 10**40, -(10**40), 0, -0.0, 1e-300]), "a number"),
               ([node] * (rng.choice([2, 100, 10_000]) if small else 2), "a list of copies")]
    choice = rng.randrange(len(replace) + 2)
    if choice < len(replace):
        parent[key], what = replace[choice]
        return _dump(doc, suffix), f"{path} -> {what}"
    if choice == len(replace):
        del parent[key]
        return _dump(doc, suffix), f"{path} deleted"
    depth = rng.choice([70, 500, 100_000])  # written as text: the dumpers would recurse
    parent[key] = _DEEP
    text = _dump(doc, suffix).decode()
    nested = "[" * depth + json.dumps(node) + "]" * depth
    text = text.replace(f'"{_DEEP}"' if suffix == ".json" else _DEEP, nested, 1)
    return text.encode(), f"{path} nested {depth} deep"


@dataclass(frozen=True)
class Base:
    """A file to mutate: its name, bytes and suffix, the mutations that fit it, how the engine
    share runs it (argv given the mutated file and an output folder), and a parsed document
    for structural mutations (JSON/YAML)."""

    name: str
    raw: bytes
    suffix: str
    mutations: tuple[Callable, ...]
    engine: Callable[[Path, Path], list[str]] | None = None
    doc: object = None


_BYTES = (_flip, _insert_byte, _delete_byte, _delete_line, _insert_line, _truncate, _number)


def _map(path: Path, out: Path) -> list[str]:
    return ["map", "--part", str(path), "--cutter", "CUTTER/10,5", "--grid", "3x3", "-o", str(out)]


def _trimmed_mould() -> dict:
    """The sample mould with a spline trim and a freeform hole on its first surface."""
    doc = json.loads((REPO / "samples" / "mould" / "mould.json").read_text())
    t = np.linspace(0, 2 * np.pi, 9)
    circle = np.column_stack([0.5 + 0.2 * np.cos(t), 0.5 + 0.2 * np.sin(t)]).tolist()
    doc["shape"]["data"][0]["trims"] = {"count": 2, "data": [
        {"type": "spline", "degree": 2,
         "knotvector": [0, 0, 0, .25, .25, .5, .5, .75, .75, 1, 1, 1],
         "control_points": {"points": circle}, "reversed": 1},
        {"type": "freeform", "points": [[.45, .45], [.55, .45], [.55, .55], [.45, .55]],
         "reversed": 0}]}  # fmt: skip
    return doc


def _geomdl_bases(kind: str) -> list[Base]:
    docs = {
        "mould": json.loads((REPO / "samples" / "mould" / "mould.json").read_text()),
        "compressor": json.loads(
            (REPO / "samples" / "compressor" / "compressor_small.json").read_text()),
        "trimmed": _trimmed_mould(),
    }
    out = []
    for name, doc in docs.items():
        raw = (json.dumps(doc, indent=1) if kind == "json" else yaml.safe_dump(doc)).encode()
        out.append(Base(name, raw, f".{kind}", (*_BYTES, _structural), _map, doc))
    return out


def _stl_bases(realdata: Path, tmp_path: Path) -> list[Base]:
    from stl import Mode
    from stl import mesh as stl_mesh

    folder = realdata / "amorim-solidworkscam-apt"
    apt = folder / "Teste-Metrologia.apt"

    def check(path: Path, out: Path) -> list[str]:
        return [str(apt), "--part", str(path), "--json", str(out / "check.json")]

    binary = (folder / "Teste-Metrologia.STL").read_bytes()
    ascii_path = tmp_path / "ascii-base.stl"
    stl_mesh.Mesh.from_file(str(folder / "Teste-Metrologia.STL")).save(
        str(ascii_path), mode=Mode.ASCII)
    ascii_raw = ascii_path.read_bytes()
    ascii_path.unlink()
    binary_muts = (_flip, _insert_byte, _delete_byte, _truncate, _float32, _float32, _stl_count)
    return [
        Base("Teste-Metrologia", binary, ".stl", binary_muts, check),
        Base("Teste-Metrologia-ascii", ascii_raw, ".stl", _BYTES, check),
        Base("Telemecanique-Tilt-Support1",
             (folder / "Telemecanique-Tilt-Support1.stl").read_bytes(), ".stl", binary_muts),
    ]


def _cad_bases(realdata: Path, kind: str) -> list[Base]:
    folder, blade = realdata / "occt-cad-nurbs", realdata / "bladex-propeller-iges"
    if kind == "step":
        files = [folder / "ec_turbine-A.stp"]
    else:
        files = [folder / f"PRO20359-L{i}.igs" for i in (1, 2, 4, 5)]
        files += [blade / "root.iges", blade / "tip.iges", folder / "occ22470.igs"]
    return [Base(f.stem, f.read_bytes(), f.suffix, _BYTES) for f in files]


def _mutate(base: Base, rng: random.Random) -> tuple[bytes, str]:
    mutation = rng.choice(base.mutations)
    if mutation is _structural:
        return _structural(rng, base.doc, base.suffix)
    return mutation(rng, base.raw)


def _run_family(family: str, bases: list[Base], tmp_path: Path) -> None:
    n = _cases(family)

    def one(i: int) -> str | None:
        rng = random.Random(f"{os.environ.get('PATHCHECK_SEED', '')}{family}-{i}")
        base = bases[i % len(bases)]
        raw, what = _mutate(base, rng)
        path = tmp_path / f"{family}-{i:04d}-{base.name}{base.suffix}"
        path.write_bytes(raw)
        runs = [run_pathcheck(["info", str(path)])]
        if base.engine is not None and i % _ENGINE_SHARE == 3:
            out = tmp_path / f"out-{i}"
            runs.append(run_pathcheck(base.engine(path, out)))
        bad = [f"{r.argv[1]}: {p}" for r in runs for p in problems(r, path)]
        if not bad:
            path.unlink()
            return None
        return f"case {i} ({base.name}{base.suffix}, {what}): {'; '.join(bad)}"

    workers = (os.cpu_count() or 2) if n > _QUICK[family] else 2
    with ThreadPoolExecutor(max_workers=workers) as pool:
        failures = [f for f in pool.map(one, range(n)) if f]
    assert not failures, f"{len(failures)} of {n} {family} cases:\n" + "\n".join(failures)


@_TIMEOUT
@pytest.mark.parametrize("kind", ["json", "yaml"])
def test_fuzzed_geomdl_files(tmp_path, kind):
    _run_family(kind, _geomdl_bases(kind), tmp_path)


@_TIMEOUT
def test_fuzzed_stl_files(realdata, tmp_path):
    _run_family("stl", _stl_bases(realdata, tmp_path), tmp_path)


@_TIMEOUT
@pytest.mark.parametrize("kind", ["step", "iges"])
def test_fuzzed_cad_files(realdata, tmp_path, kind):
    require_extra("OCP", "cad")
    _run_family(kind, _cad_bases(realdata, kind), tmp_path)
