"""CL readers (APT-CL ISO 4343 style, Siemens NX CLSF) and the APT-CL writer.

`read_cl(path) -> ToolPath`; `read_cl_text(text)`; `is_cl_file(path)` (CL by its content);
`write_apt(toolpath, path_or_stream)`.
"""

from __future__ import annotations

from checker.apt.read import is_cl_file, read_cl, read_cl_text
from checker.apt.write import write_apt

__all__ = ["is_cl_file", "read_cl", "read_cl_text", "write_apt"]
