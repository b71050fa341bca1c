"""The engine on the portable kernels a wheel ships (compiled for numba's generic x86-64 CPU)
against the kernels `pathcheck warm` tunes to this CPU: the mould sample's engine rate per
cutter (every CC point of its job, the best of 3 calls), in fresh processes alternated
host / portable so that both see the same load. Each kind compiles into its own folder of
`--cache` on its first round (not timed: the rates are taken after a warm-up call).
Run: `python -m benchmarks.bench_portable [--rounds 2] [--cache FOLDER]`."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CUTTERS = ("CUTTER/10,5", "CUTTER/10,2", "CUTTER/10", "CUTTER/9.1633,5,0,5,0,5,0")


def rates() -> dict[str, float]:
    """CC points/s of the engine on the mould per cutter, in this process's kernels."""
    from benchmarks.speed import _mould_contacts
    from benchmarks.timing import best_of
    from checker.cutter import parse_cutter
    from checker.engine import allowable

    part, samples, con = _mould_contacts()
    own = {"cc_surface": con.surface, "cc_uv": con.uv}
    out = {}
    for text in CUTTERS:
        c = parse_cutter(text)
        allowable(samples, part, c, con.cc, con.normal, **own)  # the kernels loaded or compiled
        wall = best_of(lambda c=c: allowable(samples, part, c, con.cc, con.normal, **own)).wall
        out[text] = len(con.cc) / wall
    return out


def _child(kind: str, cache: Path) -> dict[str, float]:
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CPU_NAME", "PATHCHECK_KERNELS")}
    env.update(NUMBA_CACHE_DIR=str(cache / kind), PATHCHECK_KERNELS=kind,
               PYTHONPATH=os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]))
    done = subprocess.run([sys.executable, "-c", "import json; from benchmarks.bench_portable "
                           "import rates; print(json.dumps(rates()))"],
                          cwd=ROOT, env=env, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--cache", type=Path,
                    default=Path(tempfile.gettempdir()) / "pathcheck-bench-portable")
    args = ap.parse_args()
    runs: dict[str, list[dict[str, float]]] = {"host": [], "portable": []}
    for _ in range(args.rounds):
        for kind in runs:
            runs[kind].append(_child(kind, args.cache))
    print(f"{'cutter':28} {'host CC/s':>10} {'portable CC/s':>14} {'portable/host':>14}")
    for text in CUTTERS:
        host = max(r[text] for r in runs["host"])
        portable = max(r[text] for r in runs["portable"])
        print(f"{text:28} {host:10.0f} {portable:14.0f} {portable / host:14.2f}")


if __name__ == "__main__":
    main()
