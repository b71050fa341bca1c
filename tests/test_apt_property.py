"""Property: random and mutated input makes the reader return a tool path with finite numbers or
raise PathcheckError, never anything else."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from checker.apt import read_cl_text
from checker.errors import PathcheckError

SEED_APT = """PARTNO/PROP
UNITS/MM
CUTTER/10,2
LOAD/TOOL,1
SPINDL/3000,RPM,CLW
TLAXIS/0,0,1
CSYS/1,0,0,0,0,1,0,0,0,0,1,0
RAPID
GOTO/0,0,20
FEDRAT/300,MMPM
GOTO/0,0,0
GOTO/10,0,0,0,0,1
CIRCLE/10,5,0,0,0,1,5
GOTO/10,10,0
GODLTA/0,0,5
CYCLE/DRILL,FEDTO,5,MMPM,100
GOTO/1,2,3
CYCLE/OFF
GOTO/1,$
   2,3 $$ end
PPRINT/DONE, REALLY
FINI
"""
SEED_CLSF = """TOOL PATH/OP,TOOL,BALL
TLDATA/MILL,0.2400,0.1200,2.5000,0.0000,0.0000
MSYS/0.0000,0.0000,0.0000,1.0000000,0.0000000,0.0000000,0.0000000,1.0000000,0.0000000
PAINT/PATH
LOAD/TOOL,3,ADJUST,3
RAPID
GOTO/1.8750,-0.4396,1.5302,0.0000000,-0.9922779,0.1240347
FEDRAT/IPM,10.0000
GOTO/2.0763,3.9939,2.1335
CIRCLE/1.9949,3.6307,1.9391,0.0000000,-0.9922779,-0.1240347,0.1687,0.0060,0.5,0.375,0,TIMES,7
GOTO/1.9949,3.6097,2.1066
END-OF-PATH
"""
TOKENS = [
    "GOTO/", "CIRCLE/", "CUTTER/", "TLDATA/MILL,", "CSYS/", "MSYS/", "FEDRAT/", "RAPID", "$",
    "$$", ",", "/", ".", "-", "+", "e", "E", "D", "1", "0", "9.5", "1e308", "nan", "inf", "\n",
    " ", "\t", "TIMES,", "UNITS/INCHES", "TOOL PATH/", "END-OF-PATH", "GODLTA/", "LOAD/TOOL,",
    "CYCLE/", "OFF", "PPRINT/", "\x00", "\r", "\u00e9", "TRNTYP/WORLD",
]


def check(text: str) -> None:
    try:
        tp = read_cl_text(text)
        m = tp.motion_arrays(arc_chord_tol=0.05)
    except PathcheckError as err:
        assert str(err) and "\n" not in str(err)
        return
    assert np.isfinite(m.tip).all() and np.isfinite(m.axis).all()
    np.testing.assert_allclose(np.linalg.norm(m.axis, axis=1), 1.0, atol=1e-9)


FAST = settings(max_examples=150, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])


@FAST
@given(st.lists(st.sampled_from(TOKENS), max_size=60).map("".join))
def test_token_soup(text):
    check(text)


@FAST
@given(st.text(max_size=300))
def test_arbitrary_text(text):
    check(text)


@FAST
@given(st.binary(max_size=200))
def test_arbitrary_bytes_as_latin1(data):
    check(data.decode("latin-1"))


@st.composite
def mutated(draw) -> str:
    text = draw(st.sampled_from([SEED_APT, SEED_CLSF]))
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(["delete", "insert", "replace", "dup_line", "drop_line",
                                   "truncate"]))
        k = draw(st.integers(0, max(len(text) - 1, 0)))
        lines = text.split("\n")
        j = draw(st.integers(0, len(lines) - 1))
        if op == "delete":
            text = text[:k] + text[k + draw(st.integers(1, 8)):]
        elif op == "insert":
            text = text[:k] + draw(st.sampled_from(TOKENS)) + text[k:]
        elif op == "replace":
            text = text[:k] + draw(st.sampled_from(TOKENS)) + text[k + 1:]
        elif op == "dup_line":
            text = "\n".join(lines[:j] + [lines[j]] + lines[j:])
        elif op == "drop_line":
            text = "\n".join(lines[:j] + lines[j + 1:])
        else:
            text = text[:k]
    return text


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated())
def test_mutated_real_looking_files(text):
    check(text)


def test_the_seeds_themselves_read():
    assert len(read_cl_text(SEED_APT).motion_arrays()) == 7
    tp = read_cl_text(SEED_CLSF)
    assert tp.units == "inch" and tp.arcs[0].turns == 7
