"""What every ``mocapkit`` subcommand shares: the command group, one-line errors, progress
bars, finding and loading input files, strict JSON output."""

from __future__ import annotations

import functools
import warnings
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import click

from mocapkit.core.motion import Motion
from mocapkit.io import MocapFileError, RepairWarning, read_motion
from mocapkit.io.atomic import atomic_write_text
from mocapkit.jsonio import NonFiniteWarning, to_json_text


class CLIError(click.ClickException):
    """A one-line error with exit status 2 (bad input)."""

    exit_code = 2

    def show(self, file: Any = None) -> None:
        click.echo(f"mocapkit: error: {self.message}", err=True)


def friendly_errors(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Turn library exceptions about bad input into one-line CLI errors (no traceback)."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", RepairWarning)
                warnings.simplefilter("always", NonFiniteWarning)
                try:
                    return fn(*args, **kwargs)
                finally:
                    for w in caught:
                        kind = "repaired" if issubclass(w.category, RepairWarning) else "warning"
                        click.echo(f"mocapkit: {kind}: {w.message}", err=True)
        except MocapFileError as e:
            raise CLIError(str(e)) from None
        except (ValueError, KeyError, FileNotFoundError, ImportError) as e:
            raise CLIError(str(e).strip("'\"")) from None

    return wrapper


@contextmanager
def progress_callback(description: str, enabled: bool = True) -> Iterator[Callable[..., None]]:
    """A rich progress bar on stderr for a library function's ``progress`` callback: yields
    ``update(*labels, done, total)`` (the last two arguments are used, so it fits both
    ``progress(done, total)`` and ``progress(stage, done, total)``)."""
    if not enabled:
        yield lambda *args: None
        return
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeRemainingColumn

    with Progress(
        "[progress.description]{task.description}",
        BarColumn(),
        MofNCompleteColumn(),
        TimeRemainingColumn(),
        console=Console(stderr=True),
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
    help="Repair what is safe (frame-count mismatch, blank or truncated rows, NaN gaps) and "
    "report it, instead of failing.",
)


@click.group(context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(package_name="mocapkit")
def main() -> None:
    """mocapkit: motion-capture data tools (BVH, ASF/AMC).

    \b
    Examples:
      mocapkit info walk.bvh
      mocapkit convert subject.asf walk.amc walk.bvh   (see: mocapkit convert -h)
      mocapkit demo --out demo_out
    """


MOTION_SUFFIXES = (".bvh", ".npz", ".amc")
"""What the subcommands that read motions accept (an .amc needs its subject's .asf beside it)."""

_GLOB_CHARS = frozenset("*?[")


def _check_amc(f: Path) -> None:
    from mocapkit.io import find_asf

    try:
        find_asf(f)
    except MocapFileError as e:
        raise CLIError(str(e)) from None


def expand_inputs(
    items: Sequence[str | Path],
    suffixes: Sequence[str] = MOTION_SUFFIXES,
    exclude: Sequence[str | Path] = (),
    unique: bool = True,
) -> list[Path]:
    """The motion files named by ``items``: files as given, the files of folders and the matches
    of glob patterns (``'clips/*.bvh'``, quoted so that the shell leaves it alone) whose
    extension is one of ``suffixes`` (folders and patterns skip the rest, e.g. Bandai's
    ``.json`` labels), sorted; duplicates (unless ``unique=False``: ``view a.bvh a.bvh``
    overlays a file on itself) and ``exclude`` removed, order kept.

    An ``.amc`` needs its subject's skeleton beside it (``NN.asf`` for ``NN_MM.amc``, or the only
    ``.asf`` of its folder; :func:`mocapkit.io.find_asf`). A missing path, an empty folder or a
    pattern that matches nothing is a one-line :class:`CLIError`.
    """
    import glob

    want = tuple(s.lower() for s in suffixes)
    kinds = "/".join(want)
    skip = {Path(e).resolve() for e in exclude}
    out: list[Path] = []
    for item in items:
        p = Path(item)
        if p.is_dir():
            found = sorted(f for f in p.iterdir() if f.is_file() and f.suffix.lower() in want)
            if not found:
                raise CLIError(f"{p}: no {kinds} files in this folder")
            out += found
        elif p.exists():
            out.append(p)
        elif _GLOB_CHARS & set(str(item)):
            found = sorted(
                Path(f)
                for f in glob.glob(str(item), recursive=True)
                if Path(f).is_file() and Path(f).suffix.lower() in want
            )
            if not found:
                raise CLIError(f"{item}: no {kinds} files match this pattern")
            out += found
        else:
            raise CLIError(f"{p}: cannot read file: no such file or folder")
    seen: set[Path] = set()
    result = []
    for f in out:
        r = f.resolve()
        if r in skip or (unique and r in seen):
            continue
        seen.add(r)
        if f.suffix.lower() == ".amc":
            _check_amc(f)
        result.append(f)
    return result


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


def echo_json(obj: Any) -> None:
    """Print ``obj`` (a result's ``to_json()``) as strict JSON (:func:`mocapkit.jsonio`)."""
    click.echo(to_json_text(obj))


def write_json(path: str | Path, obj: Any) -> Path:
    """Write ``obj`` as strict JSON, atomically."""
    return atomic_write_text(path, to_json_text(obj) + "\n")
