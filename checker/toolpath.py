"""Typed tool path model: plain data filled by the CL readers in `checker.apt`.

Units and frames: every number in `MotionArrays`, `Arc`, `Frame` and the cutters is in mm in the
part frame (after `CSYS/`/`MSYS/`); `Record.args` keep the numbers exactly as written in the file
(the file's units and frame) so that the writer can reproduce them.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal, overload

import numpy as np

from checker.errors import PathcheckError

if TYPE_CHECKING:
    from checker.cutter import Cutter

Value = float | str
MAX_ARC_POINTS = 1_000_000  # per arc, from `Arc.sample`


@dataclass(slots=True)
class Record:
    """One logical statement of the file (continuations joined), used or not.

    ``word`` is the major word in upper case (``"GOTO"``, ``"TOOL PATH"``, ``"$$"`` for a comment
    line); ``args`` the values after ``/`` (floats, or upper-case minor words); ``text`` the raw
    text of free-text statements (``PPRINT``, ``PARTNO``, ``INSERT``, comments); ``comment`` an
    inline ``$$`` comment; ``slash`` whether the word was followed by ``/``; ``line`` 1-based.
    """

    word: str
    args: tuple[Value, ...] = ()
    line: int = 0
    text: str | None = None
    comment: str | None = None
    slash: bool = True

    def same_as(self, other: Record, rel: float = 1e-9) -> bool:
        """Equal word, text and args, numbers to ``rel`` relative (line numbers ignored)."""
        if (self.word, self.text, self.comment, len(self.args)) != (
            other.word,
            other.text,
            other.comment,
            len(other.args),
        ):
            return False
        for a, b in zip(self.args, other.args, strict=True):
            if isinstance(a, str) or isinstance(b, str):
                if a != b:
                    return False
            elif abs(a - b) > rel * max(abs(a), abs(b), 1e-300):
                return False
        return True


class RecordList(Sequence[Record]):
    """The records of a file in order, without an object per plain GOTO: the other statements
    are `Record`s (``statements``, at positions ``at`` of the whole sequence), the plain GOTOs
    (3 or 6 numbers, no comment) rows of arrays: ``xyz`` (G, 3) and ``lines`` (G,) as written
    (file units and frame), the axis of the 6-value ones ``axis_values`` (K, 3) at GOTO rows
    ``axis_rows`` (K,). Indexing and iteration give `Record`s, a plain GOTO's made on demand."""

    __slots__ = ("at", "axis_rows", "axis_values", "lines", "statements", "xyz")

    def __init__(self, statements: list[Record], at: np.ndarray, xyz: np.ndarray,
                 lines: np.ndarray, axis_rows: np.ndarray, axis_values: np.ndarray) -> None:
        self.statements = statements
        self.at = np.asarray(at, dtype=np.int64)
        self.xyz = np.asarray(xyz, dtype=float).reshape(-1, 3)
        self.lines = np.asarray(lines)
        self.axis_rows = np.asarray(axis_rows, dtype=np.int64)
        self.axis_values = np.asarray(axis_values, dtype=float).reshape(-1, 3)

    @classmethod
    def of(cls, records: Sequence[Record]) -> RecordList:
        """Every record as a statement object."""
        if isinstance(records, RecordList):
            return records
        empty = np.zeros(0, dtype=np.int64)
        return cls(list(records), np.arange(len(records)), np.zeros((0, 3)), empty, empty,
                   np.zeros((0, 3)))

    def __len__(self) -> int:
        return len(self.statements) + len(self.lines)

    @overload
    def __getitem__(self, i: int) -> Record: ...

    @overload
    def __getitem__(self, i: slice) -> list[Record]: ...

    def __getitem__(self, i: int | slice) -> Record | list[Record]:
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(len(self)))]
        n = len(self)
        if i < 0:
            i += n
        if not 0 <= i < n:
            raise IndexError("record index out of range")
        k = int(np.searchsorted(self.at, i))
        if k < len(self.at) and self.at[k] == i:
            return self.statements[k]
        return self.goto_record(i - k)

    def goto_record(self, g: int) -> Record:
        """The plain GOTO of row ``g`` as a record."""
        args = tuple(self.xyz[g].tolist())
        j = int(np.searchsorted(self.axis_rows, g))
        if j < len(self.axis_rows) and self.axis_rows[j] == g:
            args += tuple(self.axis_values[j].tolist())
        return Record("GOTO", args, int(self.lines[g]))

    def _gotos(self, g0: int, g1: int) -> Iterator[Record]:
        """The plain GOTOs of rows [g0, g1) as records, converted in bulk."""
        j = int(np.searchsorted(self.axis_rows, g0))
        rows = self.axis_rows
        for g, xyz, line in zip(range(g0, g1), self.xyz[g0:g1].tolist(),
                                self.lines[g0:g1].tolist(), strict=True):
            if j < len(rows) and rows[j] == g:
                yield Record("GOTO", (*xyz, *self.axis_values[j].tolist()), line)
                j += 1
            else:
                yield Record("GOTO", tuple(xyz), line)

    def __iter__(self) -> Iterator[Record]:
        g = 0
        for k, rec in enumerate(self.statements):
            end = int(self.at[k]) - k
            if end > g:
                yield from self._gotos(g, end)
                g = end
            yield rec
        yield from self._gotos(g, len(self.lines))

    def goto_counts(self, start: int, stop: int) -> tuple[int, int]:
        """(GOTO records, those with 6 values) among records [start, stop)."""
        k0, k1 = np.searchsorted(self.at, [start, stop])
        objs = [r for r in self.statements[k0:k1] if r.word == "GOTO"]
        g0, g1 = start - k0, stop - k1
        a0, a1 = np.searchsorted(self.axis_rows, [g0, g1])
        return (int(g1 - g0) + len(objs),
                int(a1 - a0) + sum(len(r.args) == 6 for r in objs))


@dataclass(frozen=True, slots=True)
class Frame:
    """A coordinate system statement: ``matrix`` (4, 4) maps file-frame mm to part-frame mm.

    ``applied`` is False where the file says its coordinates are already in the world frame
    (``TRNTYP/WORLD`` before ``CSYS/``): the frame is then only recorded.
    """

    word: str
    matrix: np.ndarray
    line: int
    applied: bool


@dataclass(frozen=True, slots=True)
class ToolChange:
    """A ``LOAD/TOOL``/``LOADTL`` statement: the tool number and the cutter active then."""

    line: int
    tool_number: int | None
    cutter: Cutter | None


@dataclass(slots=True)
class Operation:
    """A stretch of the path with one tool: records ``[first_record, end_record)`` and motions
    ``[first_motion, end_motion)`` of `ToolPath.motion_arrays()` (without arc expansion)."""

    name: str
    tool_name: str | None = None
    tool_number: int | None = None
    cutter: Cutter | None = None
    first_record: int = 0
    end_record: int = 0
    first_motion: int = 0
    end_motion: int = 0


@dataclass(frozen=True, slots=True)
class Motion:
    """One motion: tool tip (3,) and unit axis (3,) in mm / part frame, feed mm/min (nan: none),
    spindle rpm (nan: unknown), 1-based file line, operation index."""

    tip: np.ndarray
    axis: np.ndarray
    rapid: bool
    feed: float
    spindle: float
    line: int
    op: int


@dataclass(frozen=True, slots=True)
class Arc:
    """A ``CIRCLE/`` arc ending at the next ``GOTO``: centre (3,), unit axis (3,) (the motion is
    counter-clockwise about it, right-hand rule), radius, start and end tips (3,); mm, part
    frame. A helical arc moves linearly along the axis. ``motion`` is the row of its end GOTO;
    ``turns`` full revolutions are made on top of the angle from start to end (NX ``TIMES,n``)."""

    center: np.ndarray
    axis: np.ndarray
    radius: float
    start: np.ndarray
    end: np.ndarray
    line: int
    motion: int
    turns: int = 0

    @property
    def sweep(self) -> float:
        """Swept angle in radians: the angle from start to end in [0, 2 pi) (2 pi when they
        coincide and ``turns`` is 0) plus 2 pi per extra turn."""
        u, v = self._radial(self.start), self._radial(self.end)
        ang = float(np.arctan2(np.dot(np.cross(u, v), self.axis), np.dot(u, v)))
        if ang < 0:
            ang += 2 * np.pi
        if ang * self.radius <= 1e-9 * max(self.radius, 1.0) and self.turns == 0:
            return 2 * np.pi
        return ang + 2 * np.pi * self.turns

    def _radial(self, p: np.ndarray) -> np.ndarray:
        d = p - self.center
        return d - np.dot(d, self.axis) * self.axis

    def sample(self, chord_tol: float) -> np.ndarray:
        """Points (M, 3) along the arc from start to end inclusive, M >= 2, such that the
        chordal deviation of each segment from the circle is at most ``chord_tol`` mm."""
        if not chord_tol > 0:
            raise PathcheckError(f"arc chord tolerance must be > 0 mm, found {chord_tol!r}",
                                 code="usage")
        sweep = self.sweep
        r = self.radius
        if r <= chord_tol:
            n = 1
        else:
            x = chord_tol / r  # half-angle step from the sagitta; the sqrt form where 1 - x == 1
            step = 2.0 * np.arccos(1.0 - x) if x > 1e-8 else 2.0 * np.sqrt(2.0 * x)
            n = max(1, int(np.ceil(sweep / step)))
        if n > MAX_ARC_POINTS:
            raise PathcheckError(
                f"CIRCLE/: sampling this arc (radius {r:.6g} mm, {sweep / (2 * np.pi):.6g} turns) "
                f"to {chord_tol:g} mm needs {n} points, more than {MAX_ARC_POINTS}",
                line=self.line,
                code="usage",
            )
        t = np.linspace(0.0, 1.0, n + 1)
        u = self._radial(self.start)
        nu = np.linalg.norm(u)
        u = u / nu if nu > 0 else _any_normal(self.axis)
        w = np.cross(self.axis, u)
        h0 = np.dot(self.start - self.center, self.axis)
        h1 = np.dot(self.end - self.center, self.axis)
        ang = t * sweep
        pts = (
            self.center
            + r * (np.cos(ang)[:, None] * u + np.sin(ang)[:, None] * w)
            + (h0 + t * (h1 - h0))[:, None] * self.axis
        )
        pts[0], pts[-1] = self.start, self.end
        return pts


def _any_normal(a: np.ndarray) -> np.ndarray:
    """A unit vector normal to the unit vector ``a``."""
    b = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    v = np.cross(a, b)
    return v / np.linalg.norm(v)


@dataclass(frozen=True, slots=True)
class MotionArrays:
    """All motions (GOTO, GODLTA, FROM) as arrays, mm and part frame.

    tip (N, 3), axis (N, 3) unit tip -> spindle, rapid (N,) bool, feed (N,) mm/min (nan: none),
    spindle (N,) rpm (nan: unknown), line (N,) 1-based file line, op (N,) operation index,
    cycle (N,) bool (inside ``CYCLE/``...``CYCLE/OFF``: a canned-cycle position), arc (N,) index
    into `ToolPath.arcs` of the arc ending at that row, -1 for straight moves (arc-sampled rows
    from ``motion_arrays(arc_chord_tol=...)`` carry the arc index too), coolant (N,) in effect
    (0 off, 7 mist, 8 flood, -1 not stated), cycle_geometry (N, 3) the canned cycle's depth,
    clearance and retract distances along the axis from the hole position (mm; nan outside a
    cycle; None when the source gives none).
    """

    tip: np.ndarray
    axis: np.ndarray
    rapid: np.ndarray
    feed: np.ndarray
    spindle: np.ndarray
    line: np.ndarray
    op: np.ndarray
    cycle: np.ndarray
    arc: np.ndarray
    coolant: np.ndarray
    cycle_geometry: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.line)

    def motion(self, i: int) -> Motion:
        """Row ``i`` as a `Motion`."""
        return Motion(
            tip=self.tip[i],
            axis=self.axis[i],
            rapid=bool(self.rapid[i]),
            feed=float(self.feed[i]),
            spindle=float(self.spindle[i]),
            line=int(self.line[i]),
            op=int(self.op[i]),
        )

    def take(self, idx: np.ndarray) -> MotionArrays:
        """Rows ``idx`` (an index array) of every field."""
        cols = (getattr(self, f) for f in _MOTION_FIELDS)
        return MotionArrays(*(None if c is None else c[idx] for c in cols))


_MOTION_FIELDS = ("tip", "axis", "rapid", "feed", "spindle", "line", "op", "cycle", "arc",
                  "coolant", "cycle_geometry")


@dataclass(slots=True)
class ToolPath:
    """A CL file read into memory; see the module docstring for units and frames."""

    path: str
    dialect: Literal["apt", "clsf", "gcode"]
    units: Literal["mm", "inch"]
    records: Sequence[Record]
    operations: list[Operation]
    motions: MotionArrays
    arcs: list[Arc] = field(default_factory=list)
    tool_changes: list[ToolChange] = field(default_factory=list)
    frames: list[Frame] = field(default_factory=list)
    unknown: dict[str, int] = field(default_factory=dict)
    ignored: dict[str, int] = field(default_factory=dict)

    def machine_name(self) -> str | None:
        """The machine the CL file names (its first `PPRINT/MACHINE NAME`), or None."""
        records = self.records
        for record in records.statements if isinstance(records, RecordList) else records:
            words = (record.text or "").split() if record.word == "PPRINT" else []
            if len(words) == 2 and words[0].upper() == "MACHINE":
                return words[1]
        return None

    def motion_arrays(self, arc_chord_tol: float | None = None) -> MotionArrays:
        """The motions; with ``arc_chord_tol`` (mm) every arc is expanded into points placed
        before its end row, with the end row's axis, feed, line and operation."""
        m = self.motions
        if arc_chord_tol is None or not self.arcs:
            return m
        pieces: list[np.ndarray] = []
        rows: list[np.ndarray] = []
        prev = 0
        for arc in self.arcs:
            inner = arc.sample(arc_chord_tol)[1:-1]
            rows.append(np.arange(prev, arc.motion))
            pieces.append(m.tip[prev : arc.motion])
            rows.append(np.full(len(inner), arc.motion))
            pieces.append(inner)
            prev = arc.motion
        rows.append(np.arange(prev, len(m)))
        pieces.append(m.tip[prev:])
        idx = np.concatenate(rows).astype(np.intp)
        out = m.take(idx)
        return MotionArrays(
            np.concatenate(pieces).reshape(-1, 3),
            out.axis,
            out.rapid,
            out.feed,
            out.spindle,
            out.line,
            out.op,
            out.cycle,
            out.arc,
            out.coolant,
            out.cycle_geometry,
        )
