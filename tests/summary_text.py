"""The terminal summary of a results document as plain text (`pathcheck JOB`'s stdout, 200
columns, no colour), for tests that read what a person sees."""

from __future__ import annotations

import io

from rich.console import Console

from checker.commands.check import summary_view


def summary_text(doc) -> str:
    """`summary_view(doc)` printed to a string."""
    out = io.StringIO()
    console = Console(file=out, width=200, no_color=True)
    for part in summary_view(doc):
        console.print(part)
    return out.getvalue()
