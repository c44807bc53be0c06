"""The ``biplan`` command (console script ``biplan = biplan.cli.main:main``).

Subcommands live one per module in :mod:`biplan.cli` and are registered on :data:`app`.
:func:`main` turns every :class:`~biplan.BiplanError` (invalid configuration, failed solve)
into a one-line red message on stderr and exit code 2, without a traceback, and prints every
:class:`~biplan._errors.BiplanWarning` (such as the cost of a large tube) as one yellow line on
stderr when it is issued, before the work it warns of.
"""

from __future__ import annotations

import warnings
from typing import Annotated

import typer
from rich.console import Console
from rich.markup import escape

from biplan._errors import BiplanError, BiplanWarning
from biplan.cli import (
    calibrate,
    compile,
    demo,
    design,
    explore,
    maps,
    path,
    plot,
    reproduce,
    respond,
    sensitivity,
    states,
    validate,
)

__all__ = ["EXIT_BIPLAN_ERROR", "app", "main"]

#: Exit status of a run stopped by a :class:`~biplan.BiplanError` (as for usage errors).
EXIT_BIPLAN_ERROR = 2

app = typer.Typer(
    name="biplan",
    help="BiPlan simulation of multistable Mixed Folded Tubes (units: mm, N, s).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_show_locals=False,
)
app.command("demo")(demo.demo)
app.command("compile")(compile.compile_kernels)
app.add_typer(calibrate.app, name="calibrate")
app.command("validate")(validate.validate)
app.command("plot")(plot.plot)
app.command("explore")(explore.explore)
app.command("respond")(respond.respond)
app.command("sensitivity")(sensitivity.sensitivity)
app.command("design")(design.design)
app.command("states")(states.states)
app.command("path")(path.path)
app.add_typer(maps.app, name="map")
app.command("reproduce")(reproduce.reproduce)


def _show_version(value: bool) -> None:
    if value:
        from biplan import __version__

        typer.echo(f"biplan {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[
        bool,
        typer.Option(
            "--version", callback=_show_version, is_eager=True, help="Print the version and exit."
        ),
    ] = False,
) -> None:
    """BiPlan simulation of multistable Mixed Folded Tubes (units: mm, N, s)."""
    from biplan._compile.numba_cache import use_own_opt_level
    from biplan._compile.setup import limit_blas_threads

    limit_blas_threads()  # this process is biplan's own: BLAS on $BIPLAN_BLAS_THREADS threads
    use_own_opt_level()  # and its one-time compile at LLVM -O1 unless NUMBA_OPT is set


def main(argv: list[str] | None = None) -> None:
    """Run the CLI on ``argv`` (default ``sys.argv[1:]``); always exits via SystemExit.

    Parameters
    ----------
    argv : list of str, optional
        Command-line arguments without the program name.

    Raises
    ------
    SystemExit
        With the command's exit status; :data:`EXIT_BIPLAN_ERROR` after a
        :class:`~biplan.BiplanError`, whose message is printed in red on stderr.
    """
    show = warnings.showwarning

    def show_warning(message, category, filename, lineno, file=None, line=None):  # type: ignore[no-untyped-def]
        if not issubclass(category, BiplanWarning):
            return show(message, category, filename, lineno, file, line)
        Console(stderr=True, highlight=False).print(
            f"[yellow]warning:[/] {escape(str(message))}", soft_wrap=True
        )
        return None

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always", BiplanWarning)
            warnings.showwarning = show_warning
            app(args=argv, prog_name="biplan")
    except BiplanError as err:
        Console(stderr=True, highlight=False).print(
            f"[bold red]error:[/] {escape(str(err))}", soft_wrap=True
        )
        raise SystemExit(EXIT_BIPLAN_ERROR) from None
