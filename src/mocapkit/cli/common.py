"""What every ``mocapkit`` subcommand shares: the command group, one-line errors, progress
bars, finding and loading input files, strict JSON output."""

from __future__ import annotations

import functools
import os
import re
import sys
import warnings
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path
from typing import Any

import click

from mocapkit.core.motion import Motion
from mocapkit.core.skeleton import Skeleton
from mocapkit.io import MocapFileError, RepairWarning, files_under, read_motion
from mocapkit.io.atomic import OutputPathError, atomic_write_text
from mocapkit.io.errors import warning_lines
from mocapkit.jsonio import to_json_text


class CLIError(click.ClickException):
    """A one-line error with exit status 2 (bad input)."""

    exit_code = 2

    def show(self, file: Any = None) -> None:
        click.echo(f"mocapkit: error: {self.message}", err=True)


_OS_REASONS: tuple[tuple[type[OSError], str], ...] = (
    (FileNotFoundError, "no such file or folder"),
    (IsADirectoryError, "is a folder, expected a file"),
    (NotADirectoryError, "a part of this path is a file, expected a folder"),
    (FileExistsError, "is a file, expected a folder"),
    (PermissionError, "permission denied"),
)


def os_error_line(e: OSError) -> str:
    """One line for an OSError about a path: the path and what was expected there."""
    if isinstance(e, OutputPathError):
        return str(e)
    reason = next((r for cls, r in _OS_REASONS if isinstance(e, cls)), None)
    reason = reason or e.strerror or str(e) or type(e).__name__
    if e.filename is None:
        return reason if e.strerror else str(e) or reason
    where = str(e.filename) + (f" -> {e.filename2}" if e.filename2 else "")
    return f"{where}: {reason}"


def _warning_lines(caught: Sequence[warnings.WarningMessage]) -> list[str]:
    return [f"mocapkit: {line}" for line in warning_lines(caught)]


_CAUGHT: ContextVar[list[warnings.WarningMessage] | None] = ContextVar(
    "mocapkit_cli_warnings", default=None
)
"""The warnings the running command (:func:`friendly_errors`) has caught so far."""


def warnings_so_far() -> list[str]:
    """The warnings the running command has raised so far, as its end prints them, less the
    ``mocapkit:`` prefix (``warning: ...``, ``repaired: ...``): for a ``--json`` result to say
    what standard error says (newcomer report: a CMU take written as BVH, whose unit a BVH file
    cannot state, was warned about on standard error only). Empty outside a command."""
    caught = _CAUGHT.get()
    return [] if caught is None else warning_lines(caught)


def one_line(message: object) -> str:
    """``message`` on one line (newlines and runs of blanks become one space)."""
    return " ".join(str(message).split())


def exception_text(e: BaseException) -> str:
    """The message of an exception; a KeyError's repr quotes are dropped, never a quote that
    belongs to the message (``got '80:40'``)."""
    if isinstance(e, KeyError) and len(e.args) == 1 and isinstance(e.args[0], str):
        return e.args[0]
    return str(e)


def friendly_errors(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Turn library exceptions about bad input (and OSErrors about paths) into one-line CLI
    errors with exit status 2 (no traceback).

    Warnings raised meanwhile are printed once each when the command ends: a
    :class:`~mocapkit.io.RepairWarning` as ``mocapkit: repaired: ...``, others as
    ``mocapkit: warning: ...``; numpy's overflow/invalid-value RuntimeWarnings are dropped. When
    the command fails only the repairs (which may be why: a header's frame count cut to the
    rows that follow leaves a take too short) and the error line are printed, and a command
    asked to print its JSON
    result (``--json`` as a flag, or ``--json -``) prints ``{"error": LINE}`` there instead,
    so that a script reading standard output always gets JSON.
    """

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return run(*args, **kwargs)
        except click.ClickException as e:
            if kwargs.get("as_json") is True or kwargs.get("json_path") == "-":
                echo_json({"error": e.format_message()})
                e.json_printed = True  # type: ignore[attr-defined]  # not again by the group
            raise

    def run(*args: Any, **kwargs: Any) -> Any:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            token = _CAUGHT.set(caught)
            try:
                result = fn(*args, **kwargs)
            except click.exceptions.Exit:
                _flush_warnings(caught)
                raise
            except click.ClickException:
                _flush_warnings(caught, repairs_only=True)
                raise
            except MocapFileError as e:
                _flush_warnings(caught, repairs_only=True)
                raise CLIError(one_line(e)) from None
            except BrokenPipeError as e:  # `mocapkit ... | head`: the reader has gone
                if not _stdout_broken():  # another pipe (a socket): an error like any other
                    _flush_warnings(caught, repairs_only=True)
                    raise CLIError(one_line(os_error_line(e))) from None
                _quiet_stdout()
                raise click.exceptions.Exit(1) from None
            except OSError as e:
                _flush_warnings(caught, repairs_only=True)
                raise CLIError(one_line(os_error_line(e))) from None
            except (ValueError, KeyError, ImportError) as e:
                _flush_warnings(caught, repairs_only=True)
                raise CLIError(one_line(exception_text(e))) from None
            finally:
                _CAUGHT.reset(token)
            _flush_warnings(caught)
            return result

    return wrapper


def _stdout_broken() -> bool:
    """Whether standard output is a pipe whose reader has gone (poll reports an error on it)."""
    import select

    try:
        poll = select.poll()
        poll.register(sys.stdout.fileno(), select.POLLOUT)
        return any(ev & (select.POLLERR | select.POLLHUP) for _, ev in poll.poll(0))
    except (OSError, ValueError, AttributeError):  # no poll, or no real descriptor
        return False


def _quiet_stdout() -> None:
    """Point standard output at /dev/null, so that flushing it at exit after its reader has
    gone raises no second BrokenPipeError (the recipe of Python's signal documentation)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # no real file descriptor (a test runner)
        pass


def _flush_warnings(caught: Sequence[warnings.WarningMessage], repairs_only: bool = False) -> None:
    if repairs_only:
        caught = [w for w in caught if issubclass(w.category, RepairWarning)]
    for line in _warning_lines(caught):
        click.echo(line, err=True)


@contextmanager
def progress_callback(description: str, enabled: bool = True) -> Iterator[Callable[..., None]]:
    """A rich progress bar on stderr for a library function's ``progress`` callback: yields
    ``update(*labels, done, total)`` (the last two arguments are used, so it fits both
    ``progress(done, total)`` and ``progress(stage, done, total)``). Shown only when stderr
    is a terminal (logs and pipes get no bar)."""
    from rich.console import Console

    console = Console(stderr=True)
    if not enabled or not console.is_terminal:
        yield lambda *args: None
        return
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeRemainingColumn,
    )

    with Progress(
        TextColumn("{task.description}", markup=False, style="progress.description"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeRemainingColumn(),
        console=console,
        transient=True,
    ) as bar:
        task = bar.add_task(description, total=None)

        def update(*args: Any) -> None:
            *labels, done, total = args
            text = f"{description} ({labels[0]})" if labels else description
            bar.update(task, completed=done, total=total, description=text)

        yield update


@contextmanager
def progress(total: int, description: str, enabled: bool = True) -> Iterator[Callable[[], None]]:
    """A rich progress bar on stderr; yields a function to call once per finished item."""
    if not enabled or total <= 1:
        yield lambda: None
        return
    with progress_callback(description) as update:
        done = 0

        def step() -> None:
            nonlocal done
            done += 1
            update(done, total)

        update(0, total)
        yield step


def load(path: str, lenient: bool, asf: str | None = None, fps: float | None = None) -> Motion:
    kwargs: dict[str, Any] = {"lenient": lenient}
    if asf is not None:
        kwargs["asf"] = asf
    if fps is not None:
        kwargs["fps"] = fps
    return read_motion(path, **kwargs)


LENIENT = click.option(
    "--lenient",
    is_flag=True,
    help="Repair what is safe (frame-count mismatch, blank rows, an incomplete last row, NaN "
    "gaps) and report it, instead of failing.",
)


class JsonFile(click.Path):
    """A ``--json FILE|-`` value: a file to write, or ``-`` to print. A value that is another
    option (``--json --out x.bvh``, written as if ``--json`` were a flag, as it is in info,
    edit, graph and retarget) is refused, rather than read as the file's name (newcomer: the
    JSON went to a file named ``--out`` and ``x.bvh`` was read as an input)."""

    def __init__(self) -> None:
        super().__init__(dir_okay=False, allow_dash=True)

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None):
        if isinstance(value, str) and value.startswith("-") and value != "-":
            self.fail(
                f"takes a file to write, or - to print the JSON; got {value!r}, an option "
                "(here --json is not a flag: write --json - to print it)",
                param,
                ctx,
            )
        return super().convert(value, param, ctx)


class OneLineUsageError(click.UsageError):
    """A usage error (unknown option, missing argument, bad value) as one line on stderr:
    ``mocapkit: error: MESSAGE (see 'mocapkit CMD --help')``."""

    def show(self, file: Any = None) -> None:
        hint = f" (see '{self.ctx.command_path} --help')" if self.ctx is not None else ""
        click.echo(f"mocapkit: error: {one_line(self.format_message())}{hint}", err=True)


class OneLineErrorGroup(click.Group):
    """The command group: usage errors of it and of every subcommand are one line."""

    group_class = type  # subgroups (``graph``) are of this class too

    @staticmethod
    def _one_line(e: click.UsageError) -> click.UsageError:
        if isinstance(e, (OneLineUsageError, click.exceptions.NoArgsIsHelpError)):
            return e
        out = OneLineUsageError(e.format_message(), e.ctx)
        out.exit_code = e.exit_code
        return out

    def make_context(self, *args: Any, **kwargs: Any) -> click.Context:
        try:
            return super().make_context(*args, **kwargs)
        except click.UsageError as e:
            raise self._one_line(e) from None

    def invoke(self, ctx: click.Context) -> Any:
        args = [*getattr(ctx, "_protected_args", []), *ctx.args]  # the subcommand and its args
        try:
            return super().invoke(ctx)
        except click.UsageError as e:
            cmd = self.get_command(ctx, args[0]) if args else None
            if not getattr(e, "json_printed", False) and _json_on_stdout(cmd, args[1:]):
                echo_json({"error": one_line(e.format_message())})  # a mistyped option too
            raise self._one_line(e) from None


def _json_on_stdout(cmd: click.Command | None, args: Sequence[str]) -> bool:
    """Whether ``args`` ask ``cmd`` (not a group: its own subcommand judges) to print its
    JSON result on standard output: ``--json`` where it is a flag, or ``--json -``."""
    if cmd is None or isinstance(cmd, click.Group):
        return False
    opt = next((p for p in cmd.params if isinstance(p, click.Option) and "--json" in p.opts), None)
    if opt is None:
        return False
    for i, a in enumerate(args):  # under any of its names (clean's --report too)
        if a in opt.opts:
            return bool(opt.is_flag) or args[i + 1 : i + 2] == ["-"]
        if any(a == f"{name}=-" for name in opt.opts):
            return True
    return False


@click.group(
    cls=OneLineErrorGroup,
    context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100},
)
@click.version_option(package_name="mocapkit")
def main() -> None:
    """mocapkit: motion-capture data tools (BVH, ASF/AMC).

    \b
    Examples:
      mocapkit info walk.bvh
      mocapkit convert subject.asf walk.amc walk.bvh   (see: mocapkit convert -h)
      mocapkit demo --out demo_out
    """


MOTION_SUFFIXES = (".bvh", ".npz", ".amc", ".glb", ".gltf")
"""What the subcommands that read motions accept (an .amc needs its subject's .asf beside it)."""

_GLOB_CHARS = frozenset("*?[")


def check_amc(f: Path) -> None:
    from mocapkit.io import find_asf

    try:
        find_asf(f)
    except MocapFileError as e:
        raise CLIError(one_line(e)) from None


def file_key(p: Path) -> tuple[Any, ...]:
    """What makes two paths the same file: device and inode (hard links, symlinks, other
    spellings), or the resolved path when it cannot be stat'ed."""
    try:
        st = p.stat()
        return (st.st_dev, st.st_ino)
    except OSError:
        return (str(p.resolve()),)


def expand_item(item: str | Path, suffixes: Sequence[str] = MOTION_SUFFIXES) -> list[Path]:
    """The files one command-line item names (see :func:`expand_inputs`); a one-line
    :class:`CLIError` naming it when it names none."""
    import glob

    want = tuple(dict.fromkeys(s.lower() for s in suffixes))
    kinds = "/".join(want)
    p = Path(item)
    if str(item) == "-" and not p.exists():  # newcomer: `info FILE --json -`, as elsewhere
        raise CLIError(
            "-: standard input is not read; give motion files (where --json is a flag, as "
            "here, it prints the JSON with no value)"
        )
    if p.is_dir():
        try:
            found = files_under(p, want)
        except OSError as e:
            raise CLIError(
                f"{p}: cannot list this folder: {os_error_line(e).split(': ')[-1]}"
            ) from None
        if not found:
            raise CLIError(f"{p}: no {kinds} files in this folder or its sub-folders")
        return found
    if p.exists():
        return [p]
    if _GLOB_CHARS & set(str(item)):
        found = sorted(
            Path(f)
            for f in glob.glob(str(item), recursive=True)
            if Path(f).is_file() and Path(f).suffix.lower() in want
        )
        if found:
            return found
        if not any(c in str(item) for c in "*?"):  # "[take 1].bvh": a name, not a pattern
            raise CLIError(f"{p}: cannot read file: no such file or folder")
        raise CLIError(f"{item}: no {kinds} files match this pattern")
    if p.is_symlink():
        raise CLIError(f"{p}: broken symbolic link (its target does not exist)")
    raise CLIError(f"{p}: cannot read file: no such file or folder")


def is_single_file(items: Sequence[str | Path]) -> bool:
    """Whether ``items`` is exactly one existing file (not a folder, not a glob pattern): then
    a command prints one result, else a list."""
    return len(items) == 1 and Path(items[0]).is_file()


def expand_inputs(
    items: Sequence[str | Path],
    suffixes: Sequence[str] = MOTION_SUFFIXES,
    exclude: Sequence[str | Path] = (),
    unique: bool = True,
) -> list[Path]:
    """The motion files named by ``items``: files as given, the files of folders (and of their
    sub-folders, linked ones too, hidden ones skipped: :func:`mocapkit.io.files_under`) and the
    matches of glob patterns (``'clips/*.bvh'``, quoted so that the shell leaves it alone) whose
    extension is one of ``suffixes`` (folders and patterns skip the rest, e.g. Bandai's
    ``.json`` labels), sorted; duplicates (the same file under any spelling, unless
    ``unique=False``: ``view a.bvh a.bvh`` overlays a file on itself) and ``exclude`` removed,
    order kept.

    An ``.amc`` needs its subject's skeleton beside it (``NN.asf`` for ``NN_MM.amc``, or the only
    ``.asf`` of its folder; :func:`mocapkit.io.find_asf`). A missing path, an empty folder or a
    pattern that matches nothing is a one-line :class:`CLIError`.
    """
    out: list[Path] = []
    for item in items:
        out += expand_item(item, suffixes)
    skip = {file_key(Path(e)) for e in exclude}
    seen: set[tuple[Any, ...]] = set()
    result = []
    for f in out:
        key = file_key(f)
        if key in skip or (unique and key in seen):
            continue
        seen.add(key)
        if f.suffix.lower() == ".amc":
            check_amc(f)
        result.append(f)
    return result


def expand_library(
    items: Sequence[str | Path], suffixes: Sequence[str] = MOTION_SUFFIXES
) -> tuple[list[Path], list[str]]:
    """:func:`expand_inputs` for a library job, which goes on past a bad input: the files the
    items name (each once), and one error line per item that names none (a missing path, an
    empty folder, a pattern matching nothing) and per ``.amc`` without its ``.asf`` (left out,
    not the folder it is in)."""
    found: list[Path] = []
    errors: list[str] = []
    for item in items:
        try:
            found += expand_item(item, suffixes)
        except CLIError as e:
            errors.append(e.message)
    seen: set[tuple[Any, ...]] = set()
    unique = []
    for f in found:
        if file_key(f) in seen:
            continue
        seen.add(file_key(f))
        if f.suffix.lower() == ".amc":
            try:
                check_amc(f)
            except CLIError as e:
                errors.append(e.message)
                continue
        unique.append(f)
    return unique, errors


def check_input_file(path: str | Path, what: str = "motion file") -> Path:
    """``path`` as a Path if it is an existing file, else a one-line :class:`CLIError`."""
    p = Path(path)
    if p.is_dir():
        raise CLIError(f"{p}: is a folder, expected a {what}")
    if not p.exists():
        if p.is_symlink():
            raise CLIError(f"{p}: broken symbolic link (its target does not exist)")
        raise CLIError(f"{p}: cannot read file: no such file or folder")
    return p


def data_output(path: str | None, what: str, example: str) -> str | None:
    """``path`` for an output that is not a motion (JSON, GraphML, a plot, an .npy, a page):
    refused when named like a motion file (``--plot clips/x.bvh`` would put a PNG among the
    clips, where the next run reads it as one). ``-`` (standard output) is no file: None."""
    if path == "-":  # standard output (see report_lines): no file to check
        return None
    if path is not None and Path(path).suffix.lower() in (*MOTION_SUFFIXES, ".asf"):
        raise CLIError(
            f"{path}: a motion file name for the {what}; give it another extension (e.g. {example})"
        )
    return path


def no_joint_named(name: str, skeleton: Skeleton) -> str:
    """The message "no joint named 'X'" with the joints likely meant: the part the name means
    in another convention (the body model: ``Knee_L`` -> ``LowerLeg_L``), else close spellings
    (case ignored), else the first few of the rig's joints."""
    import difflib

    from mocapkit.body import body_of

    names = list(skeleton.names)
    close = [names[j] for j in body_of(skeleton).joints_meant(name)]
    lower = {n.lower(): n for n in names}
    close = close or [
        lower[m] for m in difflib.get_close_matches(name.lower(), list(lower), 3, 0.6)
    ]
    if close:
        return f"no joint named {name!r} (did you mean {', '.join(close)}?)"
    shown = ", ".join(list(names)[:12]) + (", ..." if len(names) > 12 else "")
    return f"no joint named {name!r} (this rig's joints: {shown})"


def npy_output(path: str | None, what: str) -> str | None:
    """``path`` for a NumPy array (:func:`data_output`): refused unless named ``.npy``, so
    that ``--mdm m.csv`` does not write binary under a text name."""
    path = data_output(path, what, ".npy")
    if path is not None and Path(path).suffix.lower() != ".npy":
        raise CLIError(f"{path}: the {what} is a NumPy array; name it .npy (e.g. mdm.npy)")
    return path


def plot_output(path: str | None) -> str | None:
    """``path`` for a plot (:func:`data_output`), which is a PNG image: refused unless named
    ``.png``, so that a plot is not written under a name another program reads as text."""
    path = data_output(path, "plot", ".png")
    if path is not None and Path(path).suffix.lower() != ".png":
        raise CLIError(f"{path}: the plot is a PNG image; name it .png (e.g. mdm.png)")
    return path


@contextmanager
def naming(*paths: str | Path | None) -> Iterator[None]:
    """Errors about the data that do not name a file name the first of ``paths``: a ValueError
    raised inside (not a :class:`~mocapkit.io.MocapFileError`, which names its file) becomes a
    one-line :class:`CLIError` ``"PATH: message"`` unless its message already names one of
    ``paths``."""
    try:
        yield
    except (click.ClickException, MocapFileError, OSError):
        raise
    except (ValueError, KeyError) as e:
        msg = one_line(exception_text(e))
        names = [str(p) for p in paths if p is not None]
        if names and not any(n in msg for n in names):
            msg = f"{names[0]}: {msg}"
        raise CLIError(msg) from None


_UP = re.compile(r"[+-]?[XYZ]")


def parse_up(value: str | None) -> str | None:
    """``--up``: X, Y or Z with an optional sign (case-insensitive), or None."""
    if value is None:
        return None
    v = value.strip().upper()
    if not _UP.fullmatch(v):
        raise click.BadParameter(
            f"{value!r}: expected X, Y or Z with an optional sign (Y, Z, -Y, +X, ...)"
        )
    return v


def warn_if_up_disagrees(motion: Motion, up: str | None, name: str | Path) -> None:
    """One warning line when ``--up`` names another axis than the one ``name``'s body stands
    along (:func:`mocapkit.features.up_disagreement`): a Z-up reading of a Y-up take puts its
    ground on a wall, and every ground-path result (facing, travel, foot contacts) is then wrong
    without any error."""
    from mocapkit.features import up_disagreement

    found = up_disagreement(motion, up)
    if found is not None:
        click.echo(
            f"mocapkit: warning: {name}: --up {up}, but its body stands along {found} (head "
            f"above the feet); going on with {up} as asked",
            err=True,
        )


def up_option(help: str = "Up axis (Y, Z, -Y, ...) instead of the guess.") -> Callable[..., Any]:
    """The ``--up`` option, refused unless X, Y or Z with an optional sign."""
    return click.option(
        "--up", default=None, help=help, callback=lambda ctx, param, value: parse_up(value)
    )


def load_all(
    paths: Sequence[Path | str], lenient: bool, description: str = "reading", show: bool = True
) -> list[Motion]:
    """Read every path (:func:`load`) under one progress bar."""
    out = []
    with progress(len(paths), description, enabled=show) as step:
        for p in paths:
            out.append(load(str(p), lenient))
            step()
    return out


def load_readable(
    paths: Sequence[Path | str], lenient: bool, description: str = "reading", show: bool = True
) -> tuple[list[Path | str], list[Motion], list[str]]:
    """Read every path under one progress bar, as a library job does: a file that cannot be
    read is left out and the others go on. Returns the paths read, their motions, and one
    error line per file left out."""
    kept: list[Path | str] = []
    motions: list[Motion] = []
    errors: list[str] = []
    with progress(len(paths), description, enabled=show) as step:
        for p in paths:
            try:
                motions.append(load(str(p), lenient))
                kept.append(p)
            except (MocapFileError, OSError) as e:
                why = e if isinstance(e, MocapFileError) else f"{p}: {e.strerror or e}"
                errors.append(one_line(why))
            step()
    return kept, motions, errors


def echo_json(obj: Any) -> None:
    """Print ``obj`` (a result's ``to_json()``) as strict JSON (:func:`mocapkit.jsonio`)."""
    click.echo(to_json_text(obj))


def write_json(path: str | Path, obj: Any) -> Path:
    """Write ``obj`` as strict JSON, atomically; ``-``: print it on standard output."""
    if str(path) == "-":
        echo_json(obj)
        return Path("-")
    return atomic_write_text(path, to_json_text(obj) + "\n")


def report_lines(json_path: str | None) -> Callable[[str], None]:
    """How a command that can write its JSON result with ``--json PATH`` prints its readable
    lines: on standard output, or on standard error when the JSON goes there (``--json -``),
    so that a script reads JSON alone."""
    to_err = json_path == "-"
    return lambda line: click.echo(line, err=to_err)
