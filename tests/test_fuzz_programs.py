"""Seeded fuzzing of CL files and G-code programs (#18): real files of ../shared/realdata and the
samples, damaged (bytes flipped, lines inserted, deleted or duplicated, truncated, numbers made
NaN, 1e308, 1e15, -0 or 40-digit, units flipped), each read by a real `pathcheck` process:
`info` for CL files, a full check against a small part for a share of them, `check-gcode` for
programs. Every run ends with exit 0, 1 or 2, no traceback, no signal, within 60 s and 2 GB,
and an exit 2 is one line naming the file.

A small sample runs in `make test`; PATHCHECK_FUZZ=nightly runs 500 cases per family (about
10-14 minutes on two shared cores); PATHCHECK_SEED=S draws a fresh set of cases. A failing case
is reproduced by its seed, the test's id (and S)."""

from __future__ import annotations

import os
import random
import re
import shutil

import pytest

from tests.conftest import REALDATA
from tests.hostile import REPO, assert_sane, run_pathcheck

NIGHTLY = os.environ.get("PATHCHECK_FUZZ") == "nightly"
CASES = 500 if NIGHTLY else 24  # per family
CHECK_EVERY = 10 if NIGHTLY else 6  # every n-th CL case is a full check against a small part
# PATHCHECK_SEED=S: a fresh set of cases (case i seeded by "S:i"), else case i seeded by i
_SEED = os.environ.get("PATHCHECK_SEED", "")


def _rng(n: int) -> random.Random:
    return random.Random(f"{_SEED}:{n}" if _SEED else n)

CL_SOURCES = [
    *sorted((REALDATA / "amorim-solidworkscam-apt").glob("*.apt")),
    *sorted((REALDATA / "mech491-nx-clsf").glob("APT_*.txt")),
    *sorted((REPO / "samples").glob("*/*.apt")),
]
# jobs small enough to check in a few seconds, with their parts
CHECK_SOURCES = [
    (REPO / "samples" / "mould" / "mould.apt", REPO / "samples" / "mould" / "mould.json", 60),
    (REALDATA / "amorim-solidworkscam-apt" / "Teste-Metrologia.apt",
     REALDATA / "amorim-solidworkscam-apt" / "Teste-Metrologia.STL", None),
]
GCODE_SOURCES = [
    ("linuxcnc-5axis-gcode/boat-xyzac.ngc", "linuxcnc-xyzac-trt"),
    ("linuxcnc-5axis-gcode/boat-xyzbc.ngc", "linuxcnc-xyzbc-trt"),
    ("linuxcnc-5axis-gcode/impeller-7bl-xyzac.ngc", "linuxcnc-xyzac-trt"),
    ("linuxcnc-5axis-gcode/xyzab-tdr-demo.ngc", "linuxcnc-xyzab-tdr"),
    ("linuxcnc-5axis-gcode/b-index.ngc", "linuxcnc-hmc"),
    ("nx-postlib-gcode/DMU70eVo_840D_5axis_BC.ptp", "dmu70evo-840d"),
    ("nx-postlib-gcode/Haas_VF2_TR_5axis_AB.ptp", "haas-vf2-tr"),
    ("nx-postlib-gcode/DMG_DMC160U_MillPlus_5axis.ptp", "dmc160u-millplus"),
    ("nx-postlib-gcode/Toyoda_FH55_horizontal_B.ptp", "fanuc-hmc"),
]
HOSTILE_NUMBERS = ("NaN", "nan", "inf", "1e308", "-1e308", "1e15", "-1e15", "-0", "0",
                   "9" * 40, "-" + "9" * 25, "1e-320", "0.000000000001", "1_0", "100000")
_NUMBER = re.compile(r"(?<![A-Za-z_])[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?")
_UNIT_FLIPS = (("UNITS/MM", "UNITS/INCHES"), ("UNITS/INCHES", "UNITS/MM"), ("MMPM", "IPM"),
               ("IPM", "MMPM"), ("G21", "G20"), ("G20", "G21"), ("G71", "G70"))


def _lines(text: str) -> list[str]:
    return text.splitlines(keepends=True) or [""]


def mutate(data: bytes, rng: random.Random) -> tuple[bytes, str]:
    """One to three seeded mutations of a file's bytes, and what they were."""
    done = []
    for _ in range(rng.choice((1, 1, 2, 3))):
        kind = rng.choice(("flip", "insert", "delete", "truncate", "number", "number",
                           "number", "units", "duplicate"))
        text = data.decode("latin-1")
        lines = _lines(text)
        k = rng.randrange(len(lines))
        if kind == "flip" and data:
            at = rng.randrange(len(data))
            value = rng.choice((rng.randrange(256), rng.randrange(32, 127)))
            data = data[:at] + bytes([value]) + data[at + 1:]
        elif kind == "insert":
            new = rng.choice((lines[rng.randrange(len(lines))], "GOTO/1,2\n", "CIRCLE/0,0,0\n",
                              "G2 X1 I1e11\n", "#7=[1/0]\n", "$$\n", "FEDRAT/IPM,1\n",
                              "CSYS/1,0,0,1e15,0,1,0,0,0,0,1,0\n", "G1 X#9 Y#<a>\n",
                              "".join(chr(rng.randrange(32, 127)) for _ in range(40)) + "\n"))
            lines.insert(k, new)
            data = "".join(lines).encode("latin-1")
        elif kind == "delete":
            del lines[k]
            data = "".join(lines).encode("latin-1")
        elif kind == "truncate":
            data = data[: rng.randrange(len(data) + 1)]
        elif kind == "number":
            found = list(_NUMBER.finditer(text))
            if found:
                m = rng.choice(found)
                text = text[: m.start()] + rng.choice(HOSTILE_NUMBERS) + text[m.end():]
                data = text.encode("latin-1")
        elif kind == "units":
            old, new = rng.choice(_UNIT_FLIPS)
            data = text.replace(old, new, 1).encode("latin-1")
        elif kind == "duplicate":
            n = rng.randrange(1, 50)
            block = lines[k : k + n]
            lines[k:k] = block * rng.randrange(1, 20)
            data = "".join(lines).encode("latin-1")
        done.append(kind)
    return data, "+".join(done)


def _need_realdata() -> None:
    if not REALDATA.is_dir():
        pytest.skip(f"../shared/realdata not found at {REALDATA}; fuzzing skipped")


@pytest.mark.parametrize("seed", range(CASES))
def test_fuzz_cl(seed, tmp_path):
    _need_realdata()
    rng = _rng(seed)
    if seed % CHECK_EVERY == CHECK_EVERY - 1:
        job, part, keep = rng.choice(CHECK_SOURCES)
        text = job.read_bytes()
        if keep is not None:  # the first records only: a check of a few seconds
            text = b"".join(text.splitlines(keepends=True)[:keep])
        data, how = mutate(text, rng)
        (tmp_path / "job.apt").write_bytes(data)
        shutil.copy(part, tmp_path / f"job{part.suffix}")
        run = run_pathcheck(["job.apt", "--json", "out.json"], cwd=tmp_path)
        assert_sane(run, ("job.apt", f"job{part.suffix}", "out.json"))
    else:
        source = rng.choice(CL_SOURCES)
        data, how = mutate(source.read_bytes(), rng)
        (tmp_path / f"case{source.suffix}").write_bytes(data)
        run = run_pathcheck(["info", f"case{source.suffix}"], cwd=tmp_path)
        assert_sane(run, f"case{source.suffix}")
    assert how  # (shown by pytest when an assertion above fails: the source and mutations)


@pytest.mark.parametrize("seed", range(CASES))
def test_fuzz_gcode(seed, tmp_path):
    _need_realdata()
    rng = _rng(10_000 + seed)
    rel, machine = rng.choice(GCODE_SOURCES)
    source = REALDATA / rel
    data, how = mutate(source.read_bytes(), rng)
    (tmp_path / f"case{source.suffix}").write_bytes(data)
    run = run_pathcheck(["check-gcode", f"case{source.suffix}", "--machine", machine],
                        cwd=tmp_path)
    assert_sane(run, f"case{source.suffix}")
    assert how
