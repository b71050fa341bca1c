"""Bounds on what a tool path may ask for, so that no size grows with the numbers of the input:
a coordinate beyond any machine's travel is an error naming the line, not a 100-km move; the
positions a program expands into (arcs in chords, rotary turns in steps) are bounded in total;
inputs whose memory grows with their size beyond what streaming removes (the records a CL file
keeps as objects, the poses of a check, the CC points of an allowable search) are refused
beyond a bound, in one line naming the file and the bound (docs/formats.md, "Job sizes and memory").
Bounds on part files live in `checker.geometry.part_limits`."""

from __future__ import annotations

from pathlib import Path

from checker.errors import PathcheckError

#: mm, part or work frame: the largest machine tools travel about 30 m; 100 m is beyond any
MAX_COORDINATE_MM = 1e5
#: degrees, a rotary word or position: 2,777 turns
MAX_ROTARY_DEG = 1e6
#: positions a G-code program's arcs and rotary turns may expand into, in total
MAX_PROGRAM_POINTS = 5_000_000
#: records of a CL file other than plain GOTOs (each is an object of a few hundred bytes)
MAX_CL_STATEMENTS = 2_000_000
#: poses one check takes (motions, arcs in chords): the check keeps about 3 kB for each
MAX_CHECK_POSES = 2_000_000
#: CC points one `allowable` search takes: its document keeps about 1 kB for each
MAX_CC_POINTS = 1_000_000
#: rays of a stock model (checker.stock.dexels): about 36 bytes each at 4 intervals per ray
MAX_STOCK_RAYS = 40_000_000


def refuse_beyond(count: int, limit: int, what: str, name: str, *, path: str | Path | None,
                  line: int | None = None) -> None:
    """A PathcheckError (code "limit") when ``count`` ``what`` exceed ``limit``; ``name`` is the
    constant of this module that sets it."""
    if count > limit:
        raise PathcheckError(
            f"{count:,} {what}: expected at most {limit:,} (checker.input_limits.{name}); "
            "split the job", path=path, line=line, code="limit")
#: full turns of one G-code arc (LinuxCNC's G2/G3 P word): a thread mill's helix makes tens
MAX_ARC_TURNS = 10_000
