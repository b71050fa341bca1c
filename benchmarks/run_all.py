"""Run every benchmark in this folder, one after the other (`make bench`): first the one-run
speed summary (`benchmarks.speed`), then each `bench_*` module."""

from __future__ import annotations

import importlib
import pkgutil
import sys
from pathlib import Path


def main() -> None:
    here = Path(__file__).resolve().parent
    names = ["speed", *sorted(m.name for m in pkgutil.iter_modules([str(here)])
                               if m.name.startswith("bench_"))]
    for name in names:
        print(f"\n=== benchmarks.{name} ===", flush=True)
        sys.argv = [f"benchmarks.{name}"]
        importlib.import_module(f"benchmarks.{name}").main()


if __name__ == "__main__":
    main()
