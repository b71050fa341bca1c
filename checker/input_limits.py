"""Bounds on what a tool path may ask for, so that no size grows with the numbers of the input:
a coordinate beyond any machine's travel is an error naming the line, not a 100-km move; the
positions a program expands into (arcs in chords, rotary turns in steps) are bounded in total.
Bounds on part files live in `checker.geometry.limits`."""

from __future__ import annotations

#: mm, part or work frame: the largest machine tools travel about 30 m; 100 m is beyond any
MAX_COORDINATE_MM = 1e5
#: degrees, a rotary word or position: 2,777 turns
MAX_ROTARY_DEG = 1e6
#: positions a G-code program's arcs and rotary turns may expand into, in total
MAX_PROGRAM_POINTS = 5_000_000
#: full turns of one G-code arc (LinuxCNC's G2/G3 P word): a thread mill's helix makes tens
MAX_ARC_TURNS = 10_000
