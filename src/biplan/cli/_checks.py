"""Checks of a command-line request, run by every subcommand before it solves or compiles
anything.

Every refusal is a :class:`~biplan.ConfigError` that names what the user typed (the option,
such as ``--out`` or ``--max-step``), its value and the valid range; :func:`biplan.cli.main.main`
prints it as one red line and exits with status 2, without a traceback.

* :func:`output_directory` / :func:`output_file` — the output location: not a system
  directory, not an existing file where a directory is expected (or the reverse), not inside
  a file, writable; a file's suffix among the supported ones (:func:`figure_suffixes`).
* :func:`options_named` — re-raises a library :class:`~biplan.ConfigError` (whose parameter is
  an internal name such as ``ramp.rate``) under the option the value came from.
* :func:`given` and :func:`refuse_unused` — an option typed on the command line that the
  chosen mode would ignore is refused, never dropped silently.
"""

from __future__ import annotations

import os
from collections.abc import Collection, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path

import typer

from biplan._errors import ConfigError

__all__ = [
    "SYSTEM_DIRECTORIES",
    "figure_suffixes",
    "given",
    "options_named",
    "output_directory",
    "output_file",
    "refuse_unused",
]

#: System directories: never an output location, nor anything below them; neither is ``/``
#: itself, nor may a file be written directly into it.
SYSTEM_DIRECTORIES = (
    "/bin",
    "/boot",
    "/dev",
    "/etc",
    "/lib",
    "/lib32",
    "/lib64",
    "/proc",
    "/sbin",
    "/sys",
    "/usr",
)


def _system_directory(path: Path) -> str | None:
    """The system directory ``path`` is, or lies in (``"/"`` for the root), else None."""
    if path == Path(path.anchor):
        return str(path)
    for name in SYSTEM_DIRECTORIES:
        system = Path(name)
        if path == system or system in path.parents:
            return name
    return None


def _writable(directory: Path) -> bool:
    return os.access(directory, os.W_OK | os.X_OK)


def _check_location(path: Path, option: str, *, directory: bool) -> Path:
    """Shared part of :func:`output_directory` and :func:`output_file`."""
    try:
        return _check_real_location(path, option, directory=directory)
    except PermissionError as err:  # a folder on the way cannot be searched
        what = "a directory" if directory else "a file"
        raise ConfigError(option, str(path), f"{what} you can reach ({err.strerror})") from None


def _check_real_location(path: Path, option: str, *, directory: bool) -> Path:
    what = "a directory" if directory else "a file"
    real = Path(os.path.realpath(path))
    # a file may not be written into a system directory (nor into / itself)
    system = _system_directory(real if directory else real.parent)
    if system is not None:
        where = "a system directory" if real == Path(system) else f"inside {system}"
        raise ConfigError(
            option,
            str(path),
            f"{what} you can write to outside the system directories ({real} is {where})",
        )
    if real.exists():
        if directory and not real.is_dir():
            raise ConfigError(option, str(path), f"{what} (it is an existing file)")
        if not directory and real.is_dir():
            raise ConfigError(option, str(path), f"{what} (it is an existing directory)")
        folder = real if directory else real.parent
        if not _writable(folder) or not (directory or os.access(real, os.W_OK)):
            raise ConfigError(option, str(path), f"{what} you can write to ({real} is not)")
        return path
    ancestor = real.parent
    while not ancestor.exists():  # the root always exists
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise ConfigError(option, str(path), f"{what} not inside a file ({ancestor} is a file)")
    if not _writable(ancestor):
        raise ConfigError(option, str(path), f"{what} you can create ({ancestor} is not writable)")
    return path


def figure_suffixes() -> frozenset[str]:
    """The suffixes (lower case, with the dot) of every format matplotlib writes figures in."""
    from matplotlib.backend_bases import FigureCanvasBase

    return frozenset(f".{s}" for s in FigureCanvasBase.get_supported_filetypes())


def output_directory(path: Path, option: str = "--out", files: Collection[str] = ()) -> Path:
    """Check that ``path`` is, or can be created as, a writable directory outside the system
    directories; ``files`` (names written into it) must not exist as directories.

    Nothing is created. Returns ``path``.

    Raises
    ------
    ConfigError
        Naming ``option`` and ``path``: a system directory (or inside one), an existing file,
        inside a file, not writable, or one of ``files`` is a directory.
    """
    _check_location(path, option, directory=True)
    for name in files:
        if (path / name).is_dir():
            raise ConfigError(
                option,
                str(path),
                f"a directory where {name} can be written ({name} is a directory)",
            )
    return path


def output_file(path: Path, option: str = "--out", suffixes: Collection[str] | None = None) -> Path:
    """Check that ``path`` is, or can be created as, a writable file outside the system
    directories, with one of ``suffixes`` (lower case, with the dot; None: any).

    Nothing is created. Returns ``path``.

    Raises
    ------
    ConfigError
        Naming ``option`` and ``path``, as :func:`output_directory`, or a suffix that is missing
        or not among ``suffixes`` (the message lists them).
    """
    if suffixes is not None and path.suffix.lower() not in suffixes:
        found = f"suffix {path.suffix}" if path.suffix else "no suffix"
        raise ConfigError(
            option, str(path), f"a file name ending in {', '.join(sorted(suffixes))} ({found})"
        )
    return _check_location(path, option, directory=False)


@contextmanager
def options_named(names: Mapping[str, str]) -> Iterator[None]:
    """Re-raise a :class:`ConfigError` whose parameter is a key of ``names`` under the option
    it maps to (``{"ramp.rate": "--rate"}``); others pass unchanged.

    Wrap only the construction of the objects the options go into, never a solve: a solver's
    own parameters must keep their names.
    """
    try:
        yield
    except ConfigError as err:
        option = names.get(str(err.parameter))
        if option is None:
            raise
        raise ConfigError(option, err.value, err.valid) from None


def given(ctx: typer.Context, name: str) -> bool:
    """Whether the parameter ``name`` (its Python name) was typed on the command line (or
    set by an environment variable), not left at its default."""
    source = ctx.get_parameter_source(name)
    return source is not None and source.name not in ("DEFAULT", "DEFAULT_MAP")


def refuse_unused(ctx: typer.Context, options: Mapping[str, str], reason: str) -> None:
    """Refuse every option of ``options`` (Python name → option) given on the command line:
    it would be ignored ``reason`` (e.g. "without --dynamic")."""
    for name, option in options.items():
        if given(ctx, name):
            value = ctx.params[name]
            raise ConfigError(
                option, getattr(value, "value", value), f"left out {reason} (it has no effect)"
            )
