"""The engine on real third-party CAD (../shared/realdata: OpenCASCADE's STEP/IGES test parts and
BladeX's propeller IGES): every part mapped with a ball, a bull-nose and a flat cutter on a small
(u, v) grid. It must answer (no exception from compiled code, no endless loop: the suite's
timeout), never NaN, and for the ball never call a cutter safe that the brute-force oracle
(tests/engine_oracle.py, dense sampling plus bisection, written from the cutter's geometry
alone) proves unsafe: engine <= oracle + 1e-3 mm. Before the fix, ec_turbine-A.stp raised a
ZeroDivisionError from `refine.steps._steps` and ran without end with CUTTER/10,2."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from engine_oracle import oracle_sizes
from requires import require_extra

from checker.cutter import parse_cutter
from checker.engine.maps import allowable_maps
from checker.geometry import load_part
from checker.geometry.sampling import sample_part
from checker.tool_library import load_tool_library

require_extra("OCP", "cad")

REALDATA = Path(__file__).resolve().parents[2] / "shared" / "realdata"
PARTS = sorted([*(REALDATA / "occt-cad-nurbs").glob("*.stp"),
                *(REALDATA / "occt-cad-nurbs").glob("*.igs"),
                *(REALDATA / "bladex-propeller-iges").glob("*.iges")])
CUTTERS = ("CUTTER/6,3", "CUTTER/10,2", "CUTTER/10")
GRID = (3, 3)


@pytest.fixture(scope="module", params=PARTS, ids=lambda p: p.name)
def cad(request, realdata):
    part = load_part(request.param)
    return part, sample_part(part)


@pytest.mark.parametrize("cutter_text", CUTTERS)
def test_real_cad_is_mapped_without_fault(cad, cutter_text):
    part, tp = cad
    cutter = parse_cutter(cutter_text)
    tools = load_tool_library().family(cutter.kind, cutter.family_corner, theta=cutter.theta)
    maps = allowable_maps(part, tp, cutter, GRID, tools)
    assert len(maps) == len(part.surfaces)
    sizes = np.concatenate([m.size[m.kept] for m in maps])
    assert not np.isnan(sizes).any()
    assert (sizes >= 0.0).all()
    if cutter.kind != "ball" or not sizes.size:
        return
    cc = np.concatenate([m.cc[m.kept] for m in maps])
    normals = np.concatenate([m.normal[m.kept] for m in maps])
    up = normals[:, 2] > 0.05  # the oracle is 3-axis: tool axis +z
    if not up.any():
        return
    ref = oracle_sizes(part, cutter, cc[up], normals[up], dense=40)
    eng = sizes[up]
    both = np.isfinite(eng) & np.isfinite(ref)
    assert (eng[both] <= ref[both] + 1e-3).all(), np.c_[eng, ref][both][eng[both] > ref[both]]
    assert not (np.isinf(eng) & np.isfinite(ref)).any()
