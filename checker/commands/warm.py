"""`pathcheck warm`: compile the kernels into the per-user cache once (`make setup` runs it);
without it the first check compiles what it needs as it goes."""

from __future__ import annotations

import click


@click.command()
def warm() -> None:
    """Compile the numeric kernels into the per-user cache (once per install; about half a
    minute on 2 cores). Later runs load them in well under a second."""
    from checker.progress import step
    from checker.warm import warm_kernels

    with step("compile the kernels"):
        folder, seconds = warm_kernels()
    click.echo(f"kernels compiled into {folder} in {seconds:.1f} s")
