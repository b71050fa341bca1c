"""The check of a job as one package (see `checker.check.job` for the stages)."""

from checker.check.options import CheckOptions

__all__ = ["CheckOptions"]
