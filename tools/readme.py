"""The commands of README.md and of the reference pages in docs/, run as a newcomer runs them:
from the clone's root, with the virtual environment `make setup` built activated (`.venv/bin`
first on PATH). The pages run in the order of `PAGES` (README.md first: later pages use what
its blocks wrote, as a reader who followed it has), each block's commands in the page's order.

- a ```sh block: every command runs and must exit 0, or the code its comment names
  (`# exit 1`); `export NAME=VALUE` holds for the block's later commands; a command ending in
  `&` runs in the background until the block ends, then gets SIGTERM and must exit 0 (a server
  the block's later commands talk to).
- a ```console block: `$ COMMAND` lines, each followed by the output it printed. The command runs
  the same way and its output must match the recorded one, numbers with a decimal point aside
  (times and depths differ from machine to machine, counts do not).
- ```text blocks are examples for another site (a cluster, a CAM server) and are not run.

    python tools/readme.py            # run every block and compare (what tests/test_readme.py does)
    python tools/readme.py --write    # run every block and record the console outputs in the pages
"""

from __future__ import annotations

import argparse
import os
import re
import shlex
import signal
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
DOCS = REPO / "docs"
# the command pages in the order a reader meets the commands in the README; any other page after
COMMAND_ORDER = ("check", "info", "allowable", "map", "check-gcode", "flank", "serve", "batch",
                 "report", "view", "store", "warm")
_FENCE = re.compile(r"^```(\w*)\s*$")
_EXIT = re.compile(r"#.*\bexit (\d+)\b")
_BACKGROUND = re.compile(r"&(?=\s*(#.*)?$)")  # the `&` that ends a command line
_DECIMAL = re.compile(r"-?\d+\.\d+(e[-+]?\d+)?")
_DRAWING = re.compile(r"[\u2500-\u257f]+")  # rich's table borders, as wide as their columns
NOT_RUN = ("make test",)  # the suite itself: tests/test_readme.py runs inside it
COMMAND_TIMEOUT_S = 300.0
SERVER_START_S = 3.0


@dataclass
class Command:
    """One command of a block: what runs (continuation lines joined, comments dropped), the line
    as written, the exit code it must give, whether it runs in the background, and (console
    blocks) the output recorded after it."""

    text: str
    source: str
    exit_code: int = 0
    background: bool = False
    recorded: list[str] = field(default_factory=list)


@dataclass
class Block:
    """A fenced block of a page: its kind (sh or console), first and last line (1-based, the
    fences excluded), its commands and the page it is on."""

    kind: str
    first: int
    last: int
    commands: list[Command]
    page: Path = README

    @property
    def name(self) -> str:
        return f"{self.page.relative_to(REPO)}:{self.first}"


def pages() -> list[Path]:
    """README.md, then the command pages (docs/commands/, `COMMAND_ORDER` first), then the other
    pages of docs/: every page whose sh and console blocks run."""
    commands = sorted((DOCS / "commands").glob("*.md"),
                      key=lambda p: (COMMAND_ORDER.index(p.stem) if p.stem in COMMAND_ORDER
                                     else len(COMMAND_ORDER), p.name))
    others = sorted(p for p in DOCS.rglob("*.md") if p.parent != DOCS / "commands")
    return [README, *commands, *others]


def _command(text: str) -> Command:
    """A command line as the shell runs it (bash drops the comment itself), without its `&`."""
    code = _EXIT.search(text)
    words = shlex.split(text, comments=True)
    background = bool(words) and words[-1] == "&"
    run = _BACKGROUND.sub(" ", text).strip() if background else text.strip()
    return Command(run, text.strip(), int(code.group(1)) if code else 0, background)


def _joined(lines: list[str]) -> list[tuple[int, str]]:
    """(index, text) of each logical line: a trailing backslash continues it."""
    out: list[tuple[int, str]] = []
    pending: tuple[int, str] | None = None
    for i, line in enumerate(lines):
        if pending is not None:
            pending = (pending[0], pending[1] + " " + line.strip())
        else:
            pending = (i, line)
        if pending[1].rstrip().endswith("\\"):
            pending = (pending[0], pending[1].rstrip()[:-1])
            continue
        out.append(pending)
        pending = None
    if pending is not None:
        out.append(pending)
    return out


def blocks(text: str, page: Path = README) -> list[Block]:
    """The sh and console blocks of a page's text."""
    lines = text.splitlines()
    found: list[Block] = []
    i = 0
    while i < len(lines):
        m = _FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        j = i + 1
        while j < len(lines) and not lines[j].startswith("```"):
            j += 1
        kind, body = m.group(1), lines[i + 1:j]
        if kind == "sh":
            cmds = [_command(t) for _, t in _joined(body)
                    if t.strip() and not t.lstrip().startswith("#")
                    and not t.lstrip().startswith(NOT_RUN)]
            found.append(Block(kind, i + 2, j, cmds, page))
        elif kind == "console":
            cmds = []
            for _, t in _joined(body):
                if t.startswith("$ "):
                    cmds.append(_command(t[2:]))
                elif cmds:
                    cmds[-1].recorded.append(t)
            found.append(Block(kind, i + 2, j, cmds, page))
        i = j + 1
    return found


def environment(store: Path) -> dict[str, str]:
    """The shell of a newcomer who ran `source .venv/bin/activate`, with its own results store."""
    venv_bin = Path(sys.executable).parent
    env = {**os.environ, "PATH": f"{venv_bin}{os.pathsep}{os.environ.get('PATH', '')}",
           "VIRTUAL_ENV": str(venv_bin.parent), "PATHCHECK_STORE": str(store),
           "COLUMNS": "200"}
    env.pop("PYTHONHOME", None)
    return env


def normalised(lines: list[str]) -> list[str]:
    """Output lines as compared: decimals, table borders and runs of blanks made uniform."""
    out = []
    for line in lines:
        line = _DRAWING.sub("-", _DECIMAL.sub("#", line))
        line = " ".join(line.split())
        if line:
            out.append(line)
    return out


@dataclass
class Outcome:
    """What running a command gave: exit code and its output lines (stdout then stderr)."""

    command: Command
    code: int
    output: list[str]

    def problem(self, kind: str) -> str | None:
        if self.code != self.command.exit_code:
            tail = "\n".join(self.output[-15:])
            return (f"`{self.command.text}` exited {self.code}, the page says "
                    f"{self.command.exit_code}:\n{tail}")
        if "Traceback (most recent call last)" in "\n".join(self.output):
            return f"`{self.command.text}` printed a traceback"
        if kind == "console" and normalised(self.output) != normalised(self.command.recorded):
            return (f"`{self.command.text}` printed something else than the page records; "
                    "regenerate with `python tools/readme.py --write` and read the diff")
        return None


def _lines(text: str) -> list[str]:
    return [line.rstrip() for line in text.splitlines()]


def run_block(block: Block, env: dict[str, str]) -> list[Outcome]:
    """Run a block's commands in order from the clone's root; background servers are stopped
    (SIGTERM) when the block ends and must exit 0."""
    outcomes: list[Outcome] = []
    servers: list[tuple[Command, subprocess.Popen]] = []
    env = dict(env)
    try:
        for cmd in block.commands:
            words = shlex.split(cmd.text, comments=True)
            if words[0] == "export":  # the block's later commands see it, as in a shell
                env.update(w.split("=", 1) for w in words[1:])
                continue
            if cmd.background:
                proc = subprocess.Popen(["bash", "-c", cmd.text], cwd=REPO, env=env,
                                        stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                        stderr=subprocess.STDOUT, text=True,
                                        start_new_session=True)
                servers.append((cmd, proc))
                try:
                    proc.wait(timeout=SERVER_START_S)
                except subprocess.TimeoutExpired:
                    continue  # started and serving
                outcomes.append(Outcome(cmd, proc.returncode, _lines(proc.stdout.read())))
                continue
            res = subprocess.run(["bash", "-c", cmd.text], cwd=REPO, env=env,
                                 stdin=subprocess.DEVNULL, capture_output=True, text=True,
                                 timeout=COMMAND_TIMEOUT_S, check=False)
            outcomes.append(Outcome(cmd, res.returncode, _lines(res.stdout + res.stderr)))
    finally:
        for cmd, proc in servers:
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)  # as Ctrl-C or a service manager stops it
                try:
                    out, _ = proc.communicate(timeout=30)
                except subprocess.TimeoutExpired:
                    os.killpg(proc.pid, signal.SIGKILL)
                    out, _ = proc.communicate()
                outcomes.append(Outcome(cmd, proc.returncode, _lines(out)))
    return outcomes


def write_outputs(text: str, results: dict[int, list[Outcome]]) -> str:
    """A page's text with each console block's outputs (by first line) replaced by the ones
    just printed."""
    lines = text.splitlines()
    for block in sorted(blocks(text), key=lambda b: -b.first):
        if block.kind != "console" or block.first not in results:
            continue
        body = []
        for outcome in results[block.first]:
            body.append(f"$ {outcome.command.source}")
            body.extend(outcome.output)
        lines[block.first - 1:block.last] = body
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true",
                        help="record the console outputs of this run in the pages")
    args = parser.parse_args(argv)
    failures = 0
    with tempfile.TemporaryDirectory(prefix="pathcheck-readme-") as tmp:
        env = environment(Path(tmp) / "results.sqlite")
        for page in pages():
            text = page.read_text()
            results: dict[int, list[Outcome]] = {}
            for block in blocks(text, page):
                results[block.first] = outcomes = run_block(block, env)
                for outcome in outcomes:
                    problem = outcome.problem("sh" if args.write else block.kind)
                    print(f"{block.name}: {problem}" if problem
                          else f"{block.name}: ok  {outcome.command.text}")
                    failures += problem is not None
            if args.write and results:
                page.write_text(write_outputs(text, results))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
