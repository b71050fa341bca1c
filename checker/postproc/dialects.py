"""G-code dialects as data (after LinuxCNC's rs274 interpreter): which G codes exist and their
modal groups, how codes, comments, block numbers and the program frame are written, the words
that switch tool-centre-point control, and a few hooks: the control's G94 feed-distance rule and
the code formatter.

Modal groups used by the reader (values are the normalised code, e.g. ``"0"``, ``"84.2"``):
motion, plane, distance, feed_mode, units, cutter_comp, length_offset, return_mode, coord_system,
path_control, arc_distance, non_modal, plus the dialect's own (``tilt``, ``datum``, ``cycle``).
Dialects: ``fanuc`` (Fanuc 0i/30i ISO), ``haas`` (Haas NGC), ``linuxcnc`` (rs274ngc),
``siemens`` (Sinumerik 840D ISO-like G code with TRAORI, SUPA, CYCLE8x), ``heidenhain``
(TNC ISO programming, blocks end with ``*``), ``millplus`` (Heidenhain/Philips MillPlus: G70/G71
inch/mm, G93 datum shift, G74 machine position, G7 tilted plane, G79 cycle call, G141 TCP).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from checker.errors import PathcheckError

#: G codes that are canned cycles: a hole at each X/Y of the block, down to Z from the R plane
CANNED_CYCLES = frozenset(
    {"73", "76", "81", "82", "83", "84", "84.2", "85", "86", "87", "88", "89"}
)

_MOTION = ("0", "1", "2", "3")


def _groups(**groups: tuple[str, ...]) -> dict[str, str]:
    return {code: name for name, codes in groups.items() for code in codes}


_COMMON_G: dict[str, str] = _groups(
    motion=(*_MOTION, "80", *sorted(CANNED_CYCLES - {"84.2"})),
    plane=("17", "18", "19"),
    distance=("90", "91"),
    feed_mode=("93", "94", "95"),
    units=("20", "21"),
    cutter_comp=("40", "41", "42"),
    length_offset=("43", "44", "49"),
    return_mode=("98", "99"),
    coord_system=("54", "55", "56", "57", "58", "59"),
    path_control=("61", "64"),
    non_modal=("4", "10", "28", "30", "53", "92"),
)


def _rot_sq(drot: np.ndarray) -> np.ndarray:
    drot = np.asarray(drot, dtype=float)
    if drot.ndim < 2:
        drot = drot.reshape(-1, 1)
    return (drot**2).sum(axis=1)


def _feed_distance_combined(dxyz: np.ndarray, drot: np.ndarray, tcp: bool = False) -> np.ndarray:
    """Fanuc-style G94 rule: F applies to sqrt(dX^2 + dY^2 + dZ^2 + dA^2 + dB^2 + dC^2), degrees
    counted as length units; with tool-centre-point control F is the tip's speed (the
    linear-first rule). ``dxyz (N, 3)`` in program units, ``drot (N, k)`` degrees."""
    if tcp:
        return _feed_distance_linear_first(dxyz, drot)
    return np.sqrt((np.asarray(dxyz) ** 2).sum(axis=1) + _rot_sq(drot))


def _feed_distance_linear_first(dxyz: np.ndarray, drot: np.ndarray, tcp: bool = False):
    """LinuxCNC / Siemens / Heidenhain G94 rule: F applies to the XYZ distance when it is
    non-zero, otherwise to sqrt(dA^2 + dB^2 + dC^2) in degrees (per minute)."""
    lin = np.linalg.norm(dxyz, axis=1)
    return np.where(lin > 0.0, lin, np.sqrt(_rot_sq(drot)))


def _code_padded(letter: str, code: float) -> str:
    """``G01``, ``M03``: two-digit integer codes as Fanuc posts write them."""
    return f"{letter}{int(code):02d}" if float(code).is_integer() else f"{letter}{code:g}"


def _code_plain(letter: str, code: float) -> str:
    """``G1``, ``M3``: LinuxCNC's and Sinumerik's usual spelling."""
    return f"{letter}{code:g}"


@dataclass(frozen=True)
class Dialect:
    """One control's G-code language, as tables plus hooks."""

    name: str
    letters: frozenset[str]  # word letters the control knows
    g_groups: dict[str, str]
    block_number_letters: tuple[str, ...]
    program_number_letter: str | None  # "O1000" line after "%"; None: no program number
    named_parameters: bool  # LinuxCNC #<name>
    letter_assignments: bool  # "R3=1.5" / "A5=0.0" words (indexed addresses, R parameters)
    feed_distance: Callable[..., np.ndarray]
    format_code: Callable[[str, float], str]
    last_g_wins: bool  # two G codes of one group in a block: Fanuc takes the last, rs274 errs
    initial_motion: int | None  # motion mode at program start (Fanuc G00; rs274: none)
    units_codes: dict[str, str] = field(default_factory=lambda: {"20": "inch", "21": "mm"})
    feed_codes: dict[str, int] = field(default_factory=lambda: {"93": 93, "94": 94, "95": 95})
    machine_frame: frozenset[str] = frozenset({"G53"})  # words: positions in machine coordinates
    tcp_on: frozenset[str] = frozenset()  # words that switch tool-centre-point control on
    tcp_off: frozenset[str] = frozenset()
    tcp_on_block: str = ""  # what the post writes (length offset words follow where "{h}")
    tcp_off_block: str = ""
    length_offset: str = "G43 H{tool:02d}"  # the post's length-offset words ("" none)
    comment_open: str = "("  # "(": (text); ";": ; text
    nested_comments: bool = False
    block_end: str = ""  # " *" for Heidenhain ISO
    keywords: frozenset[str] = frozenset()  # Sinumerik identifiers: TRAORI, SUPA, MCALL, CR=
    # (CYCLEnn(...) calls are known too); any other identifier is an error
    parameter_letter: str = "#"  # MillPlus E parameters: "B=E254"
    inverse_time: bool = True
    home_codes: frozenset[str] = frozenset({"28", "30"})  # reference-point returns
    tool_call_on_t: bool = False  # Heidenhain: the T block is the tool change (no M6)
    cycle_call: str | None = None  # MillPlus G79: the defined cycle at X Y Z
    header: tuple[str, ...] = ("G17 G40 G49 G80 G90", "G54")  # a machine file may override
    footer: tuple[str, ...] = ("M05", "M09", "G91 G28 Z0.0", "G90", "M30")
    tool_change: tuple[str, ...] = ("G91 G28 Z0.0", "G90", "T{tool:02d} M06")
    program_start: Callable[[str, str, int], list[str]] | None = None
    program_end: Callable[[str, str, int], list[str]] | None = None

    def group_of(self, code: str, *, path: str | None = None, line: int | None = None) -> str:
        """Modal group of a normalised G code, or a PathcheckError naming it."""
        group = self.g_groups.get(code)
        if group is None:
            raise PathcheckError(
                f"G{code} is not a G code of the {self.name} dialect as read by pathcheck "
                f"(known: {', '.join('G' + c for c in sorted(self.g_groups, key=float))})",
                path=path,
                line=line,
                code="gcode",
            )
        return group

    def comment(self, text: str) -> str:
        """A comment block on one line: parentheses become brackets, anything but printable
        ASCII becomes '?' (controls take no other characters in comments)."""
        clean = "".join(c if " " <= c <= "~" else "?" for c in " ".join(text.split()))
        clean = clean.replace("(", "[").replace(")", "]")
        return f"; {clean}" if self.comment_open == ";" else f"({clean})"

    def units_code(self, units: str) -> str:
        code = next(c for c, u in self.units_codes.items() if u == units)
        return self.format_code("G", float(code))

    def feed_code(self, mode: int) -> str:
        code = next(c for c, m in self.feed_codes.items() if m == mode)
        return self.format_code("G", float(code))


def _fanuc_start(name: str, units: str, number: int) -> list[str]:
    return ["%", f"O{number:04d} ({name})"]


def _percent_end(name: str, units: str, number: int) -> list[str]:
    return ["%"]


def _plain_start(name: str, units: str, number: int) -> list[str]:
    return ["%", f"({name})"]


def _siemens_start(name: str, units: str, number: int) -> list[str]:
    return [f"; {name}"]


def _no_end(name: str, units: str, number: int) -> list[str]:
    return []


def _heidenhain_start(name: str, units: str, number: int) -> list[str]:
    return [f"%{name} {'G70' if units == 'inch' else 'G71'} *"]


def _heidenhain_end(name: str, units: str, number: int) -> list[str]:
    return [f"N99999999 %{name} {'G70' if units == 'inch' else 'G71'} *"]


_FANUC_G = {
    **_COMMON_G,
    **{c: "cycle" for c in (*CANNED_CYCLES, "80")},  # Fanuc group 09, apart from G00-G03
    "5.1": "path_control",
    "62": "path_control",
    "60": "non_modal",  # single-direction positioning: a positioning move
    "43.4": "length_offset",  # tool centre point control
    "43.5": "length_offset",
    "74": "cycle",
    "54.1": "coord_system",
    "15": "polar",
    "69": "rotation",
}

FANUC = Dialect(
    name="fanuc",
    letters=frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZ"),
    g_groups=_FANUC_G,
    block_number_letters=("N", ":"),  # ":" is Fanuc's alignment sequence number
    program_number_letter="O",
    named_parameters=False,
    letter_assignments=True,
    feed_distance=_feed_distance_combined,
    format_code=_code_padded,
    last_g_wins=True,
    initial_motion=0,
    tcp_on=frozenset({"G43.4", "G43.5"}),
    tcp_off=frozenset({"G49"}),
    tcp_on_block="G43.4 H{tool:02d}",
    tcp_off_block="G49",
    program_start=_fanuc_start,
    program_end=_percent_end,
)

HAAS = Dialect(
    **{
        **FANUC.__dict__,
        "name": "haas",
        "g_groups": {
            **_FANUC_G,
            "187": "path_control",
            "234": "length_offset",  # TCPC
            "254": "coord_system",  # DWO
            "255": "coord_system",
            "268": "rotation",
            "269": "rotation",
            "103": "path_control",
            "141": "cutter_comp",
            "47": "non_modal",
        },
        "tcp_on": frozenset({"G234"}),
        "tcp_off": frozenset({"G49"}),
        "tcp_on_block": "G234 H{tool:02d}",
        "nested_comments": True,  # NX's Haas posts write "(#508= (MILL ))"
    }
)

LINUXCNC = Dialect(
    name="linuxcnc",
    letters=frozenset("ABCDFGHIJKLMNPQRSTUVWXYZ"),  # rs274ngc: no E; O starts o-word control
    g_groups={
        **_COMMON_G,
        "43.1": "length_offset",
        "59.1": "coord_system",
        "59.2": "coord_system",
        "59.3": "coord_system",
        "61.1": "path_control",
        "90.1": "arc_distance",
        "91.1": "arc_distance",
        "92.1": "non_modal",
        "92.2": "non_modal",
        "28.1": "non_modal",
        "30.1": "non_modal",
    },
    block_number_letters=("N",),
    program_number_letter=None,
    named_parameters=True,
    letter_assignments=False,
    feed_distance=_feed_distance_linear_first,
    format_code=_code_plain,
    last_g_wins=False,
    initial_motion=None,
    tcp_on=frozenset({"M428"}),  # the switchkins M codes of LinuxCNC's 5-axis configurations
    tcp_off=frozenset({"M429"}),
    tcp_on_block="M428",
    tcp_off_block="M429",
    length_offset="G43 H{tool}",
    header=("G17 G40 G49 G80 G90 G64 P0.005", "G54"),
    footer=("G94", "M5", "M9", "M2"),
    tool_change=("G53 G0 Z0", "T{tool} M6"),
    program_start=_plain_start,
    program_end=_percent_end,
)

SIEMENS = Dialect(
    name="siemens",
    letters=frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZ"),
    g_groups={
        **_groups(
            motion=_MOTION,
            plane=("17", "18", "19"),
            distance=("90", "91"),
            feed_mode=("93", "94", "95"),
            units=("70", "71", "700", "710"),
            cutter_comp=("40", "41", "42"),
            coord_system=("500", "54", "55", "56", "57", *(str(c) for c in range(505, 600))),
            path_control=("60", "64", "641", "642", "643", "644", "9", "601", "602", "603",
                          "62", "621"),
            non_modal=("4", "53", "153", "74", "75", "63", "25", "26"),
            polar=("110", "111", "112"),
        ),
    },
    block_number_letters=("N", ":"),
    program_number_letter=None,
    named_parameters=False,
    letter_assignments=True,  # R1=5
    feed_distance=_feed_distance_linear_first,
    format_code=_code_plain,
    last_g_wins=True,
    initial_motion=0,
    units_codes={"70": "inch", "71": "mm", "700": "inch", "710": "mm"},
    machine_frame=frozenset({"G53", "G153", "SUPA"}),
    tcp_on=frozenset({"TRAORI"}),
    tcp_off=frozenset({"TRAFOOF"}),
    tcp_on_block="TRAORI",
    tcp_off_block="TRAFOOF",
    length_offset="",  # D words with the tool change
    comment_open=";",
    keywords=frozenset({
        "TRAORI", "TRAFOOF", "SUPA", "MCALL", "TRANS", "ATRANS", "ROT", "AROT", "SCALE",
        "ASCALE", "MIRROR", "AMIRROR", "CR", "AP", "RP", "SOFT", "BRISK", "FFWON", "FFWOF",
        "CFC", "CFTCP", "CFIN", "ORIWKS", "ORIMKS", "ORIAXES", "ORIVECT", "FGROUP", "FGREF",
        "COMPCAD", "COMPCURV", "COMPON", "COMPOF", "UPATH", "SPATH", "MSG", "STOPRE", "SPOS",
        "SPOSA", "DIAMOF", "TOFRAME", "TOROT", "TCARR", "TCOABS", "TCOFR", "PAROT", "PAROTOF",
        "ADIS", "ADISPOS", "OFFN", "CUT3DC", "CUT3DF", "ORIC", "ORID", "ORIEULER",
        "ORIRPY", "ORIVIRT1", "ORIVIRT2", "ORIPLANE", "ORICONCW", "ORICONCCW", "ORICONIO",
        "ORICONTO", "ORICURVE", "ORIPATH", "ORIPATHS", "ORIROTA", "ORIROTR", "ORIROTT",
        "ORIROTC", "FIFOCTRL", "WALIMON", "WALIMOF", "RET",
    }),
    home_codes=frozenset({"74", "75"}),
    header=("G17 G40 G90", "G54"),
    footer=("M5", "M9", "M30"),
    tool_change=("SUPA G0 Z0 D0", "T{tool} M6", "D1"),
    program_start=_siemens_start,
    program_end=_no_end,
)

HEIDENHAIN = Dialect(
    name="heidenhain",
    letters=frozenset("ABCDEFGHIJKLMNPQRSTUVWXYZ"),
    g_groups=_groups(
        motion=_MOTION,
        plane=("17", "18", "19"),
        distance=("90", "91"),
        feed_mode=("94",),
        units=("70", "71"),
        cutter_comp=("40", "41", "42"),
        non_modal=("4", "30", "31", "99", "79", "53", "54"),
    ),
    block_number_letters=("N",),
    program_number_letter=None,
    named_parameters=False,
    letter_assignments=False,
    feed_distance=_feed_distance_linear_first,
    format_code=_code_padded,
    last_g_wins=False,
    initial_motion=None,
    units_codes={"70": "inch", "71": "mm"},
    feed_codes={"94": 94},
    machine_frame=frozenset({"M91"}),
    tcp_on=frozenset({"M128"}),
    tcp_off=frozenset({"M129"}),
    tcp_on_block="M128",
    tcp_off_block="M129",
    length_offset="",  # the tool call carries the length
    comment_open=";",
    block_end=" *",
    inverse_time=False,
    tool_call_on_t=True,
    header=("G17 G40 G90",),
    footer=("M05", "M09", "M30"),
    tool_change=("G00 G90 Z0 M91", "T{tool} G17"),
    program_start=_heidenhain_start,
    program_end=_heidenhain_end,
)

MILLPLUS = Dialect(
    name="millplus",
    letters=frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZ"),
    g_groups=_groups(
        motion=_MOTION,
        cycle_def=("81", "82", "83", "84", "85", "86", "87", "88", "89"),
        plane=("17", "18", "19"),
        distance=("90", "91"),
        feed_mode=("94", "95"),
        units=("70", "71"),
        cutter_comp=("40", "41", "42", "141"),
        coord_system=("54", "55", "56", "57", "58", "59"),
        path_control=("60", "61", "62", "64", "6"),
        datum=("92", "93"),
        tilt=("7",),
        non_modal=("4", "74", "79", "174", "9"),
    ),
    block_number_letters=("N",),
    program_number_letter="O",
    named_parameters=False,
    letter_assignments=True,  # indexed addresses: A5=, L1=, F2=, E254=
    feed_distance=_feed_distance_linear_first,
    format_code=_code_padded,
    last_g_wins=True,
    initial_motion=0,
    units_codes={"70": "inch", "71": "mm"},
    feed_codes={"94": 94, "95": 95},
    machine_frame=frozenset({"G74"}),
    tcp_on=frozenset({"G141"}),
    tcp_off=frozenset({"G40"}),
    tcp_on_block="G141",
    tcp_off_block="G40",
    length_offset="",
    parameter_letter="E",
    inverse_time=False,
    home_codes=frozenset(),
    cycle_call="79",
    header=("G17 G40 G90",),
    footer=("M05", "M09", "M30"),
    tool_change=("G74 Z-.1 L1", "T{tool} M06"),
    program_start=_fanuc_start,
    program_end=_percent_end,
)

DIALECTS: dict[str, Dialect] = {
    d.name: d for d in (FANUC, LINUXCNC, SIEMENS, HEIDENHAIN, HAAS, MILLPLUS)
}


def get_dialect(name: str) -> Dialect:
    """The dialect table by name (fanuc, linuxcnc, siemens, heidenhain, haas, millplus)."""
    try:
        return DIALECTS[name]
    except KeyError:
        raise PathcheckError(
            f"unknown G-code dialect '{name}': expected one of {', '.join(DIALECTS)}", code="gcode"
        ) from None
