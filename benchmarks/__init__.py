"""Speed measurements, one script per area: `python -m benchmarks.bench_NAME` prints a table."""
