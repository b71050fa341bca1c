"""What the commands print on the terminal: the progress of `checker.progress` steps on stderr
(a transient rich bar only when stderr is a terminal and not `--quiet`; `--verbose`: one line
per step with its time, terminal or not), a text console that does not wrap lines when
piped, and the notes a command shows only if it succeeds."""

from __future__ import annotations

import sys

# columns of stdout when it is not a terminal: no line is wrapped, tables keep their width
PIPE_WIDTH = 10_000
_notes: list[str] = []  # the running command's notes, shown when it ends (`show_notes`)


def note(text: str) -> None:
    """A note on stderr (`pathcheck: note: TEXT`) shown when the command ends with exit 0 or 1;
    an input error (exit 2) is its one line alone."""
    _notes.append(text)


def show_notes(show: bool) -> None:
    """The running command's notes on stderr (`show`) or dropped; none are kept after."""
    if show:
        for text in _notes:
            print(f"pathcheck: note: {text}", file=sys.stderr)
    _notes.clear()


def text_console(*, stderr: bool = False):
    """A rich Console for the human text on stdout (stderr with `stderr`): the terminal's
    width on a terminal; piped, lines never wrapped (rich would cut them at 80 columns)."""
    from rich.console import Console

    console = Console(stderr=stderr, soft_wrap=True)
    if console.is_terminal:
        return console
    return Console(stderr=stderr, soft_wrap=True, width=PIPE_WIDTH, no_color=True)


def fixed(value: float, decimals: int) -> str:
    """`value` with `decimals` places for a table; a value that rounds to zero prints unsigned
    (`0.000`, never `-0.000`: a 3-axis operation's B is -0.0 when computed from its axis)."""
    text = f"{value:.{decimals}f}"
    return text[1:] if text.startswith("-") and float(text) == 0.0 else text


class TerminalView:
    """A `checker.progress.View` on stderr; `quiet` and `verbose` are set by the options before
    the first step. Nested steps are rows of one bar display, gone when the outer step ends."""

    def __init__(self) -> None:
        self.quiet = False
        self.verbose = False
        self._console = None
        self._progress = None
        self._tasks: list[object] = []

    def _stderr(self):
        if self._console is None:
            from rich.console import Console

            self._console = Console(stderr=True)
        return self._console

    def start(self, name: str, total: float | None) -> None:
        if self.quiet or not self._stderr().is_terminal:
            self._tasks.append(None)
            return
        if self._progress is None:
            from rich.progress import (
                BarColumn,
                Progress,
                SpinnerColumn,
                TaskProgressColumn,
                TextColumn,
                TimeElapsedColumn,
            )

            self._progress = Progress(SpinnerColumn(), TextColumn("{task.description}"),
                                      BarColumn(), TaskProgressColumn(), TimeElapsedColumn(),
                                      console=self._stderr(), transient=True)
            self._progress.start()
        self._tasks.append(self._progress.add_task(name, total=total))

    def advance(self, amount: float) -> None:
        """Move the innermost bar and draw it at once (advances come between compiled batches,
        a few dozen per step: a short step shows its progress too, not only rich's 10 Hz
        frames)."""
        if self._tasks and self._tasks[-1] is not None:
            self._progress.advance(self._tasks[-1], amount)
            self._progress.refresh()

    def end(self, name: str, seconds: float) -> None:
        task = self._tasks.pop() if self._tasks else None
        if task is not None:
            self._progress.remove_task(task)
        if self.verbose and not self.quiet:
            line = f"pathcheck: {name}: {seconds:.2f} s"
            if self._progress is not None:
                self._progress.console.print(line, markup=False, highlight=False,
                                             soft_wrap=True)
            else:
                print(line, file=sys.stderr, flush=True)
        if not self._tasks:
            self.close()

    def close(self) -> None:
        """Take the bar off the terminal (the next step starts a new one)."""
        if self._progress is not None:
            self._progress.stop()
            self._progress = None
