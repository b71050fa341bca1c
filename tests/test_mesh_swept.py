"""The certificate of a whole stretch of a move (checker.mesh.swept) against dense poses along
it (the exact per-pose depth, `pose_depths`), on the real moves and the real part of a
SolidWorks-CAM job (../shared/realdata/amorim-solidworkscam-apt/Interface-glue: its STL and
the cutters of its operations: ball, flat and cone).

- A translation (the job's own 3-axis moves, with its cutters and with a bull-nose and a
  tapered ball instead): the certificate is exact, so it passes at the largest sampled depth
  plus what the samples can miss, and fails just below it.
- The tool turning (the same moves made 4-axis: B changing by up to 0.5 degree over a move,
  about the compressor sample's median, the machine running linearly in X Y Z B; or 5-axis,
  the tool's axis turning as much, linearly, the tip running straight): it never
  passes below the largest sampled depth (whole moves and their halves), and it passes on most
  moves when the tolerance is 0.1 mm above it (the slack for the turning grows with the
  distance from the tip: 0.5 degree is 0.09 mm at 10 mm). Without that slack (tau = alpha = 0)
  it passes wrongly on most moves: the slack is needed."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from checker.apt import read_cl
from checker.b_axis import axis_for_b, rotate_about_y
from checker.cutter import parse_cutter
from checker.geometry import load_part
from checker.mesh import MeshIndex, pose_depths, tool_pieces
from checker.mesh.swept import certified_stretches
from checker.verify import Stretches, pose_at, stretches

JOB = (Path(__file__).resolve().parents[2] / "shared" / "realdata" / "amorim-solidworkscam-apt"
       / "Interface-glue")
SAMPLES = 801  # poses along each move
REACH = 1.0
CENTER = np.array([0.0, 0.0, -40.0])


@pytest.fixture(scope="module")
def job():
    if not JOB.with_suffix(".apt").is_file():
        pytest.skip("../shared/realdata is not beside the checkout")
    tp = read_cl(JOB.with_suffix(".apt"))
    ma = tp.motion_arrays()
    mesh = load_part(JOB.with_suffix(".STL")).mesh
    index = MeshIndex.build(mesh.vertices, mesh.triangles)
    cutters = [op.cutter for op in tp.operations]
    # feed moves within one operation whose ends are near the part
    a = np.flatnonzero((~ma.rapid[1:]) & (ma.op[1:] == ma.op[:-1])) + 1
    near = np.zeros(len(a), dtype=bool)
    for o in np.unique(ma.op[a]):
        k = np.flatnonzero(ma.op[a] == o)
        pieces = tool_pieces(cutters[o], with_holder=True)
        for ends in (a[k] - 1, a[k]):
            near[k] |= pose_depths(index, pieces, ma.tip[ends], ma.axis[ends],
                                   reach=REACH).depth > -0.5
    rng = np.random.default_rng(20261124)
    ends = rng.choice(a[near], 120, replace=False)
    return SimpleNamespace(ma=ma, index=index, cutters=cutters, end=np.sort(ends))


def _dense(job, moves, end, b, cutters=None):
    """(moves, SAMPLES) the depths at poses evenly along each move (the real motion), with the
    operations' `cutters` (default: the job's)."""
    cutters = job.cutters if cutters is None else cutters
    t = np.linspace(0.0, 1.0, SAMPLES)
    out = np.empty((len(end), SAMPLES))
    for o in np.unique(job.ma.op[end]):
        k = np.flatnonzero(job.ma.op[end] == o)
        e = np.repeat(end[k], SAMPLES)
        tips, axes = pose_at(moves, e, np.tile(t, len(k)), b, CENTER)
        d = pose_depths(job.index, tool_pieces(cutters[o], with_holder=True), tips, axes,
                        reach=REACH).depth
        out[k] = d.reshape(len(k), SAMPLES)
    return out


def _certify(job, ref: Stretches, end, tol, cutters=None):
    cutters = job.cutters if cutters is None else cutters
    out = np.empty(len(end), dtype=bool)
    for o in np.unique(job.ma.op[end]):
        k = np.flatnonzero(job.ma.op[end] == o)
        part = Stretches(*(x[k] for x in ref))
        out[k] = certified_stretches(job.index, tool_pieces(cutters[o], with_holder=True),
                                     part.mids, part.axes, part.half, part.tau, part.alpha,
                                     tol[k])
    return out


@pytest.mark.parametrize("cutter", [None, "CUTTER/10,2", "CUTTER/9.1633,5,0,5,0,5,0"],
                         ids=["as written", "bull-nose", "tapered ball"])
def test_a_translation_is_certified_exactly(job, cutter):
    cutters = None if cutter is None else [parse_cutter(cutter)] * len(job.cutters)
    moves = SimpleNamespace(tip=job.ma.tip, axis=job.ma.axis)
    end = job.end
    ones = np.ones(len(end))
    ref = stretches(moves, end, 0.0 * ones, ones, None, CENTER)
    assert np.abs(ref.tau).max() == 0.0 and np.abs(ref.alpha).max() < 1e-7
    sampled = _dense(job, moves, end, None, cutters).max(axis=1)
    length = np.linalg.norm(job.ma.tip[end] - job.ma.tip[end - 1], axis=1)
    missed = 0.5 * length / (SAMPLES - 1)  # the depth changes by at most the distance moved
    reached = sampled > -REACH  # below that the sampled depth is only a cap
    assert (sampled > 0.0).sum() >= 20 and reached.mean() > 0.9
    above = _certify(job, ref, end, sampled + missed + 1e-7, cutters)
    below = _certify(job, ref, end, sampled - 1e-7, cutters)
    assert above.all(), end[~above]
    assert not below[reached].any(), end[below & reached]


def _turning(job, rng, kind: str):
    """The job's moves turning, by up to 0.5 degree over a move: "table", B (degrees) per pose
    with the part-frame tips as written and the axes turned with the table; "axis", the tool's
    axis tilted (b None: the tip straight, the axis turning linearly)."""
    n = len(job.ma.tip)
    b = rng.uniform(-20.0, 20.0, n)
    b[job.end] = b[job.end - 1] + rng.uniform(-0.5, 0.5, len(job.end))
    if kind == "table":
        return SimpleNamespace(tip=job.ma.tip, axis=axis_for_b(b)), b
    spin = rng.uniform(0.0, 2.0 * np.pi, n)
    spin[job.end] = spin[job.end - 1]
    tilt = np.radians(b)
    axis = np.column_stack([np.sin(tilt) * np.cos(spin), np.sin(tilt) * np.sin(spin),
                            np.cos(tilt)])
    return SimpleNamespace(tip=job.ma.tip, axis=axis), None


@pytest.mark.parametrize("kind", ["table", "axis"])
def test_a_turning_tool_is_never_certified_below_the_dense_poses(job, kind):
    moves, b = _turning(job, np.random.default_rng(7), kind)
    end = job.end
    ones = np.ones(len(end))
    dense = _dense(job, moves, end, b)
    mid = SAMPLES // 2
    whole = None
    for t0, t1, cols in ((0.0, 1.0, slice(None)), (0.0, 0.5, slice(0, mid + 1)),
                         (0.5, 1.0, slice(mid, None))):
        ref = stretches(moves, end, t0 * ones, t1 * ones, b, CENTER)
        assert (ref.alpha > 0.0).all() and ((ref.tau > 0.0).all() if b is not None else
                                            (ref.tau == 0.0).all())
        sampled = dense[:, cols].max(axis=1)
        below = _certify(job, ref, end, sampled - 1e-7)
        assert not below.any(), end[below]
        whole = (ref, sampled) if whole is None else whole
    ref, sampled = whole
    # not vacuous: a little above the dense poses most whole moves pass
    above = _certify(job, ref, end, sampled + 0.1)
    assert above.mean() >= 0.75, above.mean()
    # the slack for the turning is what keeps it sound
    bare = ref._replace(tau=0.0 * ones, alpha=0.0 * ones)
    assert _certify(job, bare, end, sampled - 1e-7).mean() > 0.25


def test_the_machine_tip_runs_straight_between_the_poses(job):
    """The turning motion as `stretches` models it: the machine tip linear, the part-frame
    tip within tau of the chord at every pose of the stretch."""
    moves, b = _turning(job, np.random.default_rng(3), "table")
    end = job.end
    t = np.linspace(0.0, 1.0, 101)
    ref = stretches(moves, end, np.zeros(len(end)), np.ones(len(end)), b, CENTER)
    e = np.repeat(end, t.size)
    tips, _ = pose_at(moves, e, np.tile(t, len(end)), b, CENTER)
    chord = (ref.mids - ref.half)[:, None] + 2.0 * t[None, :, None] * ref.half[:, None]
    off = np.linalg.norm(tips.reshape(len(end), t.size, 3) - chord, axis=2).max(axis=1)
    assert (off <= ref.tau + 1e-9).all()
    assert (off >= 0.1 * ref.tau).mean() > 0.9  # and tau is not far above it
    machine = rotate_about_y(tips, b[e - 1] + np.tile(t, len(end)) * (b[e] - b[e - 1]), CENTER)
    lin = machine.reshape(len(end), t.size, 3)
    second = lin[:, 2:] - 2.0 * lin[:, 1:-1] + lin[:, :-2]
    assert np.abs(second).max() < 1e-9
