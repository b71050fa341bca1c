"""The header block of a posted program: what an operator reads before pressing cycle start
(source CL file, date, pathcheck version, machine, every tool, and the program's own verdict),
written as comments in the dialect's syntax so it never changes motion; and the verdict read
back from a program (what `samples/post_hook.py` exits with)."""

from __future__ import annotations

import re
from collections.abc import Sequence
from datetime import datetime

from checker import __version__

NOT_CHECKED = "NOT CHECKED"
CLEAN = "CLEAN"
FINDINGS = "FINDINGS"
_VERDICT = re.compile(r"^\s*[(;]\s*PATHCHECK VERDICT ([A-Z ]+?)(?:[:\])]|$)", re.M)


def verdict_text(counts: dict[str, int] | None) -> str:
    """The verdict line's text: NOT CHECKED (``counts`` None), CLEAN (all counts 0), or
    FINDINGS with the non-zero counts of the program as written, e.g. ``FINDINGS: gouge 2,
    no feasible B 18``."""
    if counts is None:
        return NOT_CHECKED
    found = [f"{name} {n}" for name, n in counts.items() if n]
    return f"{FINDINGS}: {', '.join(found)}" if found else CLEAN


def header_lines(*, source: str | None, machine: str, tools: Sequence[str], verdict: str,
                 posted_at: datetime | None = None) -> list[str]:
    """The header's lines (plain text; the writer makes them comments): ``posted_at`` in ISO
    8601 local time with its offset (default: now)."""
    when = (posted_at or datetime.now()).astimezone().isoformat(timespec="seconds")
    return [
        f"PATHCHECK {__version__} POSTED {when}",
        f"SOURCE {source or '-'}",
        f"MACHINE {machine}",
        *(f"TOOL {t}" for t in tools),
        f"PATHCHECK VERDICT {verdict}",
    ]


def read_verdict(text: str) -> str | None:
    """The verdict a posted program states in its header (CLEAN, FINDINGS or NOT CHECKED), or
    None when it has no pathcheck header."""
    found = _VERDICT.search(text)
    return None if found is None else found.group(1).strip()
