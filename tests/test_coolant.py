"""COOLNT/ is read into the motions and carried into the posted program."""

from __future__ import annotations

import numpy as np

from checker.apt import read_cl_text
from checker.postproc.machine import load_machine
from checker.postproc.post import moves_from_toolpath, post_program

JOB = """PARTNO/COOLANT
UNITS/MM
CUTTER/6,3
LOADTL/1
SPINDL/8000,CLW
RAPID
GOTO/0,0,10
COOLNT/FLOOD
FEDRAT/500,MMPM
GOTO/0,0,0
GOTO/10,0,0
COOLNT/MIST
GOTO/20,0,0
COOLNT/OFF
RAPID
GOTO/20,0,10
END
FINI
"""


def test_coolant_state_follows_the_records_and_reaches_the_gcode():
    tp = read_cl_text(JOB, path="coolant.apt")
    m = tp.motion_arrays()
    np.testing.assert_array_equal(m.coolant, [-1, 8, 8, 7, 0])
    assert "COOLNT" not in tp.ignored and "COOLNT" not in tp.unknown
    text = post_program(moves_from_toolpath(tp), load_machine("fanuc-hmc"))
    blocks = text.splitlines()
    m8 = next(i for i, b in enumerate(blocks) if " M08" in b or b.endswith("M08"))
    m7 = next(i for i, b in enumerate(blocks) if "M07" in b)
    m9 = next(i for i, b in enumerate(blocks) if "M09" in b)
    assert m8 < m7 < m9
