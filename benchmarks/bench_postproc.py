"""Post-processor speed. Run: `python -m benchmarks.bench_postproc`.

- posting a synthetic 4-axis path (100,000 moves, B crossing 360 several times) for the Fanuc
  (G94 rotary rule, rollover B) and LinuxCNC (G93, limited B) machines;
- posting a synthetic 5-axis path (100,000 moves, passing the pole) for the A/C trunnion
  (inverse kinematics, solution choice) without and with TCP, and the head-head machine;
- reading the program back and into the part frame;
- reading the real 7-blade impeller program (294 KB, G93 A/C, TCP) into the part frame with its
  machine when ../shared is present.
Times are CPU seconds of this process (single-threaded code), steady on a loaded machine.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from checker.postproc.machine import load_machine
from checker.postproc.post import PostMoves, post_program
from checker.postproc.reader import read_gcode, read_gcode_text
from checker.postproc.replay import part_motions

REALDATA = Path(__file__).resolve().parents[1].parent / "shared" / "realdata"
N = 100_000


def synthetic(n: int = N) -> PostMoves:
    """A zig-zag on a radius-60 cylinder about Y, B from -30 to 1,050 degrees, one tool."""
    s = np.linspace(0.0, 1.0, n)
    b = -30.0 + 1080.0 * s
    th = np.radians(b)
    tip = np.c_[-60.0 * np.sin(th), 30.0 * np.sin(40 * s), 60.0 * np.cos(th)]
    rapid = np.zeros(n, bool)
    rapid[0] = True
    return PostMoves.build(tip, b, rapid=rapid, feed=1500.0, spindle=9000.0, coolant=8, tool=1)


def synthetic5(n: int = N) -> PostMoves:
    """Tool axes tilting 5..55 deg while the azimuth turns 3,600 deg, a spiral of tips."""
    s = np.linspace(0.0, 1.0, n)
    tilt = np.radians(5 + 50 * np.abs(np.sin(30 * np.pi * s)))
    az = np.radians(3600 * s)
    axis = np.c_[np.sin(tilt) * np.cos(az), np.sin(tilt) * np.sin(az), np.cos(tilt)]
    tip = np.c_[40 * np.cos(az) * s, 40 * np.sin(az) * s, 10 * np.sin(50 * s)]
    rapid = np.zeros(n, bool)
    rapid[0] = True
    return PostMoves.build(tip, axis=axis, rapid=rapid, feed=1500.0, spindle=9000.0, tool=1)


def timed(fn):
    """Result and CPU seconds of ``fn()`` (CPU time: steady on a shared, loaded machine)."""
    t = time.process_time()
    out = fn()
    return out, time.process_time() - t


def main() -> None:
    moves = synthetic()
    print(f"{'step':<46}{'cpu s':>9}{'per cpu s':>14}")

    def row(label: str, seconds: float, count: int, unit: str) -> None:
        print(f"{label:<46}{seconds:>9.2f}{count / seconds:>12,.0f} {unit}")

    five = synthetic5()
    cases = [("fanuc-hmc", moves, False), ("linuxcnc-hmc", moves, False),
             ("fanuc-trunnion-ac", five, False), ("fanuc-trunnion-ac", five, True),
             ("linuxcnc-head-head-ac", five, False)]
    for name, moves, tcp in cases:
        machine = load_machine(name).with_options(tcp={"enabled": tcp})
        name = f"{name}{' tcp' if tcp else ''}"
        text, t_post = timed(lambda m=machine, mv=moves: post_program(mv, m))
        read, t_read = timed(lambda m=machine, s=text: read_gcode_text(s, m.dialect))
        part, t_part = timed(lambda m=machine, r=read: part_motions(r, m))
        blocks = len(text.splitlines())
        row(f"post {N:,} moves, {name}", t_post, N, "mv")
        row(f"read back {blocks:,} blocks", t_read, blocks, "bl")
        row(f"to part frame {len(part):,} points", t_part, len(part), "pt")
    impeller = REALDATA / "linuxcnc-5axis-gcode" / "impeller-7bl-xyzac.ngc"
    if impeller.is_file():
        machine = load_machine("linuxcnc-xyzac-trt")
        moves_read, t = timed(lambda: read_gcode(impeller, "linuxcnc"))
        print(f"{'read impeller-7bl-xyzac.ngc (' + f'{len(moves_read):,} moves)':<46}{t:>9.2f}")
        _, t = timed(lambda: part_motions(moves_read, machine))
        print(f"{'  to part frame (linuxcnc-xyzac-trt)':<46}{t:>9.2f}")
    else:
        print("../shared/realdata absent: impeller read skipped")


if __name__ == "__main__":
    main()
