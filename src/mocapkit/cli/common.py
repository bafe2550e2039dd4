"""What every ``mocapkit`` subcommand shares: the command group, one-line errors, progress
bars, loading files."""

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
                result = fn(*args, **kwargs)
            for w in caught:
                click.echo(f"mocapkit: repaired: {w.message}", err=True)
            return result
        except MocapFileError as e:
            raise CLIError(str(e)) from None
        except (ValueError, KeyError, FileNotFoundError, ImportError) as e:
            raise CLIError(str(e).strip("'\"")) from None

    return wrapper


@contextmanager
def progress(total: int, description: str, enabled: bool = True) -> Iterator[Callable[[], None]]:
    """A rich progress bar on stderr; yields a function to call once per finished item."""
    if not enabled or total <= 1:
        yield lambda: None
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
        task = bar.add_task(description, total=total)
        yield lambda: bar.advance(task)


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


MOTION_SUFFIXES = (".bvh", ".npz")  # what a folder argument contributes


def expand_inputs(items: Sequence[str], exclude: Sequence[str] = ()) -> list[Path]:
    """Files and the motion files (``*.bvh``, ``*.npz``) of folders, sorted, without ``exclude``."""
    skip = {Path(e).resolve() for e in exclude}
    out: list[Path] = []
    for item in items:
        p = Path(item)
        if p.is_dir():
            found = sorted(f for f in p.iterdir() if f.suffix.lower() in MOTION_SUFFIXES)
            if not found:
                raise CLIError(f"{p}: no .bvh or .npz files in this folder")
            out += found
        elif p.exists():
            out.append(p)
        else:
            raise CLIError(f"{p}: no such file or folder")
    seen: set[Path] = set()
    result = []
    for f in out:
        r = f.resolve()
        if r in skip or r in seen:
            continue
        seen.add(r)
        result.append(f)
    return result
