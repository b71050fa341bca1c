"""`pathcheck warm`: compile the kernels for this CPU into the per-user cache once (`make setup`
runs it); without it a wheel's first check runs on the portable kernels it ships, and a source
checkout's compiles what it needs as it goes."""

from __future__ import annotations

import click


@click.command()
def warm() -> None:
    """Compile the numeric kernels for this CPU into the per-user cache (once per install;
    about a minute and a half on 2 cores). Later runs load them in well under a second."""
    from checker.progress import step
    from checker.warm import warm_kernels

    with step("compile the kernels"):
        folder, seconds, cpu = warm_kernels()
    click.echo(f"kernels compiled into {folder} in {seconds:.1f} s ({cpu:.0f} CPU s)")
