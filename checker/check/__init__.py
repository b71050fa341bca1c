"""The check of a job as one package, one stage per module (`checker.check.job` runs them):
`options` what the caller asks (`CheckOptions`), `inputs` the config, the part file and the
cutters resolved, `context` the job context every stage shares (`JobContext`), `verified` the
real tool along a version of the motions and its verdicts, `program` the program that is
written, `advice` the allowable cutter and the best B at the cutting poses, `rotary` the rotary
axes' motion, `document` the results document assembled from those, `checked` what is handed
to posting, `posting` the G-code, `without_part` the check against the stock, the fixtures and
the machine alone."""

from checker.check.checked import Checked
from checker.check.job import check_job, check_program, check_toolpath
from checker.check.options import CheckOptions

__all__ = ["CheckOptions", "Checked", "check_job", "check_program", "check_toolpath"]
