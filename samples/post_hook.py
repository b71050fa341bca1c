"""Example CAM post-processor hook: send a CL job to the pathcheck service (`pathcheck serve`)
and write the corrected 4-axis G-code it returns.

    python samples/post_hook.py JOB.apt [--part PART] [--machine NAME] [-o JOB.nc]
                                [--on-findings refuse|stop|comment]
                                [--address tcp://127.0.0.1:5555] [--timeout 120]

The CL text is sent inline (the service may run on another machine); the part is sent as a path
on the service's machine, or inline when it is a geomdl .json file. The G-code is written
atomically (a temporary file renamed into place). Exit code, from the verdict the written
program states in its header (what was actually written): 0 clean, 1 findings (written with a
comment, and with `stop` an optional stop M01, before each offending move) or refused (the
default when the program has findings: nothing written, the reason on stderr), 2 error (one
line on stderr).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import tempfile
from pathlib import Path

from checker.client import Client, raise_for_error
from checker.errors import PathcheckError
from checker.postproc.header import CLEAN, read_verdict


def part_field(part: Path) -> dict:
    """`{"geomdl": ...}` for a geomdl JSON file (sent inline), else `{"path": ...}`."""
    if part.suffix.lower() == ".json":
        return {"geomdl": json.loads(part.read_text())}
    return {"path": str(part.resolve())}


def _name(stem: str) -> str:
    """The job's file stem as a service job name (letters, digits, '_' and '-')."""
    return re.sub(r"[^A-Za-z0-9_-]", "_", stem)[:64] or "job"


def write_atomically(path: Path, text: str) -> None:
    """Write `text` to a temporary file beside `path`, then rename it into place."""
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def post(job: Path, part: Path | None, machine: str | None, out: Path, address: str,
         timeout_s: float, on_findings: str = "refuse") -> dict:
    """Check and post `job` through the service; writes `out` unless the service refused the
    program; returns the reply (`results`, and `gcode` or `refused`)."""
    request: dict = {"apt": job.read_text(), "name": _name(job.stem), "post": True,
                     "on_findings": on_findings}
    if part is not None:
        request["part"] = part_field(part)
    if machine:
        request["machine"] = machine
    with Client(address, timeout_s=timeout_s, retries=1) as client:
        reply = raise_for_error(client.call("check", **request))
    if "gcode" in reply:
        write_atomically(out, reply["gcode"])
    return reply


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("job", type=Path)
    parser.add_argument("--part", type=Path, default=None)
    parser.add_argument("--machine", default=None)
    parser.add_argument("-o", "--output", type=Path, default=None)
    parser.add_argument("--on-findings", choices=("refuse", "stop", "comment"), default="refuse")
    parser.add_argument("--address", default="tcp://127.0.0.1:5555")
    parser.add_argument("--timeout", type=float, default=120.0)
    args = parser.parse_args(argv)
    out = args.output or args.job.with_suffix(".nc")
    try:
        reply = post(args.job, args.part, args.machine, out, args.address, args.timeout,
                     args.on_findings)
    except (PathcheckError, OSError, ValueError) as err:
        print(f"post_hook: {err}", file=sys.stderr)
        return 2
    if "refused" in reply:
        print(f"post_hook: {out}: {reply['refused']}; give --on-findings stop or comment to "
              "write it", file=sys.stderr)
        return 1
    verdict = read_verdict(reply["gcode"])
    counts = reply["results"]["summary"]["counts"]
    print(f"{out}: {verdict}: {counts['gouge']} gouge, {counts['interference']} interference, "
          f"{counts['holder']} holder, {counts['crash']} crash")
    return 0 if verdict == CLEAN else 1


if __name__ == "__main__":
    sys.exit(main())
