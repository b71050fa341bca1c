"""G-code reader: a program in a dialect -> its motion blocks in the work frame (machine axes),
with modal state (motion, plane, distance, feed mode, units, tool, spindle, coolant) resolved.

Interpreted: G0-G3 (arcs by I/J/K or R, planes G17-G19), canned cycles G73/G76/G81-G89 (each hole
as rapid down to R, feed to Z, rapid back to R or the initial level), G20/G21 (converted to mm),
G90/G91, G93/G94/G95, G28/G30 and G53 (the named linear axes end unknown in the work frame),
G92 and G10 L20 (set the position), T/M6, S/M3/M4/M5, M7/M8/M9, A/B/C words, full circles by
I/J/K alone; per dialect (`checker.postproc.dialects`): the units and feed-mode codes (Sinumerik,
Heidenhain and MillPlus G70/G71), the machine-frame words (G53, SUPA, G74, M91), the words that
switch tool-centre-point control (G43.4, G234, M428, TRAORI, M128, G141) and their cancels,
Sinumerik ``MCALL CYCLE81..89(RTP, RFP, SDIS, DP, DPR)`` holes, MillPlus G93/G92 datum shifts, G7
tilted planes (``A5= B5= C5=``: rotations about X, then Y, then Z; the XYZ that follow are in the
tilted frame and the tool is along its Z) and G8x definitions called by G79, LinuxCNC M61 Q,
Heidenhain ``T`` tool calls, block delete (a block starting with ``/``: skipped while the
switch is on, the default, else run; counted either way). Other codes of the dialect table are
accepted and counted. Unknown positions are NaN.
"""

from __future__ import annotations

import math
import re
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from checker.errors import PathcheckError, read_input
from checker.input_limits import MAX_ARC_TURNS, MAX_COORDINATE_MM, MAX_ROTARY_DEG
from checker.postproc.dialects import CANNED_CYCLES, Dialect, get_dialect
from checker.postproc.gcode_lex import Block, lex_block
from checker.units import mm_per_unit

_NO_CENTER = (math.nan, math.nan, math.nan)
_NOT_TEXT = re.compile(r"[^\t\n\r\x0b\x0c\x20-\x7e]")
#: row kinds
PROGRAMMED, CYCLE, HOME, MACHINE_FRAME = 0, 1, 2, 3
_AXES = "XYZABC"
_PLANES = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}  # (u, v, normal) axis indices
_ARC_OFFSETS = "IJK"
#: Sinumerik drilling and boring cycles read as holes
_SIEMENS_CYCLE = re.compile(r"CYCLE(7[67]|8[1-9])")
#: keys of `GcodeMoves.other` counting the block-delete (``/``) blocks, as the switch was set
BLOCK_DELETE_SKIPPED = "/ blocks skipped (block delete on)"
BLOCK_DELETE_RUN = "/ blocks run (block delete off)"


@dataclass(frozen=True)
class GcodeMoves:
    """Motion rows of a program in order. ``xyz (N,3)`` end point, work frame, mm (NaN unknown);
    ``abc (N,3)`` rotary words at the end, degrees as written (NaN never set); ``motion (N,)`` 0
    rapid, 1 linear, 2 CW arc, 3 CCW arc; ``center (N,3)`` arc centre mm (NaN otherwise) in
    ``plane (N,)`` 17/18/19; ``feed (N,)`` F in effect (mm/min for G94, 1/min for G93, mm/rev for
    G95) and ``feed_mode (N,)``; ``tool``, ``spindle`` (signed rpm, 0 stopped), ``coolant`` (0, 7,
    8; -1 unknown) in effect; ``line (N,)`` program line (1-based); ``kind (N,)`` PROGRAMMED,
    CYCLE, HOME or MACHINE_FRAME; ``tcp (N,)`` the xyz are work-frame tips (tool-centre-point
    control or a tilted plane); ``tool_axis (N,3)`` the work-frame tool axis a tilted plane
    fixes (NaN otherwise)."""

    path: str
    dialect: str
    units: str
    xyz: np.ndarray
    abc: np.ndarray
    motion: np.ndarray
    center: np.ndarray
    plane: np.ndarray
    feed: np.ndarray
    feed_mode: np.ndarray
    tool: np.ndarray
    spindle: np.ndarray
    coolant: np.ndarray
    line: np.ndarray
    kind: np.ndarray
    tcp: np.ndarray = None  # type: ignore[assignment]
    tool_axis: np.ndarray = None  # type: ignore[assignment]
    comments: tuple[tuple[int, str], ...] = ()
    other: dict[str, int] = field(default_factory=dict)
    blocks: int = 0  # blocks read (program lines with code or a comment)
    units_stated: bool = False  # the program states its units (G20/G21 or the dialect's own)
    #: (N,) full turns of each arc row (LinuxCNC's G2/G3 P word, 1 without; 1 for other rows);
    #: None: every arc makes one
    arc_turns: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.line)


@dataclass
class _State:
    scale: float
    units: str
    pos: list[float]  # XYZABC, mm / degrees
    motion: int | None = None
    cycle: str | None = None
    plane: int = 17
    absolute: bool = True
    arc_absolute: bool = False
    feed_mode: int = 94
    feed: float = math.nan
    tool: int = 0
    next_tool: int = 0
    speed: float = math.nan
    spindle_dir: int = 0
    coolant: int = -1
    retract_initial: bool = True  # G98
    cycle_r: float = math.nan
    cycle_z: float = math.nan
    cycle_initial: float = math.nan
    tcp: bool = False
    datum: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])  # MillPlus G93/G92
    tilt: np.ndarray | None = None  # MillPlus G7 frame (3x3), None: untilted
    mcall: list[float] | None = None  # Sinumerik modal cycle arguments
    cycle_def: dict[str, float] | None = None  # MillPlus G8x definition

class _Program:
    """Accumulates rows while the state machine walks the blocks."""

    def __init__(self, dialect: Dialect, path: str, units: str):
        self.dialect, self.path = dialect, path
        scale = mm_per_unit(units)
        self.st = _State(
            scale=scale, units=units, pos=[math.nan] * 6, motion=dialect.initial_motion
        )
        self.arc_turns: dict[int, int] = {}  # row -> turns of an arc with P > 1
        self.rows: dict[str, list] = {
            k: []
            for k in (
                "xyz",
                "abc",
                "motion",
                "center",
                "plane",
                "feed",
                "feed_mode",
                "tool",
                "spindle",
                "coolant",
                "line",
                "kind",
                "tcp",
                "tool_axis",
            )
        }
        self.comments: list[tuple[int, str]] = []
        self.other: Counter[str] = Counter()
        self.params: dict[str, float] = {}
        self.units_seen: str | None = None
        self.blocks = 0

    def error(self, message: str, line: int) -> PathcheckError:
        return PathcheckError(message, path=self.path, line=line, code="gcode")

    def _out(self, pos: list[float]) -> list[float]:
        """Programmed XYZ (tilted frame, datum shift) -> work frame."""
        st = self.st
        xyz = np.asarray(pos[:3], dtype=float)
        if st.tilt is not None:
            xyz = st.tilt @ xyz
        return (xyz + np.asarray(st.datum)).tolist()

    def reframe(self, datum: list[float], tilt: np.ndarray | None) -> None:
        """Change the datum / tilted plane keeping the tool where it is (in the work frame)."""
        st = self.st
        here = np.asarray(self._out(st.pos), dtype=float) - np.asarray(datum)
        if tilt is not None:
            here = tilt.T @ here
        st.datum, st.tilt = list(datum), tilt
        st.pos[:3] = here.tolist()

    def emit(self, pos: list[float], motion: int, line: int, kind: int, center=None) -> None:
        st = self.st
        r = self.rows
        framed = st.tilt is not None or any(st.datum)
        if framed:
            if center is not None and np.isfinite(center).all():
                c = np.asarray(center, float)
                center = (st.tilt @ c if st.tilt is not None else c) + np.asarray(st.datum)
            r["xyz"].append(self._out(pos))
        else:
            r["xyz"].append(pos[:3])
        r["tcp"].append(st.tcp or st.tilt is not None)
        r["tool_axis"].append(_NO_CENTER if st.tilt is None else st.tilt[:, 2].tolist())
        r["abc"].append(pos[3:])
        r["motion"].append(motion)
        r["center"].append(_NO_CENTER if center is None else center)
        r["plane"].append(st.plane)
        r["feed"].append(st.feed)
        r["feed_mode"].append(st.feed_mode)
        r["tool"].append(st.tool)
        spindle = 0.0 if st.spindle_dir == 0 else st.spindle_dir * st.speed
        r["spindle"].append(spindle)
        r["coolant"].append(st.coolant)
        r["line"].append(line)
        r["kind"].append(kind)
        st.pos = list(pos)

    # -- one block -------------------------------------------------------------------------
    def block(self, block: Block, line: int) -> None:
        self.comments += [(line, c) for c in block.comments if c]
        g_codes: dict[str, str] = {}
        m_codes: list[int] = []
        words: dict[str, float] = {}
        tools: list[float] = []
        tokens: set[str] = {name for name, _ in block.keywords}
        for letter, value in block.words:
            if letter not in self.dialect.letters:
                raise self.error(f"{letter} is not a word of the {self.dialect.name} dialect", line)
            if letter in "GMT" and not math.isfinite(value):
                raise self.error(
                    f"{letter} word has no known value (an unset parameter?): expected a number",
                    line,
                )
            if letter == "G":
                code = f"{value:g}"
                group = self.dialect.group_of(code, path=self.path, line=line)
                if group in g_codes and not self.dialect.last_g_wins:
                    raise self.error(
                        f"G{g_codes[group]} and G{code} are both in modal group '{group}': "
                        "expected one per block",
                        line,
                    )
                g_codes[group] = code
                tokens.add(f"G{code}")
            elif letter == "M":
                m_codes.append(int(value))
                tokens.add(f"M{int(value)}")
            elif letter == "T":
                tools.append(value)
            elif letter in ("N", "O"):
                continue
            elif letter in words:
                raise self.error(
                    f"word {letter} appears twice in the block: expected it once", line
                )
            else:
                words[letter] = value
        for name, _ in block.assignments:
            self.other[f"{name.rstrip('0123456789') if name[0].isalpha() else '#'}="] += 1
        for name, args in block.keywords:
            if name == "CR" and args:  # Sinumerik arc radius
                words["R"] = args[0]
            elif name not in ("MCALL", "SUPA") and not _SIEMENS_CYCLE.fullmatch(name):
                self.other[name] += 1
        assigned = dict(block.assignments)
        self._modes(g_codes, words, m_codes, tools, line)
        dia = self.dialect
        if tokens & dia.tcp_on:
            self.st.tcp = True
        elif tokens & dia.tcp_off:
            self.st.tcp = False
        if not self._frames(g_codes, words, assigned, block.keywords, line):
            self._motion(g_codes, words, line, machine_frame=bool(tokens & dia.machine_frame))
        for name, value in block.assignments:
            self.params[name] = value

    def _modes(
        self,
        g: dict[str, str],
        words: dict[str, float],
        m_codes: list[int],
        tools: list[float],
        line: int,
    ) -> None:
        st = self.st
        if "units" in g:
            self.set_units(self.dialect.units_codes[g["units"]])
        if "feed_mode" in g:
            st.feed_mode = self.dialect.feed_codes[g["feed_mode"]]
        if "F" in words:
            f = words["F"]
            st.feed = f if st.feed_mode == 93 else f * st.scale
        if "S" in words:
            st.speed = words["S"]
        if tools:
            st.next_tool = int(tools[0])
            if self.dialect.tool_call_on_t:
                st.tool = st.next_tool
        for m in m_codes:
            if m == 61 and "Q" in words:  # LinuxCNC: set the tool in the spindle
                st.tool = int(words["Q"])
            elif m == 6:
                st.tool = st.next_tool
                if len(tools) > 1:
                    st.next_tool = int(tools[1])
            elif m in (3, 4, 5):
                st.spindle_dir = {3: 1, 4: -1, 5: 0}[m]
            elif m in (7, 8, 9):
                st.coolant = 0 if m == 9 else m
            elif m not in (0, 1, 2, 30, 61):
                self.other[f"M{m}"] += 1
        if "plane" in g:
            st.plane = int(g["plane"])
        if "distance" in g:
            st.absolute = g["distance"] == "90"
        if "arc_distance" in g:
            st.arc_absolute = g["arc_distance"] == "90.1"
        if "return_mode" in g:
            st.retract_initial = g["return_mode"] == "98"
        for group in (
            "cutter_comp",
            "length_offset",
            "coord_system",
            "path_control",
            "polar",
            "rotation",
        ):
            if group in g:
                self.other[f"G{g[group]}"] += 1

    def _target(self, words: dict[str, float], line: int) -> tuple[list[float], bool]:
        """End position of the block's axis words (absolute or incremental) and whether any."""
        st = self.st
        pos = list(st.pos)
        given = False
        for k, letter in enumerate(_AXES):
            if letter in words:
                given = True
                value = words[letter] * (st.scale if k < 3 else 1.0)
                pos[k] = value if st.absolute else pos[k] + value
                self.bounded(pos[k], letter, line, rotary=k >= 3)
        return pos, given

    def bounded(self, value: float, word: str, line: int, *, rotary: bool = False) -> float:
        """`value` (mm, or degrees for a rotary axis) when within any machine's reach (NaN,
        unknown, passes); else an error naming the line and the word."""
        limit, unit = (MAX_ROTARY_DEG, "deg") if rotary else (MAX_COORDINATE_MM, "mm")
        if abs(value) > limit:
            raise self.error(
                f"{word} reaches {value:.6g} {unit}, beyond any machine's reach: expected "
                f"within +-{limit:g} {unit}", line)
        return value

    def set_units(self, units: str) -> None:
        st = self.st
        st.units = units
        st.scale = mm_per_unit(units)
        self.units_seen = self.units_seen or units

    def _frames(self, g, words, assigned, keywords, line) -> bool:
        """Dialect blocks that are not motion: MillPlus datum shifts, tilted planes, cycle
        definitions and calls; Sinumerik cycles. True when the block is done."""
        st = self.st
        if "datum" in g:  # MillPlus G93 absolute / G92 incremental datum shift
            base = [0.0, 0.0, 0.0] if g["datum"] == "93" else list(st.datum)
            shift = [self.bounded(base[k] + words.get(a, 0.0) * st.scale, a, line)
                     for k, a in enumerate("XYZ")]
            self.reframe(shift, st.tilt)
            self.other[f"G{g['datum']}"] += 1
            return True
        if "tilt" in g:  # MillPlus G7 A5= B5= C5=: the working plane
            angles = [assigned.get(f"{a}5", 0.0) for a in "ABC"]
            if not all(math.isfinite(v) for v in angles):
                raise self.error("G7 plane angles A5= B5= C5= must be known numbers", line)
            rot = _rot_xyz(*angles)
            self.reframe(st.datum, None if np.allclose(rot, np.eye(3)) else rot)
            self.other["G7"] += 1
            return True
        if "cycle_def" in g:  # MillPlus G8x: define the cycle G79 calls
            st.cycle_def = {k: v * (st.scale if k in "YZB" else 1.0) for k, v in words.items()}
            if "F" in words:
                st.feed = words["F"] * st.scale
            self.other[f"G{g['cycle_def']}"] += 1
            return True
        if self.dialect.cycle_call and g.get("non_modal") == self.dialect.cycle_call:
            target, _ = self._target(words, line)
            self._millplus_hole(target, line)
            return True
        for name, args in keywords:
            if name == "MCALL":
                st.mcall = None
                cycles = [a for n, a in keywords if _SIEMENS_CYCLE.fullmatch(n)]
                if cycles:
                    st.mcall = cycles[0]
                return True
            if _SIEMENS_CYCLE.fullmatch(name):
                self._siemens_hole(list(st.pos), args, line)
                return True
        return False

    def _siemens_hole(self, target: list[float], args: list[float], line: int) -> None:
        """One Sinumerik drilling cycle at X/Y: rapid to RFP + SDIS, feed to DP (or RFP - DPR),
        rapid back to RTP."""
        st = self.st
        rtp, rfp, sdis, dp, dpr = ([*args, *[math.nan] * 5])[:5]
        s = st.scale
        sdis = 0.0 if not math.isfinite(sdis) else sdis
        depth = dp if math.isfinite(dp) else rfp - dpr
        hole = list(target)
        self.emit(hole, 0, line, CYCLE)
        for z, motion in (((rfp + sdis) * s, 0), (depth * s, 1), (rtp * s, 0)):
            hole[2] = self.bounded(z, "cycle plane", line)
            self.emit(hole, motion, line, CYCLE)

    def _millplus_hole(self, target: list[float], line: int) -> None:
        """MillPlus G79 at X Y Z (the surface): rapid to Z + Y (set-up clearance), feed to
        Z + Z (the depth, negative), rapid to Z + B (retract)."""
        st = self.st
        d = st.cycle_def or {}
        top = target[2]
        hole = list(target)
        hole[2] = top + d.get("B", d.get("Y", 0.0))
        self.emit(hole, 0, line, CYCLE)
        for z, motion in ((top + d.get("Y", 0.0), 0), (top + d.get("Z", 0.0), 1),
                          (top + d.get("B", d.get("Y", 0.0)), 0)):
            hole[2] = self.bounded(z, "cycle plane", line)
            self.emit(hole, motion, line, CYCLE)

    def _motion(self, g: dict[str, str], words: dict[str, float], line: int,
                machine_frame: bool = False) -> None:
        st = self.st
        non_modal = g.get("non_modal")
        if non_modal == "4":  # dwell: X/P are the time
            return
        for code in (g.get("cycle"), g.get("motion")):  # Fanuc: cycles in their own group
            if code in CANNED_CYCLES:
                if st.cycle is None:
                    st.cycle_initial = st.pos[2]
                st.cycle = code
            elif code == "80":
                st.cycle = None
            elif code is not None:
                st.cycle, st.motion = None, int(code)
        target, given = self._target(words, line)
        if non_modal in ("10", "92"):
            self.other[f"G{non_modal}"] += 1
            if non_modal == "92" or words.get("L") == 20:
                for k, a in enumerate(_AXES):
                    if a in words:
                        st.pos[k] = target[k]
            return
        if non_modal in self.dialect.home_codes:
            homed = [k for k, a in enumerate("XYZ") if a in words] or [0, 1, 2]  # none: all
            for k in homed:
                target[k] = math.nan  # at the reference point: unknown in the work frame
            self.emit(target, 0, line, HOME)
            return
        defines = g.get("motion") in CANNED_CYCLES or g.get("cycle") in CANNED_CYCLES
        if st.cycle is not None and (given or defines):
            self._cycle(target, words, line)
            return
        if st.mcall is not None and given and not machine_frame:
            self.emit(target, 0, line, PROGRAMMED)
            self._siemens_hole(target, st.mcall, line)
            return
        if st.motion in (2, 3) and any(k in words for k in _ARC_OFFSETS):
            given = True  # I/J/K without an end point: a full circle (Fanuc)
        if not given:
            return
        if st.motion is None:
            raise self.error(
                "axis words without a motion mode: expected G0, G1, G2 or G3 first", line
            )
        if machine_frame:  # machine coordinates: unknown in the work frame
            for k, a in enumerate("XYZ"):
                if a in words:
                    target[k] = math.nan
            self.emit(target, st.motion, line, MACHINE_FRAME)
            return
        center = self._arc_center(target, words, line) if st.motion in (2, 3) else None
        turns = self._arc_turns(words, line) if st.motion in (2, 3) else 1
        if turns > 1:
            self.arc_turns[len(self.rows["line"])] = turns
        self.emit(target, st.motion, line, PROGRAMMED, center)

    def _arc_turns(self, words: dict[str, float], line: int) -> int:
        """LinuxCNC's turn count of G2/G3, `P` (1 without): the arc ends after P - 1 extra full
        turns. As LinuxCNC, a P that is not a whole number (within 0.001) is an error; so is
        one below 1 or above MAX_ARC_TURNS. Other dialects give P no meaning on an arc."""
        if self.dialect.name != "linuxcnc" or "P" not in words:
            return 1
        p = words["P"]
        if not math.isfinite(p) or abs(p - round(p)) > 0.001:
            raise self.error(f"arc turn count P{p:g} is not a whole number: expected P1, P2, "
                             "... (full turns of G2/G3)", line)
        if not 1 <= round(p) <= MAX_ARC_TURNS:
            raise self.error(f"arc turn count P{p:g}: expected 1 to {MAX_ARC_TURNS:,} turns",
                             line)
        return int(round(p))

    def _arc_center(self, target: list[float], words: dict[str, float], line: int) -> np.ndarray:
        st = self.st
        u, v, w = _PLANES[st.plane]
        start, end = np.array(st.pos[:3]), np.array(target[:3])
        center = start.copy()
        self._known_arc_words(words, line)
        if "R" in words:
            radius = self.bounded(words["R"] * st.scale, "R", line)
            d = end[[u, v]] - start[[u, v]]
            chord = float(np.hypot(*d))
            if chord == 0.0 or chord > 2 * abs(radius) + 1e-9:
                raise self.error(
                    f"arc radius R{words['R']:g} cannot join the start and end points "
                    f"(chord {chord:.4f} mm)",
                    line,
                )
            h = math.sqrt(max(radius**2 - chord**2 / 4, 0.0))
            left = np.array([-d[1], d[0]]) / chord
            side = (1.0 if st.motion == 3 else -1.0) * (1.0 if radius > 0 else -1.0)
            mid = 0.5 * (start[[u, v]] + end[[u, v]])
            center[[u, v]] = mid + side * h * left
            return center
        offsets = [
            words.get(_ARC_OFFSETS[k], math.nan if st.arc_absolute else 0.0) * st.scale
            for k in (u, v)
        ]
        if st.arc_absolute:
            center[[u, v]] = offsets
        else:
            center[[u, v]] = start[[u, v]] + np.array(offsets)
        for k in (u, v):
            self.bounded(center[k], f"arc centre {_ARC_OFFSETS[k]}", line)
        if not any(_ARC_OFFSETS[k] in words for k in (u, v)):
            if np.allclose(end, start, atol=1e-12, equal_nan=True):
                return np.full(3, np.nan)  # no displacement, no centre: the block does not move
            raise self.error(
                f"arc without centre: expected {_ARC_OFFSETS[u]}/{_ARC_OFFSETS[v]} or R "
                f"in plane G{st.plane}",
                line,
            )
        center[w] = start[w]
        return center

    def _known_arc_words(self, words: dict[str, float], line: int) -> None:
        """An arc needs its R or I/J/K: one that has no known value (an unset parameter such
        as `R#7`, a HAL pin) is an error here, where the move needs it."""
        for letter in ("R", *_ARC_OFFSETS):
            if letter in words and not math.isfinite(words[letter]):
                raise self.error(
                    f"arc word {letter} has no known value (an unset parameter?): expected a "
                    "number", line)

    def _cycle(self, target: list[float], words: dict[str, float], line: int) -> None:
        """One hole: rapid to X/Y, rapid to R, feed to Z, rapid back (G98 initial, G99 R)."""
        st = self.st
        if "R" in words:
            r = words["R"] * st.scale
            st.cycle_r = self.bounded(r if st.absolute else st.cycle_initial + r, "R", line)
        if "Z" in words:
            z = words["Z"] * st.scale
            st.cycle_z = self.bounded(z if st.absolute else st.cycle_r + z, "Z", line)
        hole = list(target)
        hole[2] = st.pos[2]
        self.emit(hole, 0, line, CYCLE)
        for z, motion in ((st.cycle_r, 0), (st.cycle_z, 1)):
            hole[2] = z
            self.emit(hole, motion, line, CYCLE)
        hole[2] = st.cycle_initial if st.retract_initial else st.cycle_r
        self.emit(hole, 0, line, CYCLE)

    def result(self) -> GcodeMoves:
        r = self.rows
        n = len(r["line"])

        def arr(key, dtype, shape=()):
            return np.asarray(r[key], dtype=dtype).reshape((n, *shape))

        return GcodeMoves(
            path=self.path,
            dialect=self.dialect.name,
            units=self.units_seen or self.st.units,
            xyz=arr("xyz", float, (3,)),
            abc=arr("abc", float, (3,)),
            motion=arr("motion", int),
            center=arr("center", float, (3,)),
            plane=arr("plane", int),
            feed=arr("feed", float),
            feed_mode=arr("feed_mode", int),
            tool=arr("tool", int),
            spindle=arr("spindle", float),
            coolant=arr("coolant", int),
            line=arr("line", int),
            kind=arr("kind", int),
            tcp=arr("tcp", bool),
            tool_axis=arr("tool_axis", float, (3,)),
            comments=tuple(self.comments),
            other=dict(self.other),
            blocks=self.blocks,
            units_stated=self.units_seen is not None,
            arc_turns=self._turns(n),
        )

    def _turns(self, n: int) -> np.ndarray | None:
        """(n,) turns of every row from the rows' P words, None when every arc makes one."""
        if not self.arc_turns:
            return None
        turns = np.ones(n, dtype=np.int64)
        turns[list(self.arc_turns)] = list(self.arc_turns.values())
        return turns


def read_gcode_text(
    text: str, dialect: str | Dialect, *, path: str = "<text>", units: str = "mm",
    block_delete: bool = True,
) -> GcodeMoves:
    """Motion rows of G-code ``text``; ``units`` is the control's default before G20/G21.

    ``block_delete`` is the operator's block-delete (optional block skip) switch: on, a block
    starting with ``/`` is skipped whole (its moves, modes, parameters and comments), as the
    control does; off, it runs like any other. On is the default because that is how a program
    with ``/`` blocks runs in production: the ``/`` blocks are the optional ones (a probing
    cycle, a first-part check, a spring pass) that the switch leaves out once the job is
    proven, so the check sees the moves production makes; ``block_delete=False`` reads the
    program as run with the switch off. Either way the ``/`` blocks are lexed (bad text is an
    error under both settings) and counted in ``other`` (`BLOCK_DELETE_SKIPPED` or
    `BLOCK_DELETE_RUN`), which the program summary lists."""
    dia = get_dialect(dialect) if isinstance(dialect, str) else dialect
    prog = _Program(dia, path, units)
    bad = _NOT_TEXT.search(text)
    if bad:
        number = text.count("\n", 0, bad.start()) + 1
        raise prog.error(
            f"expected printable ASCII G-code, found character {ord(bad.group(0)):#04x}", number
        )
    for number, raw in enumerate(text.splitlines(), start=1):
        stripped = raw.strip()
        if not stripped or stripped == "%":
            continue
        if dia.block_end and "%" in stripped:  # Heidenhain "%NAME G71 *" begin and end
            units = re.search(r"G7([01])", stripped.upper())
            if units:
                prog.set_units("inch" if units.group(1) == "0" else "mm")
            continue
        if (dia.program_number_letter and stripped[:1] in "oO"
                and not re.match(r"[oO]\s*[0-9]", stripped)):
            prog.other["program name"] += 1  # "O ENTER OP AND LAST 3 DIGITS"
            continue
        if not dia.program_number_letter and stripped[:1] in "oO":
            raise prog.error(
                "o-word subroutines and control flow are not supported: expected plain G-code",
                number,
            )
        block = lex_block(stripped, dia, prog.params, path=path, line=number)
        prog.blocks += 1
        if block.deleted:
            prog.other[BLOCK_DELETE_SKIPPED if block_delete else BLOCK_DELETE_RUN] += 1
            if block_delete:
                continue
        prog.block(block, number)
    return prog.result()


def read_gcode(
    path: str | Path, dialect: str | Dialect, *, units: str = "mm", block_delete: bool = True
) -> GcodeMoves:
    """Motion rows of the G-code file at ``path`` (see `read_gcode_text`; ``block_delete``
    the switch, on by default: ``/`` blocks skipped)."""
    path = Path(path)
    text = read_input(path, "G-code", code="gcode").decode("latin-1")
    return read_gcode_text(text, dialect, path=str(path), units=units,
                           block_delete=block_delete)


def _rot_xyz(a: float, b: float, c: float) -> np.ndarray:
    """Rz(c) Ry(b) Rx(a), degrees: rotations about X, then Y, then Z (fixed axes)."""
    a, b, c = np.radians([a, b, c])
    rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    rz = np.array([[np.cos(c), -np.sin(c), 0], [np.sin(c), np.cos(c), 0], [0, 0, 1]])
    return rz @ ry @ rx
