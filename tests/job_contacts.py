"""The engine's inputs for a sample job's cutting moves: its part, the part sampled once, and
the contact points of every cutting move (CL -> CC with the job's first cutter)."""

from __future__ import annotations

from pathlib import Path

from checker.apt import read_cl
from checker.geometry import load_part
from checker.geometry.contact import Contacts, cl_to_cc
from checker.geometry.sampling import TestPoints, sample_part
from checker.part import Part


def job_contacts(apt: Path) -> tuple[Part, TestPoints, Contacts]:
    """(part, test points, contacts) of `apt`'s cutting moves; the part is `apt` with .json."""
    tp = read_cl(apt)
    ma = tp.motion_arrays()
    cut = ~ma.rapid
    part = load_part(apt.with_suffix(".json"))
    samples = sample_part(part)
    return part, samples, cl_to_cc(part, samples, tp.operations[0].cutter, ma.tip[cut],
                                   ma.axis[cut])
