"""Service latency over real sockets on 127.0.0.1 (broker + 2 worker processes):

- `ping`: p50/p99 round trip from one REQ client, and from 8 concurrent clients;
- a small 3-axis `allowable` (10 CC points on the mould sample, bull-nose CUTTER/12,3): the first
  call (load + sample + search, cold worker) against the following calls (part cache), p50/p99.

    .venv/bin/python -m benchmarks.bench_service [--pings 2000] [--allowables 50]
"""

from __future__ import annotations

import argparse
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from checker.client import Client, raise_for_error
from checker.config import default_config
from checker.service.broker import Broker

MOULD = Path(__file__).resolve().parents[1] / "samples" / "mould" / "mould.json"
CUTTER = "CUTTER/12,3"


def _ms(samples: list[float]) -> tuple[float, float]:
    arr = np.asarray(samples) * 1000
    return float(np.percentile(arr, 50)), float(np.percentile(arr, 99))


def _timed(client: Client, n: int, op: str, **fields) -> list[float]:
    out = []
    for _ in range(n):
        t0 = time.perf_counter()
        raise_for_error(client.call(op, **fields))
        out.append(time.perf_counter() - t0)
    return out


def mould_cc(n: int, seed: int = 1) -> list[list[float]]:
    """n CC rows [x, y, z, nx, ny, nz] at random (u, v) inside the mould's first surface."""
    from checker.geometry import load_part
    from checker.geometry.evaluate import evaluate

    surface = load_part(MOULD).surfaces[0]
    (u0, u1), (v0, v1) = surface.domain
    rng = np.random.default_rng(seed)
    u = u0 + (u1 - u0) * rng.uniform(0.2, 0.8, n)
    v = v0 + (v1 - v0) * rng.uniform(0.2, 0.8, n)
    ev = evaluate(surface, u, v)
    return np.hstack([ev.points, ev.normals]).tolist()


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--pings", type=int, default=2000)
    parser.add_argument("--allowables", type=int, default=50)
    args = parser.parse_args()
    broker = Broker(default_config(), bind="tcp://127.0.0.1:*", workers=2)
    thread = threading.Thread(target=broker.run, daemon=True)
    thread.start()
    address = broker.wait_started(60, ready_workers=2)
    rows: list[tuple[str, int, str, str]] = []
    try:
        with Client(address) as client:
            _timed(client, 50, "ping")  # warm up
            p50, p99 = _ms(_timed(client, args.pings, "ping"))
            rows.append(("ping, 1 client", args.pings, f"{p50:.3f}", f"{p99:.3f}"))

        def one_client(_: int) -> list[float]:
            with Client(address) as c:
                return _timed(c, args.pings // 8, "ping")

        t0 = time.perf_counter()
        with ThreadPoolExecutor(8) as pool:
            lat = [x for part in pool.map(one_client, range(8)) for x in part]
        rate = len(lat) / (time.perf_counter() - t0)
        p50, p99 = _ms(lat)
        rows.append((f"ping, 8 clients ({rate:.0f} req/s)", len(lat), f"{p50:.3f}", f"{p99:.3f}"))

        fields = {"part": {"path": str(MOULD)}, "cc": mould_cc(10), "cutter": CUTTER}
        with Client(address, timeout_s=300) as client:
            first = _timed(client, 1, "allowable", **fields)[0]
            warm = _timed(client, args.allowables, "allowable", **fields)
        p50, p99 = _ms(warm)
        rows.append(("allowable 10 pts, first call", 1, f"{first * 1000:.1f}", "-"))
        rows.append(("allowable 10 pts, cached part", len(warm), f"{p50:.2f}", f"{p99:.2f}"))
        speedup = first / warm[0]
    finally:
        broker.stop()
        thread.join(30)
    print(f"{'case':<36} {'n':>6} {'p50 ms':>10} {'p99 ms':>10}")
    for name, n, a, b in rows:
        print(f"{name:<36} {n:>6} {a:>10} {b:>10}")
    print(f"second allowable call vs first: {speedup:.1f}x faster (target >= 5x)")


if __name__ == "__main__":
    main()
