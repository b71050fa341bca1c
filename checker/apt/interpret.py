"""`RecordList` -> `ToolPath`: a state machine over the statements (units, frames, tool, feed,
modal axis); the runs of plain GOTOs between statements are copied in bulk into motion arrays
allocated once, converted to mm / part frame in bulk at the end."""

from __future__ import annotations

import math
from collections import Counter

import numpy as np

from checker.apt import coordinate_systems as fr
from checker.apt.lexer import MAX_ABS
from checker.errors import PathcheckError
from checker.input_limits import MAX_COORDINATE_MM
from checker.toolpath import (
    Arc,
    Frame,
    MotionArrays,
    Operation,
    Record,
    RecordList,
    ToolChange,
    ToolPath,
)
from checker.units import MM_PER_INCH, mm_per_unit

LENGTH_UNITS = {
    "INCH": "inch",
    "INCHES": "inch",
    "IN": "inch",
    "MM": "mm",
    "MILLIMETERS": "mm",
    "MILLIMETRES": "mm",
    "METRIC": "mm",
}
FEED_UNITS = {"IPM": "inch", "IPR": "inch", "MMPM": "mm", "MMPR": "mm"}
# known statements that carry nothing the checker uses: kept in `records`, counted in `ignored`
# (statements that move or turn the part, such as ORIGIN or ROTABL, stay `unknown` on purpose)
IGNORED = frozenset(
    {
        "$$", "PAINT", "CUTCOM", "PPRINT", "INSERT", "PARTNO", "END", "FINI",
        "END-OF-PATH", "SELECT", "TITLE", "REMARK", "UNITS", "UNIT", "INTOL", "OUTTOL", "TOLER",
        "MACHIN", "CLRSRF", "CLEARP", "DELAY", "OPSTOP", "STOP", "SEQNO", "OPSKIP", "AUXFUN",
        "PREFUN", "DISPLY",
    }
)
AXIS_NORM_TOL = 1e-2  # |(i,j,k)| must be 1 to this; CAM systems print 4-7 decimals
ARC_RADIUS_TOL = 1e-2  # relative mismatch allowed between CIRCLE radius and its end points
MIN_AXIS_NORM = 1e-6  # a CIRCLE axis shorter than this has no usable direction
MAX_TURNS = 1000  # full turns of one helical CIRCLE (NX TIMES,n)
ARC_RADIUS_ABS = 2e-3  # mm, plus this (4-decimal inch files round to 0.0025 mm)
CHUNK = 1 << 20  # rows per vectorised step on the motion arrays (bounds the temporaries)
SHORT_RUN = 4  # GOTO runs up to this long go one by one (a bulk copy costs more for them)
# indices of angles (not lengths) in the cutter statements, by number of values
_CUTTER_ANGLES = (4, 5)  # CUTTER/d,r,e,f,alpha,beta,h
_TLDATA_ANGLES = (3, 4)


def file_units(records: list[Record], *, path: str) -> str:
    """The file's length unit: its ``UNITS``/``UNIT`` statement, else the unit of its first
    ``FEDRAT`` (NX listings state none), else mm."""
    found: tuple[str, int] | None = None
    for rec in records:
        if rec.word in ("UNITS", "UNIT"):
            word = rec.args[0] if rec.args else None
            unit = LENGTH_UNITS.get(word) if isinstance(word, str) else None
            if unit is None:
                raise PathcheckError(
                    f"{rec.word}/: expected INCHES or MM, found {word!r}",
                    path=path,
                    line=rec.line,
                    code="parse",
                )
            if found is not None and found[0] != unit:
                raise PathcheckError(
                    f"{rec.word}/: units change from {found[0]} (line {found[1]}) to {unit}; "
                    "expected one unit per file",
                    path=path,
                    line=rec.line,
                    code="parse",
                )
            found = (unit, rec.line)
    if found is not None:
        return found[0]
    for rec in records:
        if rec.word == "FEDRAT":
            for a in rec.args:
                if isinstance(a, str) and a in FEED_UNITS:
                    return FEED_UNITS[a]
    return "mm"


def _err(rec: Record, msg: str, *, path: str, code: str = "parse") -> PathcheckError:
    return PathcheckError(f"{rec.word}/: {msg}", path=path, line=rec.line, code=code)


def _numbers(
    rec: Record, counts: tuple[int, ...] | None, what: str, *, path: str
) -> tuple[float, ...]:
    """The record's values, all numbers, in one of the allowed counts (None: any)."""
    for pos, a in enumerate(rec.args, start=1):
        if isinstance(a, str):
            raise _err(rec, f"expected a number at position {pos} ({what}), found {a!r}", path=path)
    if counts is not None and len(rec.args) not in counts:
        allowed = " or ".join(str(c) for c in counts)
        raise _err(
            rec, f"expected {allowed} values ({what}), found {len(rec.args)}", path=path
        )
    return rec.args  # type: ignore[return-value]


_NO_CYCLE = (math.nan, math.nan, math.nan)
_CYCLE_WORDS = ("FEDTO", "RAPTO", "RTRCTO")


def cycle_geometry(rec: Record, path: str) -> tuple[float, float, float]:
    """(depth, clearance, retract) of a canned cycle, distances along the tool axis from each
    hole position (file units): the tool rapids to `clearance` above it, feeds to `depth` below
    it and retracts to `retract` above it. Keyword form `CYCLE/DRILL,FEDTO,d,...,RAPTO,c,
    RTRCTO,r` (SolidWorks CAM, NX; RTRCTO AUTO or absent: back to the clearance) or the ISO
    4343 positional form `CYCLE/DRILL,d,MMPM,f,c`. Signs are ignored: a drill goes down."""
    args = rec.args
    found: dict[str, float] = {}
    for word, value in zip(args, args[1:], strict=False):
        if word in _CYCLE_WORDS and not isinstance(value, str):
            found[word] = abs(float(value))
    if "FEDTO" not in found:
        nums = [a for a in args[1:] if not isinstance(a, str)]
        if len(nums) >= 3:  # d, f, c
            found = {"FEDTO": abs(nums[0]), "RAPTO": abs(nums[2])}
        elif nums:
            found = {"FEDTO": abs(nums[0])}
        else:
            raise _err(rec, "expected the cycle's depth (FEDTO,d or a first number)", path=path)
    clear = found.get("RAPTO", 0.0)
    return found["FEDTO"], clear, found.get("RTRCTO", clear)


def circle_values(rec: Record, *, path: str) -> tuple[tuple[float, ...], int]:
    """``CIRCLE/xc,yc,zc,i,j,k[,r,...][,TIMES,n]`` -> (numbers, extra full turns n)."""
    args, turns = rec.args, 0
    if "TIMES" in args:
        k = args.index("TIMES")
        n = args[k + 1] if k + 2 == len(args) else None
        if isinstance(n, str) or n is None or n != int(n) or not 0 <= n <= MAX_TURNS:
            found = ",".join(map(str, args[k:]))
            raise _err(rec, f"expected TIMES,n with a whole 0 <= n <= {MAX_TURNS} at the end, "
                       f"found {found!r}", path=path)
        args, turns = args[:k], int(n)
    v = _numbers(Record(rec.word, args, rec.line), tuple(range(6, 12)),
                 "xc,yc,zc,i,j,k[,r,...]", path=path)
    if v[3] == v[4] == v[5] == 0:
        raise _err(rec, "expected a non-zero circle axis i,j,k, found 0,0,0", path=path)
    if not math.hypot(*v[3:6]) > MIN_AXIS_NORM:  # (1e-320, 0, 0) has no direction to use
        raise _err(rec, f"expected a circle axis i,j,k of unit length, found "
                   f"{','.join(f'{x:g}' for x in v[3:6])}", path=path)
    return v, turns


class _Reader:
    """State machine over the records; see `interpret`."""

    def __init__(self, records: RecordList, *, path: str, dialect: str, units: str,
                 require_cutter: bool) -> None:
        self.records = records
        self.path = path
        self.dialect = dialect
        self.units = units
        self.scale = mm_per_unit(units)
        self.require_cutter = require_cutter
        # motion columns (file units, file frame), rows [0, n) filled; feed, spindle, frame,
        # operation and cycle change seldom: each motion points to a row of `states`, pushed
        # when one changes
        total = len(records.lines) + sum(
            r.word in ("GOTO", "FROM", "GODLTA") for r in records.statements)
        self.n = 0
        self.pos = np.empty((total, 3))
        self.ax = np.empty((total, 3))
        self.rapid = np.zeros(total, dtype=bool)
        self.line = np.empty(total, dtype=np.int64)
        self.sid = np.empty(total, dtype=np.int32)
        self.states: list[tuple[float, ...]] = []
        self.dirty = True
        # state
        self.default_axis = (0.0, 0.0, 1.0)
        self.axis = self.default_axis
        self.rapid_next = False
        self.feed_now = math.nan
        self.feed_per_rev: float | None = None
        self.rpm = math.nan
        self.coolant = -1  # COOLNT in effect: 0 off, 7 mist, 8 flood, -1 not stated
        self.in_cycle = False
        self.cycle_feed = math.nan  # mm/min of the current canned cycle
        self.cycle_geometry = _NO_CYCLE  # its depth, clearance and retract distances, mm
        self.world = False
        self.frame_now = -1
        self.matrices: list[np.ndarray | None] = []
        self.frames: list[Frame] = []
        self.tool_defined = False
        self.cutter = None
        self.tool_number: int | None = None
        self.tool_name: str | None = None
        self.pending_arc: tuple[Record, tuple[float, ...], int, int] | None = None
        # (CIRCLE, values, turns, frame, end row)
        self.arc_specs: list[tuple[Record, tuple[float, ...], int, int, int]] = []
        self.tool_changes: list[ToolChange] = []
        self.ops: list[Operation] = [Operation(name="")]
        self.named: list[bool] = [False]
        self.unknown: Counter[str] = Counter()
        self.ignored: Counter[str] = Counter()

    # ---- operations ----------------------------------------------------------------------
    def boundary(self, index: int) -> None:
        """A statement that starts a new operation once the current one has motions."""
        op = self.ops[-1]
        if self.n > op.first_motion:
            op.end_record, op.end_motion = index, self.n
            self.ops.append(
                Operation(
                    name="",
                    tool_name=self.tool_name,
                    tool_number=self.tool_number,
                    cutter=self.cutter,
                    first_record=index,
                    first_motion=self.n,
                )
            )
            self.named.append(False)
            self.dirty = True
        self.axis = self.default_axis

    def set_tool(self, **kw: object) -> None:
        """Set tool_name / tool_number / cutter here and on the current operation."""
        for key, value in kw.items():
            setattr(self, key, value)
            setattr(self.ops[-1], key, value)

    # ---- motions -------------------------------------------------------------------------
    def push_state(self) -> None:
        """Feed (mm/min, nan), feed per rev (mm, nan), rpm, frame, operation, in cycle."""
        per_rev = math.nan if self.feed_per_rev is None else self.feed_per_rev
        feed = self.feed_now
        if self.in_cycle and not math.isnan(self.cycle_feed):
            feed, per_rev = self.cycle_feed, math.nan
        geometry = self.cycle_geometry if self.in_cycle else _NO_CYCLE
        self.states.append((feed, per_rev, self.rpm, self.frame_now, len(self.ops) - 1,
                            self.in_cycle, self.coolant, *geometry))
        self.dirty = False

    def state_of(self, row: int) -> tuple[float, ...]:
        """The state of motion ``row`` (negative: from the last filled one)."""
        return self.states[self.sid[row if row >= 0 else self.n + row]]

    def add_motion(self, rec: Record, xyz: tuple[float, float, float], rapid: bool) -> None:
        if not rapid and not self.tool_defined and self.require_cutter:
            raise _err(
                rec,
                "feed move before any CUTTER/ or TLDATA/ statement: expected the cutter to be "
                "defined first, found none",
                path=self.path,
                code="cutter",
            )
        if self.dirty:
            self.push_state()
        row = self.n
        self.pos[row] = xyz
        self.ax[row] = self.axis
        self.rapid[row] = rapid
        self.line[row] = rec.line
        self.sid[row] = len(self.states) - 1
        self.n = row + 1

    def plain_gotos(self, g0: int, g1: int) -> None:
        """The plain GOTOs of rows [g0, g1) of the record list, with no statement between
        them, copied in bulk (their modal axis filled forward); `goto`'s rules hold."""
        rl = self.records
        if g1 - g0 <= SHORT_RUN or self.pending_arc is not None:  # one by one: cheaper
            for g in range(g0, min(g1, g0 + SHORT_RUN)):
                self.goto(rl.goto_record(g))
            g0 = min(g1, g0 + SHORT_RUN)
        if g0 >= g1:
            return
        rapid = self.rapid_next
        if (g1 - g0 > 1 or not rapid) and not self.tool_defined and self.require_cutter:
            first = Record("GOTO", (), int(rl.lines[g0 + rapid]))
            raise _err(first, "feed move before any CUTTER/ or TLDATA/ statement: expected the "
                       "cutter to be defined first, found none", path=self.path, code="cutter")
        if self.dirty:
            self.push_state()
        self.rapid[self.n] = rapid
        self.rapid_next = False
        for c0 in range(g0, g1, CHUNK):
            c1 = min(c0 + CHUNK, g1)
            r0, r1 = self.n, self.n + c1 - c0
            self.pos[r0:r1] = rl.xyz[c0:c1]
            self.line[r0:r1] = rl.lines[c0:c1]
            self.sid[r0:r1] = len(self.states) - 1
            a0, a1 = (int(k) for k in rl.axis_rows.searchsorted([c0, c1]))
            ax = self.ax[r0:r1]
            ax[:] = self.axis
            if a1 > a0:
                idx = np.full(c1 - c0, -1, dtype=np.int64)
                idx[rl.axis_rows[a0:a1] - c0] = np.arange(a0, a1)
                np.maximum.accumulate(idx, out=idx)
                has = idx >= 0
                ax[has] = rl.axis_values[idx[has]]
                self.axis = tuple(rl.axis_values[a1 - 1].tolist())
            self.n = r1

    def goto(self, rec: Record) -> None:
        a = rec.args
        n = len(a)
        if (n != 3 and n != 6) or str in map(type, a):
            _numbers(rec, (3, 6), "x,y,z[,i,j,k]", path=self.path)
        if n == 6:
            self.axis = a[3:]  # type: ignore[assignment]
        rapid = self.rapid_next
        self.rapid_next = False
        self.add_motion(rec, a[:3], rapid)  # type: ignore[arg-type]
        if self.pending_arc is not None:
            circle = self.pending_arc[0]
            if self.n < 2 or self.state_of(-2)[4] != self.state_of(-1)[4]:
                raise _err(circle, "expected a tool position before the arc, found none",
                           path=self.path)
            self.arc_specs.append((*self.pending_arc, self.n - 1))
            self.pending_arc = None

    def last_position(self, rec: Record) -> np.ndarray:
        """The last tip in the current file frame, file units."""
        if self.n == 0:
            raise _err(rec, "expected a tool position before this move, found none",
                       path=self.path)
        p = self.pos[self.n - 1].copy()
        last = self.state_of(-1)[3]
        if last != self.frame_now:
            s = self.scale
            old = self.matrices[last] if last >= 0 else None
            new = self.matrices[self.frame_now] if self.frame_now >= 0 else None
            p = fr.to_frame(fr.from_frame(p * s, old), new) / s
        return p

    # ---- one record ----------------------------------------------------------------------
    def step(self, index: int, rec: Record) -> None:
        word = rec.word
        path = self.path
        if word in _STATE_WORDS:
            self.dirty = True
        if self.pending_arc is not None and word in _BREAKS_ARC:
            raise _err(self.pending_arc[0], f"expected the arc's end GOTO, found {word} at line "
                       f"{rec.line}", path=path)
        if word == "RAPID":
            self.rapid_next = True
        elif word == "FEDRAT":
            self.fedrat(rec)
        elif word == "GOTO":
            self.goto(rec)
        elif word == "FROM":
            v = _numbers(rec, (3, 6), "x,y,z[,i,j,k]", path=path)
            if len(v) == 6:
                self.axis = v[3:]
            self.add_motion(rec, v[:3], True)
        elif word == "GODLTA":
            self.godlta(rec)
        elif word == "CIRCLE":
            values, turns = circle_values(rec, path=path)
            self.pending_arc = (rec, values, turns, self.frame_now)
        elif word == "SPINDL":
            self.spindl(rec)
        elif word == "COOLNT":
            self.coolant = _coolant(rec, self.coolant)
        elif word == "CYCLE":
            self.cycle(rec)
        elif word in ("CUTTER", "TLDATA"):
            self.boundary(index)
            self.cutter_statement(rec)
        elif word in ("LOAD", "LOADTL"):
            self.load(index, rec)
        elif word == "TOOL PATH":
            self.boundary(index)
            self.tool_path(rec)
        elif word in ("CSYS", "MSYS"):
            self.boundary(index)
            self.coordinate_system(rec)
        elif word == "TRNTYP":
            self.world = bool(rec.args) and rec.args[0] == "WORLD"
        elif word == "TLAXIS":
            v = _numbers(rec, (3,), "i,j,k", path=path)
            if not any(v):
                raise _err(rec, "expected a non-zero tool axis i,j,k, found 0,0,0", path=path)
            self.default_axis = self.axis = v
        elif word == "MULTAX":
            if rec.args and rec.args[0] == "OFF":
                self.axis = self.default_axis
        elif word in IGNORED:
            self.ignored[word] += 1
            self.name_from_comment(rec)
        else:
            self.unknown[word] += 1

    def fedrat(self, rec: Record) -> None:
        """A feed for the moves that follow; it also ends a canned cycle that no CYCLE/OFF
        closed (SolidWorks CAM writes none: its contouring moves start with a FEDRAT)."""
        nums = [a for a in rec.args if not isinstance(a, str)]
        words = [a for a in rec.args if isinstance(a, str)]
        bad = [w for w in words if w not in FEED_UNITS]
        if len(nums) != 1 or bad or len(words) > 1:
            found = ",".join(str(a) for a in rec.args) or "nothing"
            raise _err(rec, f"expected a feed value and an optional IPM/IPR/MMPM/MMPR, found "
                       f"{found!r}", path=self.path)
        f = nums[0]
        self.in_cycle = False
        if f < 0:
            raise _err(rec, f"expected a feed >= 0, found {f:g}", path=self.path)
        unit = words[0] if words else ("IPM" if self.units == "inch" else "MMPM")
        self.rapid_next = False  # an explicit feed before the move cancels a pending RAPID
        scale = MM_PER_INCH if unit.startswith("I") else 1.0
        if unit.endswith("PR"):
            self.feed_per_rev, self.feed_now = f * scale, math.nan
        else:
            self.feed_per_rev, self.feed_now = None, f * scale

    def cycle(self, rec: Record) -> None:
        """``CYCLE/OFF`` ends a canned cycle, ``CYCLE/INIT`` prepares one; anything else starts
        one, with its feed from ``...,MMPM,f`` / ``IPM,f`` (per rev: times the rpm) and its
        geometry (`cycle_geometry`)."""
        first = rec.args[0] if rec.args else "ON"
        if first == "OFF":
            self.in_cycle = False
        elif first != "INIT":
            self.in_cycle = True
            if first != "ON":  # a new cycle: its own feed, geometry or none
                self.cycle_feed = math.nan
                self.cycle_geometry = cycle_geometry(rec, self.path)
            for unit, value in zip(rec.args, rec.args[1:], strict=False):
                if isinstance(unit, str) and unit in FEED_UNITS and not isinstance(value, str):
                    f = value * (MM_PER_INCH if unit.startswith("I") else 1.0)
                    self.cycle_feed = f * self.rpm if unit.endswith("PR") else f
                    break

    def spindl(self, rec: Record) -> None:
        words = {a for a in rec.args if isinstance(a, str)}
        nums = [a for a in rec.args if not isinstance(a, str)]
        if "OFF" in words:
            self.rpm = 0.0
        elif nums and not words & {"SFM", "SMM"}:
            self.rpm = float(nums[0])
        elif nums:
            self.rpm = math.nan

    def godlta(self, rec: Record) -> None:
        v = _numbers(rec, (1, 3), "d or dx,dy,dz", path=self.path)
        p = self.last_position(rec)
        if len(v) == 1:
            a = np.asarray(self.axis, dtype=float)
            na = np.linalg.norm(a)
            if na == 0:
                raise _err(rec, "expected a tool axis to move along, found 0,0,0", path=self.path)
            p = p + v[0] * a / na
        else:
            p = p + np.asarray(v)
        rapid = self.rapid_next
        self.rapid_next = False
        self.add_motion(rec, tuple(p.tolist()), rapid)  # type: ignore[arg-type]

    def cutter_statement(self, rec: Record) -> None:
        from checker import cutter as cutter_module  # lazily: written beside this module

        self.tool_defined = True
        if rec.word == "TLDATA":
            if not rec.args or rec.args[0] != "MILL":
                self.set_tool(cutter=None)
                self.unknown[f"TLDATA/{rec.args[0] if rec.args else ''}"] += 1
                return
            rest = Record(rec.word, rec.args[1:], rec.line)
            v = _numbers(rest, None, "MILL,d,r,h,taper,tip[,...]", path=self.path)
            mm = [x if k in _TLDATA_ANGLES else x * self.scale for k, x in enumerate(v)]
            c = cutter_module.cutter_from_tldata(mm, path=self.path, line=rec.line)
        else:
            v = _numbers(rec, None, "d[,r,e,f,alpha,beta,h]", path=self.path)
            angles = _CUTTER_ANGLES if len(v) == 7 else ()
            mm = [x if k in angles else x * self.scale for k, x in enumerate(v)]
            c = cutter_module.cutter_from_apt(mm, path=self.path, line=rec.line)
        self.set_tool(cutter=c)

    def load(self, index: int, rec: Record) -> None:
        args = rec.args[1:] if rec.word == "LOAD" and rec.args and rec.args[0] == "TOOL" else None
        if rec.word == "LOADTL":
            args = rec.args
        if args is None:
            self.unknown[f"LOAD/{rec.args[0] if rec.args else ''}"] += 1
            return
        if not args or isinstance(args[0], str) or args[0] != int(args[0]) or args[0] < 0:
            raise _err(rec, f"expected a tool number, found {args[0] if args else 'nothing'!r}",
                       path=self.path)
        self.boundary(index)
        number = int(args[0])
        name = self.tool_name if self.dialect == "clsf" else f"T{number}"
        self.set_tool(tool_number=number, tool_name=name)
        self.tool_changes.append(ToolChange(rec.line, number, self.cutter))

    def tool_path(self, rec: Record) -> None:
        """NX ``TOOL PATH/op_name,TOOL,tool_name``."""
        if not rec.args:
            raise _err(rec, "expected an operation name, found nothing", path=self.path)
        first = rec.args[0]
        self.ops[-1].name = first if isinstance(first, str) else f"{first:g}"
        self.named[-1] = True
        tool = rec.args[2] if len(rec.args) > 2 and rec.args[1] == "TOOL" else None
        self.set_tool(tool_name=str(tool) if tool is not None else None)

    def name_from_comment(self, rec: Record) -> None:
        """``$$ ... OPERATION NAME: X`` / ``PPRINT OPERATION NAME : X`` names an unnamed op."""
        if self.named[-1] or rec.text is None:
            return
        k = rec.text.upper().find("OPERATION NAME")
        if k >= 0:
            name = rec.text[k + 14 :].lstrip(" :=\t").strip()
            if name:
                self.ops[-1].name = name
                self.named[-1] = True

    def coordinate_system(self, rec: Record) -> None:
        if rec.word == "CSYS":
            v = _numbers(rec, (12,), "3x4 matrix row by row", path=self.path)
            M = fr.csys_matrix(v, self.scale, path=self.path, line=rec.line)
            applied = not self.world
        else:
            v = _numbers(rec, (9,), "origin, X axis, Y axis", path=self.path)
            M = fr.msys_matrix(v, self.scale, path=self.path, line=rec.line)
            applied = True
        self.frames.append(Frame(rec.word, M, rec.line, applied))
        self.matrices.append(M if applied else None)
        self.frame_now = len(self.matrices) - 1

    # ---- finish --------------------------------------------------------------------------
    def arrays(self) -> MotionArrays:
        n = self.n
        tip, axis, lines = self.pos[:n], self.ax[:n], self.line[:n]
        big = MAX_ABS * self.scale
        tip *= self.scale
        k = _first_row(tip, lambda t: ~(np.abs(t) <= big).all(axis=1))
        if k is not None:
            raise PathcheckError(
                f"expected coordinates of at most {MAX_ABS:g}, found "
                f"{tuple(float(v) / self.scale for v in tip[k])}",
                path=self.path,
                line=int(lines[k]),
                code="parse",
            )
        k = _first_row(axis, lambda a: ~(np.abs(np.linalg.norm(a, axis=1) - 1.0)
                                         <= AXIS_NORM_TOL))
        if k is not None:
            raise PathcheckError(
                f"expected a unit tool axis i,j,k, found {tuple(axis[k])} of length "
                f"{np.linalg.norm(axis[k]):.4g}",
                path=self.path,
                line=int(lines[k]),
                code="parse",
            )
        _normalise(axis)
        states = np.asarray(self.states, dtype=float).reshape(-1, 10)
        sid = self.sid[:n]
        if any(M is not None for M in self.matrices):
            fr.apply_frames(tip, axis, states[:, 3].astype(np.intp)[sid], self.matrices)
            _normalise(axis)
        self.within_reach(tip, lines, "tool position")
        geometry = None
        if states[:, 5].any():
            geometry = states[:, 7:10][sid] * self.scale
            self.within_reach(geometry, lines, "canned-cycle distance")
        rapid = self.rapid[:n]
        per_state = np.where(np.isnan(states[:, 1]), states[:, 0], states[:, 1] * states[:, 2])
        feed = per_state[sid]
        feed[rapid | ~(feed >= 0)] = np.nan  # rapid moves, and per-rev feeds without rpm
        return MotionArrays(
            tip=tip,
            axis=axis,
            rapid=rapid,
            feed=feed,
            spindle=states[:, 2][sid],
            line=lines,
            op=states[:, 4].astype(np.int64)[sid],
            cycle=states[:, 5].astype(bool)[sid],
            arc=np.full(n, -1, dtype=np.int64),
            coolant=states[:, 6].astype(np.int64)[sid],
            cycle_geometry=geometry,
        )

    def within_reach(self, values: np.ndarray, lines, what: str) -> None:
        """Every finite value at most MAX_COORDINATE_MM (part frame, mm), else an error naming
        the first line beyond."""
        k = _first_row(values, lambda v: (np.abs(v) > MAX_COORDINATE_MM).any(axis=1))
        if k is not None:
            shown = ", ".join(f"{v:.6g}" for v in values[k])
            raise PathcheckError(
                f"{what} ({shown}) mm in the part frame is beyond any machine's reach: "
                f"expected coordinates within +-{MAX_COORDINATE_MM:g} mm",
                path=self.path, line=int(lines[k]), code="parse",
            )

    def build_arcs(self, m: MotionArrays) -> list[Arc]:
        """Arcs in mm / part frame, checked: start and end at the CIRCLE's radius."""
        if not self.arc_specs:
            return []
        k = len(self.arc_specs)
        v = np.zeros((k, 7))
        has_r = np.zeros(k, dtype=bool)
        for n, (_, values, _, _, _) in enumerate(self.arc_specs):
            v[n, : min(len(values), 7)] = values[:7]
            has_r[n] = len(values) > 6
        frame = np.asarray([spec[3] for spec in self.arc_specs], dtype=np.intp)
        row = np.asarray([spec[4] for spec in self.arc_specs], dtype=np.intp)
        center = v[:, :3] * self.scale
        # APT: the motion is counter-clockwise about i,j,k; NX CLSF writes the opposite sense
        sense = -1.0 if self.dialect == "clsf" else 1.0
        axis = sense * v[:, 3:6] / np.linalg.norm(v[:, 3:6], axis=1)[:, None]
        fr.apply_frames(center, axis, frame, self.matrices)
        axis /= np.linalg.norm(axis, axis=1)[:, None]
        self.within_reach(np.column_stack([center, v[:, 6] * self.scale]),
                          [spec[0].line for spec in self.arc_specs], "CIRCLE/ centre and radius")
        start, end = m.tip[row - 1], m.tip[row]
        dist = []
        for p in (start, end):
            d = p - center
            dist.append(np.linalg.norm(d - np.sum(d * axis, axis=1)[:, None] * axis, axis=1))
        radius = np.where(has_r, v[:, 6] * self.scale, dist[0])
        worst = np.maximum(np.abs(dist[0] - radius), np.abs(dist[1] - radius))
        bad = np.flatnonzero((worst > ARC_RADIUS_TOL * radius + ARC_RADIUS_ABS) | (radius <= 0))
        if len(bad):
            b = bad[0]
            raise _err(
                self.arc_specs[b][0],
                f"expected the arc's start (line {m.line[row[b] - 1]}) and end (line "
                f"{m.line[row[b]]}) at radius {radius[b]:.6g} mm from the centre, found "
                f"{dist[0][b]:.6g} and {dist[1][b]:.6g} mm",
                path=self.path,
            )
        m.arc[row] = np.arange(k)
        return [
            Arc(center[n], axis[n], float(radius[n]), start[n], end[n], spec[0].line, int(row[n]),
                spec[2])
            for n, spec in enumerate(self.arc_specs)
        ]

    def finish(self) -> ToolPath:
        if self.pending_arc is not None:
            raise _err(self.pending_arc[0], "expected the arc's end GOTO, found the end of file",
                       path=self.path)
        op = self.ops[-1]
        op.end_record, op.end_motion = len(self.records), self.n
        for k, (o, named) in enumerate(zip(self.ops, self.named, strict=True), start=1):
            if not named:
                o.name = f"OP{k}"
        m = self.arrays()
        arcs = self.build_arcs(m)
        return ToolPath(
            path=self.path,
            dialect=self.dialect,  # type: ignore[arg-type]
            units=self.units,  # type: ignore[arg-type]
            records=self.records,
            operations=self.ops,
            motions=m,
            arcs=arcs,
            tool_changes=self.tool_changes,
            frames=self.frames,
            unknown=dict(self.unknown),
            ignored=dict(self.ignored),
        )


# statements that change what `_Reader.push_state` records
_STATE_WORDS = frozenset({"FEDRAT", "SPINDL", "COOLNT", "CYCLE", "CSYS", "MSYS"})
# COOLNT/ words -> coolant code (M-code number: 7 mist, 8 flood, 0 off)
_COOLANT = {"ON": 8, "FLOOD": 8, "THRU": 8, "TAP": 8, "MIST": 7, "AIR": 7, "OFF": 0}


def _coolant(rec: Record, now: int) -> int:
    """The coolant in effect after a COOLNT/ record (unknown words keep the current state)."""
    for a in rec.args:
        if isinstance(a, str) and a in _COOLANT:
            return _COOLANT[a]
    return now
# statements that may not stand between a CIRCLE and its end GOTO
_BREAKS_ARC = frozenset(
    {"CIRCLE", "FROM", "GODLTA", "CUTTER", "TLDATA", "LOAD", "LOADTL", "TOOL PATH", "CSYS",
     "MSYS", "END-OF-PATH", "FINI", "END", "CYCLE"}
)


def _first_row(values: np.ndarray, bad) -> int | None:
    """The first row of ``values`` where ``bad(rows)`` (a row mask) holds, taken CHUNK rows at
    a time so that its temporaries stay small; None when there is none."""
    for c0 in range(0, len(values), CHUNK):
        hit = np.flatnonzero(bad(values[c0 : c0 + CHUNK]))
        if len(hit):
            return c0 + int(hit[0])
    return None


def _normalise(axis: np.ndarray) -> None:
    """In place: every row of ``axis`` (N, 3) divided by its length, CHUNK rows at a time."""
    for c0 in range(0, len(axis), CHUNK):
        a = axis[c0 : c0 + CHUNK]
        a /= np.linalg.norm(a, axis=1)[:, None]


def interpret(
    records: RecordList | list[Record], *, path: str, dialect: str, require_cutter: bool = True
) -> ToolPath:
    """The tool path of ``records``. ``require_cutter``: a feed move before any ``CUTTER/`` or
    ``TLDATA/`` is an error (rapid moves are allowed)."""
    records = RecordList.of(records)
    if not len(records.lines) and not any(r.word != "$$" for r in records.statements):
        raise PathcheckError(
            "empty file: expected CL statements (GOTO/, CUTTER/, ...), found none",
            path=path,
            line=None,
            code="parse",
        )
    units = file_units(records.statements, path=path)
    reader = _Reader(records, path=path, dialect=dialect, units=units,
                     require_cutter=require_cutter)
    step = reader.step
    goto = reader.goto
    g = 0
    for k, (index, rec) in enumerate(zip(records.at.tolist(), records.statements,
                                         strict=True)):
        if index - k > g:
            reader.plain_gotos(g, index - k)
            g = index - k
        if rec.word == "GOTO" and reader.pending_arc is None:
            goto(rec)
        else:
            step(index, rec)
    reader.plain_gotos(g, len(records.lines))
    return reader.finish()
