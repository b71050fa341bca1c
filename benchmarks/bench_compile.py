"""The cold compile of the demo job's kernels: the demo job (`make demo`'s compressor sample,
checked and posted) in one fresh process with an empty kernel cache, its CPU time and numba's
compile events: CPU seconds compiled per file (each kernel's own time, not its callees'), the
most expensive kernels, and the kernels compiled for more than one signature (each signature
past the first is a compile a fixed argument type would save: a literal int, a uint64 parallel
index, a read-only array).
Run: `python -m benchmarks.bench_compile [--top 15]` (`--child FOLDER` is its own process)."""

from __future__ import annotations

import argparse
import collections
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
JOB = ROOT / "samples" / "compressor" / "compressor_small_d12.apt"


def _child(folder: Path) -> None:
    """The demo job compiled into the empty numba cache `folder`: prints one JSON object, the
    process's CPU seconds and every compile as (kernel, file, signature, own CPU seconds)."""
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    from checker.kernel_cache import use_kernel_cache

    use_kernel_cache()
    from numba.core import event

    from checker.check import check_job
    from checker.check.options import CheckOptions

    stack: list[list] = []
    compiles: list[tuple[str, str, str, float]] = []

    class _Compiles(event.Listener):
        def on_start(self, ev) -> None:
            stack.append([ev.data["dispatcher"].py_func, str(ev.data["args"]),
                          time.process_time(), 0.0])

        def on_end(self, ev) -> None:
            func, args, t0, inner = stack.pop()
            took = time.process_time() - t0
            if stack:
                stack[-1][3] += took
            compiles.append((func.__qualname__, func.__module__, args, took - inner))

    event.register("numba:compile", _Compiles())
    cpu = time.process_time()
    with tempfile.TemporaryDirectory() as tmp:
        check_job(JOB, options=CheckOptions(output=Path(tmp) / "demo.nc", on_findings="stop"))
    print(json.dumps({"cpu": time.process_time() - cpu, "compiles": compiles}))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--top", type=int, default=15)
    ap.add_argument("--child", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        _child(args.child)
        return
    with tempfile.TemporaryDirectory(prefix="pathcheck-compile-") as folder:
        env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CPU_NAME",
                                                                 "PATHCHECK_KERNELS")}
        t = time.perf_counter()
        out = subprocess.run([sys.executable, "-m", "benchmarks.bench_compile", "--child",
                              folder], cwd=ROOT, env=env, capture_output=True, text=True,
                             check=True)
        wall = time.perf_counter() - t
    res = json.loads(out.stdout.strip().splitlines()[-1])
    compiles = res["compiles"]
    total = sum(c[3] for c in compiles)
    by_file: collections.Counter[str] = collections.Counter()
    by_kernel: collections.defaultdict[str, list[float]] = collections.defaultdict(list)
    for name, module, _, own in compiles:
        by_file[module] += own
        by_kernel[f"{module}.{name}"].append(own)
    print(f"demo job, empty cache: {res['cpu']:.1f} CPU s in the process ({wall:.1f} s wall), "
          f"{total:.1f} CPU s compiling {len(compiles)} signatures")
    print("CPU s compiled per file:")
    for module, own in by_file.most_common(args.top):
        print(f"  {own:6.1f}  {module}")
    print("most expensive kernels (all their signatures):")
    for kernel, owns in sorted(by_kernel.items(), key=lambda kv: -sum(kv[1]))[:args.top]:
        print(f"  {sum(owns):6.1f}  {kernel} ({len(owns)})")
    repeated = {k: v for k, v in by_kernel.items() if len(v) > 1 and k.startswith("checker.")}
    extra = sum(sum(v) - max(v) for v in repeated.values())
    print(f"pathcheck's kernels compiled for more than one signature: {len(repeated)}, "
          f"{extra:.1f} CPU s past each one's first")
    for kernel, owns in sorted(repeated.items(), key=lambda kv: -sum(kv[1]))[:args.top]:
        print(f"  {sum(owns):6.1f}  {kernel} ({len(owns)})")


if __name__ == "__main__":
    main()
