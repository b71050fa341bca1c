"""The check of a job as one package, one stage per module (`checker.check.job` runs them):
`options` what the caller asks (`CheckOptions`), `inputs` the config, the part file and the
cutters resolved, `context` the job context every stage shares (`JobContext`), `verified` the
real tool along a version of the motions and its verdicts, `program` the program that is
written, `advice` the allowable cutter and the best B at the cutting poses, `rotary` the rotary
axes' motion, `document` the results document assembled from those, `checked` what is handed
to posting, `posting` the G-code, `without_part` the check against the stock, the fixtures and
the machine alone.

`check_job`, `check_toolpath`, `check_program` and `Checked` are loaded when first asked for,
so that a caller of one light stage (`inputs`, `options`) does not load the engine."""

from __future__ import annotations

from typing import TYPE_CHECKING

from checker.check.options import CheckOptions

if TYPE_CHECKING:
    from checker.check.checked import Checked
    from checker.check.job import check_job, check_program, check_toolpath

__all__ = ["CheckOptions", "Checked", "check_job", "check_program", "check_toolpath"]


def __getattr__(name: str):
    if name == "Checked":
        from checker.check.checked import Checked

        return Checked
    if name in ("check_job", "check_program", "check_toolpath"):
        from checker.check import job

        return getattr(job, name)
    raise AttributeError(f"module 'checker.check' has no attribute '{name}'")
