"""The nightly shop-floor report: one self-contained HTML page over the results store, with a
JSON and a CSV summary beside it. `build_report(store, out, since_s=...)` is the entry point."""

from checker.report.build import ReportFiles, build_report, parse_since

__all__ = ["ReportFiles", "build_report", "parse_since"]
