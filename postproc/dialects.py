"""G-code dialects as data (after LinuxCNC's rs274 interpreter): which G codes exist and their
modal groups, how codes and block numbers are written, comment rules, parameters, and two hooks:
the control's G94 feed-distance rule and the code formatter.

Modal groups used by the reader (values are the normalised code, e.g. ``"0"``, ``"84.2"``):
motion, plane, distance, feed_mode, units, cutter_comp, length_offset, return_mode, coord_system,
path_control, arc_distance, non_modal.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from checker.errors import PathcheckError

#: G codes that are canned cycles: a hole at each X/Y of the block, down to Z from the R plane
CANNED_CYCLES = frozenset(
    {"73", "76", "81", "82", "83", "84", "84.2", "85", "86", "87", "88", "89"}
)

_COMMON_G: dict[str, str] = {
    **{
        c: "motion"
        for c in (
            "0",
            "1",
            "2",
            "3",
            "80",
            "73",
            "76",
            "81",
            "82",
            "83",
            "84",
            "85",
            "86",
            "87",
            "88",
            "89",
        )
    },
    **{c: "plane" for c in ("17", "18", "19")},
    **{c: "distance" for c in ("90", "91")},
    **{c: "feed_mode" for c in ("93", "94", "95")},
    **{c: "units" for c in ("20", "21")},
    **{c: "cutter_comp" for c in ("40", "41", "42")},
    **{c: "length_offset" for c in ("43", "44", "49")},
    **{c: "return_mode" for c in ("98", "99")},
    **{c: "coord_system" for c in ("54", "55", "56", "57", "58", "59")},
    **{c: "path_control" for c in ("61", "64")},
    **{c: "non_modal" for c in ("4", "10", "28", "30", "53", "92")},
}


def _feed_distance_combined(dxyz: np.ndarray, db: np.ndarray) -> np.ndarray:
    """Fanuc-style G94 rule: F applies to sqrt(dX^2 + dY^2 + dZ^2 + dB^2), degrees counted as
    length units. ``dxyz (N, 3)`` in program units, ``db (N,)`` degrees."""
    return np.sqrt((dxyz**2).sum(axis=1) + db**2)


def _feed_distance_linear_first(dxyz: np.ndarray, db: np.ndarray) -> np.ndarray:
    """LinuxCNC G94 rule: F applies to the XYZ distance when it is non-zero, otherwise to |dB|
    in degrees (per minute)."""
    lin = np.linalg.norm(dxyz, axis=1)
    return np.where(lin > 0.0, lin, np.abs(db))


def _code_padded(letter: str, code: float) -> str:
    """``G01``, ``M03``: two-digit integer codes as Fanuc posts write them."""
    return f"{letter}{int(code):02d}" if float(code).is_integer() else f"{letter}{code:g}"


def _code_plain(letter: str, code: float) -> str:
    """``G1``, ``M3``: LinuxCNC's usual spelling."""
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
    letter_assignments: (
        bool  # "R3=1.5" words (MAPPS/Siemens style R parameters in Fanuc-family posts)
    )
    feed_distance: Callable[[np.ndarray, np.ndarray], np.ndarray]
    format_code: Callable[[str, float], str]
    g94_rule: str  # one line for the README and program headers
    last_g_wins: bool  # two G codes of one group in a block: Fanuc takes the last, rs274 errs
    initial_motion: int | None  # motion mode at program start (Fanuc G00; rs274: none)

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


FANUC = Dialect(
    name="fanuc",
    letters=frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZ"),
    g_groups={
        **_COMMON_G,
        **{c: "cycle" for c in (*CANNED_CYCLES, "80")},  # Fanuc group 09, apart from G00-G03
        "5.1": "path_control",
        "62": "path_control",
        "60": "non_modal",  # single-direction positioning: a positioning move
        "43.4": "length_offset",  # tool centre point control
        "74": "cycle",
        "54.1": "coord_system",
        "15": "polar",
        "69": "rotation",
    },
    block_number_letters=("N", ":"),  # ":" is Fanuc's alignment sequence number
    program_number_letter="O",
    named_parameters=False,
    letter_assignments=True,
    feed_distance=_feed_distance_combined,
    format_code=_code_padded,
    g94_rule="F = feed * sqrt(dX^2+dY^2+dZ^2+dB^2) / tip path length (degrees as mm)",
    last_g_wins=True,
    initial_motion=0,
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
    g94_rule="F = feed * |dXYZ| / tip path length (pure B moves: F = |dB| / block time, deg/min)",
    last_g_wins=False,
    initial_motion=None,
)

DIALECTS: dict[str, Dialect] = {d.name: d for d in (FANUC, LINUXCNC)}


def get_dialect(name: str) -> Dialect:
    """The dialect table by name (``fanuc`` or ``linuxcnc``)."""
    try:
        return DIALECTS[name]
    except KeyError:
        raise PathcheckError(
            f"unknown G-code dialect '{name}': expected one of {', '.join(DIALECTS)}", code="gcode"
        ) from None
