"""Where a library job runs: in this process, on a local Dask cluster that mocapkit starts and
stops (``workers=N``: N worker processes of one thread each, on 127.0.0.1), or on an existing
Dask cluster (``scheduler="tcp://host:8786"``).

A job is a pure function mapped over items (:meth:`Runner.map`, :meth:`Runner.imap`); results
come back in input order whichever way the job runs, so a job's outputs do not depend on where
or on how many workers it ran. Progress is counted from the scheduler's completion events
(:func:`distributed.as_completed`), so it works the same on a remote scheduler.

A worker that dies mid-task is replaced by its nanny and the scheduler reruns its lost tasks;
a task that kills its worker again and again (``distributed.scheduler.allowed-failures``) ends
the job with one :class:`JobError` line naming the item.
"""

from __future__ import annotations

import contextlib
import os
import resource
import sys
import time
import warnings
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

__all__ = ["RUNNER_HELP", "JobError", "RunStats", "Runner"]

Progress = Callable[[int, int], None]

RUNNER_HELP = (
    "--workers N starts a local Dask cluster of N worker processes (1 thread each) for the job "
    "and stops it after; --scheduler ADDRESS uses a running Dask cluster (its workers must see "
    "the same files; they run the tasks in this command's folder, so relative paths mean the "
    "same files); without either the job runs in this process. The results are the same."
)


class JobError(RuntimeError):
    """A library job could not finish (a worker lost again and again, the scheduler gone); its
    message is one line."""


def _peak_rss_bytes() -> int:
    """This process's peak resident memory so far (bytes)."""
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return int(peak if sys.platform == "darwin" else peak * 1024)


_MALLOC_SET = False


def keep_freed_memory() -> bool:
    """Let glibc keep large freed blocks for reuse in this process again, where its adaptive
    behaviour was turned off; True when it changed anything.

    Dask's nanny starts its workers with ``MALLOC_TRIM_THRESHOLD_`` set (to hand freed memory
    back to the system). Setting it at all turns off glibc's adaptive mmap threshold, so every
    NumPy temporary above 128 KiB is mapped afresh and page-faulted in again: a graph tile
    task ran 1.4x slower on a worker than in this process (its gathers 2-4x). Fixed thresholds
    of glibc's own adaptive ceiling (mmap above 32 MiB, trim above 64 MiB) bring it back."""
    global _MALLOC_SET
    if _MALLOC_SET or not os.environ.get("MALLOC_TRIM_THRESHOLD_"):
        return False
    _MALLOC_SET = True
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6")
        m_trim_threshold, m_mmap_threshold = -1, -3  # glibc's mallopt parameters
        return bool(libc.mallopt(m_mmap_threshold, 32 << 20)) and bool(
            libc.mallopt(m_trim_threshold, 64 << 20)
        )
    except (OSError, AttributeError):  # not glibc: nothing to do
        return False


class _ClientFolder:
    """Run tasks in the folder the client ran in, so that the paths a user typed relative to
    it mean the same files on a worker started elsewhere (``dask worker`` run from ``/`` read
    and wrote ``/fixed/...``). The working folder belongs to the whole worker process: tasks
    wanting one folder run together, a task wanting another waits until they are done, and
    the worker's own folder comes back after. A worker that has no such folder (another
    machine) runs the task in its own folder, also waiting for tasks in another one."""

    def __init__(self) -> None:
        import threading

        self._cond = threading.Condition()
        self._folder: str | None = None  # the folder the running tasks want (None: own)
        self._users = 0
        self._home: str | None = None

    @contextlib.contextmanager
    def inside(self, folder: str | None) -> Iterator[None]:
        want = folder if folder and os.path.isdir(folder) else None
        with self._cond:
            while self._users and self._folder != want:
                self._cond.wait()
            if not self._users:
                try:
                    self._home = os.getcwd()
                except OSError:  # the worker's own folder is gone: nothing to come back to
                    self._home = None
                if want is not None and (
                    self._home is None or os.path.realpath(self._home) != os.path.realpath(want)
                ):
                    os.chdir(want)
                self._folder = want
            self._users += 1
        try:
            yield
        finally:
            with self._cond:
                self._users -= 1
                if not self._users:
                    try:
                        if self._home is not None and os.getcwd() != self._home:
                            os.chdir(self._home)
                    except OSError:  # gone meanwhile: stay; the next task sets its own
                        pass
                    self._folder = None
                    self._cond.notify_all()


_CLIENT_FOLDER = _ClientFolder()


def _call(
    fn: Callable[..., Any],
    item: Any,
    shared: Any = None,
    has_shared: bool = False,
    folder: str | None = None,
) -> Any:
    """Run ``fn`` on a worker, in the client's ``folder`` (:class:`_ClientFolder`): its
    result, the warnings it raised (re-raised on the client), this worker's pid and peak
    memory, and the seconds it took."""
    from mocapkit.core.thread_warnings import collected_warnings, every_warning_shown

    keep_freed_memory()
    t0 = time.perf_counter()
    # per thread: a worker may run several tasks at once (catch_warnings is process-wide);
    # every warning, each time: each task's go back to the client with it
    with (
        _CLIENT_FOLDER.inside(folder),
        every_warning_shown(),
        collected_warnings(forward=False) as caught,
    ):
        out = fn(shared, item) if has_shared else fn(item)
    ws = [(w.category, str(w.message)) for w in caught]
    return out, ws, os.getpid(), _peak_rss_bytes(), time.perf_counter() - t0


@dataclass
class RunStats:
    """What a runner measured over its jobs: items done, seconds spent in tasks, and the peak
    resident memory of each process that ran tasks (pid -> bytes; this process when
    in-process)."""

    tasks: int = 0
    task_seconds: float = 0.0
    peak_rss: dict[int, int] = field(default_factory=dict)

    @property
    def peak_rss_max(self) -> int:
        return max(self.peak_rss.values(), default=0)

    def note(self, pid: int, rss: int, seconds: float) -> None:
        self.tasks += 1
        self.task_seconds += seconds
        self.peak_rss[pid] = max(self.peak_rss.get(pid, 0), rss)


class Runner:
    """Runs a job's tasks: in-process (default), on a local cluster of ``workers`` processes,
    or on the cluster at ``scheduler``. Use as a context manager (a local cluster is started on
    entry and stopped on exit).

    Args:
        workers: N >= 1 worker processes of a local cluster on 127.0.0.1.
        scheduler: the address of a running scheduler (``tcp://127.0.0.1:8786``).
        threads_per_worker: threads of each local worker (BLAS and numba included); in-process,
            the number of threads that run tasks side by side (default 1: one after the other).
        timeout: seconds to wait for the scheduler or the local cluster to come up.
    """

    def __init__(
        self,
        workers: int | None = None,
        scheduler: str | None = None,
        *,
        threads_per_worker: int = 1,
        timeout: float = 60.0,
    ):
        if workers is not None and scheduler is not None:
            raise ValueError("give --workers or --scheduler, not both")
        if workers is not None and workers < 1:
            raise ValueError(f"--workers must be >= 1, got {workers}")
        self.workers = workers
        self.scheduler = scheduler
        self.threads_per_worker = int(threads_per_worker)
        self.timeout = float(timeout)
        self.cluster: Any = None
        self.client: Any = None
        self.stats = RunStats()

    # ------------------------------------------------------------------ lifecycle
    @property
    def mode(self) -> str:
        """One of "in-process", "local" or "remote"."""
        if self.scheduler is not None:
            return "remote"
        return "local" if self.workers is not None else "in-process"

    def describe(self) -> str:
        if self.mode == "in-process":
            return "in-process"
        if self.mode == "local":
            return f"local Dask cluster, {self.workers} worker process(es)"
        n = len(self.client.scheduler_info().get("workers", {})) if self.client else 0
        return f"Dask scheduler {self.scheduler}, {n} worker(s)"

    def __enter__(self) -> Runner:
        self.start()
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def start(self) -> None:
        if self.mode == "in-process" or self.client is not None:
            return
        try:
            import distributed
        except ImportError as e:  # pragma: no cover - a dependency
            raise ImportError(
                "running on Dask needs the 'distributed' package: pip install dask distributed"
            ) from e
        import logging

        if self.mode == "local":
            n = str(self.threads_per_worker)
            env = {k: n for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                                  "NUMBA_NUM_THREADS")}  # fmt: skip
            self.cluster = distributed.LocalCluster(
                n_workers=self.workers,
                threads_per_worker=self.threads_per_worker,
                processes=True,
                host="127.0.0.1",
                scheduler_port=0,
                dashboard_address=None,
                worker_dashboard_address=None,
                # the scheduler's HTTP routes (/health) start even without a dashboard, on 8787
                # by default: another program there made Dask warn "Port 8787 is already in use"
                scheduler_kwargs={"dashboard": False, "dashboard_address": "127.0.0.1:0"},
                silence_logs=logging.ERROR,
                env=env,
                timeout=self.timeout,
            )
            self.client = distributed.Client(self.cluster, timeout=self.timeout)
        else:
            try:
                self.client = distributed.Client(self.scheduler, timeout=self.timeout)
            except (OSError, TimeoutError) as e:
                raise JobError(
                    f"cannot reach the Dask scheduler at {self.scheduler}: "
                    + " ".join(str(e).split())
                ) from None
            if not self.client.scheduler_info().get("workers"):
                try:
                    self.client.wait_for_workers(1, timeout=self.timeout)
                except TimeoutError:
                    self.close()
                    raise JobError(
                        f"the Dask scheduler at {self.scheduler} has no workers "
                        f"(waited {self.timeout:g} s)"
                    ) from None

    def close(self) -> None:
        client, cluster = self.client, self.cluster
        self.client = self.cluster = None
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if client is not None:
                with contextlib.suppress(Exception):  # closing; the job's result stands
                    client.close(timeout=10)
            if cluster is not None:
                with contextlib.suppress(Exception):
                    cluster.close(timeout=10)

    def worker_pids(self) -> dict[str, int]:
        """Worker address -> pid (empty in-process)."""
        if self.client is None:
            return {}
        return dict(self.client.run(os.getpid))

    # ------------------------------------------------------------------ mapping
    def map(
        self,
        fn: Callable[..., Any],
        items: Sequence[Any],
        *,
        shared: Any = None,
        progress: Progress | None = None,
        name: str | None = None,
    ) -> list[Any]:
        """``[fn(item) for item in items]`` (or ``fn(shared, item)`` when ``shared`` is given:
        sent once to every worker), in input order."""
        return list(self.imap(fn, items, shared=shared, progress=progress, name=name))

    def imap(
        self,
        fn: Callable[..., Any],
        items: Iterable[Any],
        *,
        shared: Any = None,
        progress: Progress | None = None,
        name: str | None = None,
    ) -> Iterator[Any]:
        """Like :meth:`map`, yielding each result in input order as soon as it and those before
        it are done; ``progress(done, total)`` after each finished task."""
        items = list(items)
        total = len(items)
        has_shared = shared is not None
        if progress is not None:
            progress(0, total)
        if self.client is None and self.mode == "in-process":
            # every warning every time, as on a worker: a task's report is the same either way;
            # per task, not across the yields (the caller's code runs between them)
            from mocapkit.core.thread_warnings import every_warning_shown

            def task(item: Any) -> Any:
                with every_warning_shown():
                    return fn(shared, item) if has_shared else fn(item)

            if self.threads_per_worker > 1:
                yield from self._imap_threads(task, items, None, False, progress)
                return
            for n, item in enumerate(items):
                t0 = time.perf_counter()
                out = task(item)
                self.stats.note(os.getpid(), _peak_rss_bytes(), time.perf_counter() - t0)
                if progress is not None:
                    progress(n + 1, total)
                yield out
            return
        if self.client is None:
            self.start()
        yield from self._imap_dask(fn, items, shared, has_shared, progress, name)

    def _imap_threads(
        self,
        fn: Callable[..., Any],
        items: list[Any],
        shared: Any,
        has_shared: bool,
        progress: Progress | None,
    ) -> Iterator[Any]:
        from mocapkit.core.pool import ordered_imap

        def call(item: Any) -> tuple[Any, float]:
            t0 = time.perf_counter()
            out = fn(shared, item) if has_shared else fn(item)
            return out, time.perf_counter() - t0

        for out, seconds in ordered_imap(call, items, self.threads_per_worker, progress):
            self.stats.note(os.getpid(), _peak_rss_bytes(), seconds)
            yield out

    def _imap_dask(
        self,
        fn: Callable[..., Any],
        items: list[Any],
        shared: Any,
        has_shared: bool,
        progress: Progress | None,
        name: str | None,
    ) -> Iterator[Any]:
        import uuid

        from distributed import as_completed

        client = self.client
        total = len(items)
        if total == 0:
            return
        sh = client.scatter(shared, broadcast=True, hash=False) if has_shared else None
        prefix = name or getattr(fn, "__name__", "task")
        tag = uuid.uuid4().hex[:8]
        futures = client.map(
            _call, [fn] * total, items, shared=sh, has_shared=has_shared, folder=os.getcwd(),
            key=[f"{prefix}-{tag}-{i}" for i in range(total)], pure=False,
        )  # fmt: skip
        index = {f.key: i for i, f in enumerate(futures)}
        done: dict[int, Any] = {}
        nxt = 0
        count = 0
        try:
            for fut in as_completed(futures):
                i = index[fut.key]
                try:
                    out, ws, pid, rss, secs = fut.result()
                except Exception as e:
                    raise self._job_error(e, items[i]) from None
                futures[i] = None  # type: ignore[call-overload]
                fut.release()
                self.stats.note(pid, rss, secs)
                for cat, msg in ws:
                    warnings.warn(msg, cat, stacklevel=2)
                done[i] = out
                count += 1
                if progress is not None:
                    progress(count, total)
                while nxt in done:
                    yield done.pop(nxt)
                    nxt += 1
        finally:
            pending = [f for f in futures if f is not None and not f.done()]
            if pending:
                client.cancel(pending)
            if sh is not None:
                client.cancel(sh)

    def _job_error(self, e: BaseException, item: Any) -> BaseException:
        from distributed.scheduler import KilledWorker

        what = item if isinstance(item, (str, os.PathLike)) else getattr(item, "name", None)
        where = f" while running {what}" if what is not None else ""
        if isinstance(e, KilledWorker):
            return JobError(
                f"a Dask worker died{where} more times than the scheduler allows "
                "(distributed.scheduler.allowed-failures); outputs written so far are complete "
                "and a rerun resumes from them"
            )
        if type(e).__module__.startswith(("distributed", "tornado", "asyncio")) or isinstance(
            e, (TimeoutError, ConnectionError)
        ):
            return JobError(
                f"the Dask cluster failed{where}: {type(e).__name__}: {' '.join(str(e).split())}"
            )
        return e
