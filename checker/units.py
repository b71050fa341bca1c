"""Length units: everything inside is mm; inches only at the boundaries (CL files, G-code, tool
libraries). A leaf module: it imports nothing of the project."""

from __future__ import annotations

MM_PER_INCH = 25.4


def mm_per_unit(units: str) -> float:
    """Millimetres in one length unit of `units`: 25.4 for "inch", 1 for "mm"."""
    return MM_PER_INCH if units == "inch" else 1.0
