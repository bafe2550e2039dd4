"""Library jobs on the command line: the ``--workers`` / ``--scheduler`` options every library
command takes, the job progress bar, and ``mocapkit clean LIB/`` (:func:`clean_folder`)."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import click

from mocapkit.batch.runner import RUNNER_HELP, JobError, Runner
from mocapkit.cli.common import CLIError, one_line


def runner_options(fn: Callable[..., Any]) -> Callable[..., Any]:
    """``--workers N`` and ``--scheduler ADDRESS`` (see :class:`mocapkit.batch.Runner`)."""
    fn = click.option(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="Run the job on a running Dask cluster (e.g. tcp://127.0.0.1:8786, started with "
        "`dask scheduler` and `dask worker ADDRESS`); its workers must see the same files.",
    )(fn)
    return click.option(
        "--workers",
        type=click.IntRange(min=1),
        default=None,
        metavar="N",
        help="Run the job on a local Dask cluster of N worker processes (started and stopped "
        "here). " + _sentence(RUNNER_HELP.split(";", 1)[1]),
    )(fn)


def _sentence(text: str) -> str:
    """``text`` stripped, its first letter upper case (str.capitalize lowers the rest: it wrote
    "dask scheduler" and "this process. the results", newcomer report)."""
    text = text.strip()
    return text[:1].upper() + text[1:]


@contextmanager
def job_runner(workers: int | None, scheduler: str | None) -> Iterator[Runner]:
    """The job's :class:`Runner` (started, closed at the end); a cluster failure is one line."""
    if workers is not None and scheduler is not None:
        raise CLIError("give --workers or --scheduler, not both")
    runner = Runner(workers, scheduler)
    try:  # started by the job's first task: a job with nothing to do starts no cluster
        yield runner
    except JobError as e:
        raise CLIError(one_line(e)) from None
    finally:
        runner.close()


@contextmanager
def job_progress(description: str, enabled: bool = True) -> Iterator[Callable[[int, int], None]]:
    """One progress bar over a whole job on stderr (tasks done / total, throughput, ETA), fed
    by the runner's completion events; shown only when stderr is a terminal."""
    from rich.console import Console

    console = Console(stderr=True)
    if not enabled or not console.is_terminal:
        yield lambda done, total: None
        return
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    t0 = time.perf_counter()
    with Progress(
        TextColumn("{task.description}", markup=False),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[rate]}"),
        TimeElapsedColumn(),
        TextColumn("ETA"),
        TimeRemainingColumn(),
        console=console,
        transient=True,
    ) as bar:
        task = bar.add_task(description, total=None, rate="")

        def update(done: int, total: int) -> None:
            dt = time.perf_counter() - t0
            rate = f"{done / dt:.1f}/s" if dt > 0 and done else ""
            bar.update(task, completed=done, total=total, rate=rate)

        yield update


def _mb(n: int) -> str:
    return f"{n / 2**20:.0f} MB"


def peak_memory_line(runner: Runner) -> str:
    """Peak resident memory of the processes that ran the job's tasks."""
    peaks = runner.stats.peak_rss
    if not peaks:
        return "peak memory: no task ran"
    where = "this process" if runner.mode == "in-process" else f"{len(peaks)} worker(s)"
    return f"peak memory per worker: {_mb(max(peaks.values()))} ({where})"


def clean_folder(
    library: str,
    out_dir: str | None,
    report_dir: str,
    context_by: str,
    context_max: int,
    threshold: float | None,
    two_stage: bool,
    lenient: bool,
    workers: int | None,
    scheduler: str | None,
    quiet: bool,
) -> None:
    """``mocapkit clean LIB/``: every take of a library folder cleaned against its related takes
    (:func:`mocapkit.batch.clean_library`), one line per take with flags, one summary line;
    exit status 2 when a take failed (the others are done)."""
    from mocapkit.batch.clean_library import LibraryCleanConfig, clean_library

    config = LibraryCleanConfig(context_by, context_max, threshold, two_stage, lenient)

    def on_take(r: dict[str, Any]) -> None:
        if "error" in r:
            click.echo(f"mocapkit: error: {one_line(r['error'])}", err=True)
        elif not quiet:
            if r["flagged_seconds"] > 0:
                worst = ", ".join(w["joint"] for w in r["worst_joints"][:3])
                click.echo(f"{r['take']}: {r['flagged_seconds']:.2f} s flagged ({worst})")
            left = r.get("context_skipped") or []
            if left and not r.get("context"):  # every related take left out: say so
                more = f" and {len(left) - 1} more" if len(left) > 1 else ""
                click.echo(
                    f"{r['take']}: cleaned against itself alone: its related takes were left "
                    f"out ({one_line(left[0])}{more})"
                )

    t0 = time.perf_counter()
    with (
        job_runner(workers, scheduler) as runner,
        job_progress("cleaning takes", enabled=not quiet) as step,
    ):
        res = clean_library(
            library, out_dir, report_dir, config, runner=runner, progress=step, on_take=on_take
        )
        where = runner.describe()
        mem = peak_memory_line(runner)
    dt = time.perf_counter() - t0
    n = len(res.records)
    rate = res.cleaned / dt if dt > 0 else 0.0
    if not quiet:
        done = "cleaned" if out_dir is not None else "analysed, no repair written (no --out-dir)"
        click.echo(
            f"{n} takes: {res.cleaned} {done}; {where}, {dt:.1f} s, {rate:.1f} takes/s; "
            f"{res.resumed} already complete, {len(res.failed)} failed"
        )
        click.echo(mem)
        click.echo(f"wrote {res.summary_path} and {res.overview_path}")
    if res.failed:
        raise click.exceptions.Exit(2)
