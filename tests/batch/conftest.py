"""Fixtures for the library-job tests: a small generated library (with one broken take), a
local Dask cluster of 2 worker processes, and a `dask scheduler` + 2 `dask worker` processes,
all on 127.0.0.1 and always shut down."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mocapkit import datasets
from mocapkit.batch import Runner
from mocapkit.io import write_motion

KINDS = ("walk", "run", "wave", "idle")
WORKER_ENV = {k: "1" for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                               "NUMBA_NUM_THREADS")}  # fmt: skip


def make_library(root: Path, per_kind: int = 3, seconds: float = 3.0, broken: bool = True) -> Path:
    """``root/<kind>_<NNN>.bvh`` procedural takes (one skeleton, 30 fps) and a broken file."""
    root.mkdir(parents=True, exist_ok=True)
    for k, kind in enumerate(KINDS):
        for n in range(per_kind):
            m = datasets.procedural_motion(kind, seconds=seconds, seed=10 * k + n).motion
            write_motion(m, root / f"{kind}_{n:03d}.bvh")
    if broken:
        (root / "broken_000.bvh").write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0\n")
    return root


@pytest.fixture(scope="session")
def library(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return make_library(tmp_path_factory.mktemp("lib") / "lib")


@pytest.fixture(scope="session")
def clips(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A graph library: 8 good takes of 2 s."""
    return make_library(tmp_path_factory.mktemp("clips") / "clips", 2, 2.0, broken=False)


@pytest.fixture(scope="session")
def local_runner():
    """A local cluster: 2 worker processes of 1 thread on 127.0.0.1."""
    with Runner(workers=2, timeout=60) as r:
        r.client.wait_for_workers(2, timeout=60)
        yield r


def _dask_exe() -> str:
    exe = Path(sys.executable).parent / "dask"
    if not exe.exists():
        found = shutil.which("dask")
        if found is None:
            pytest.fail("the dask console script is not installed beside python")
        return found
    return str(exe)


def _stop(procs: list[subprocess.Popen]) -> None:
    for p in reversed(procs):
        if p.poll() is None:
            p.terminate()
    for p in reversed(procs):
        try:
            p.wait(timeout=15)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait(timeout=5)


@pytest.fixture(scope="session")
def scheduler_address(tmp_path_factory: pytest.TempPathFactory):
    """`dask scheduler` + 2 `dask worker` processes on 127.0.0.1; yields the address."""
    import json

    from distributed import Client

    tmp = tmp_path_factory.mktemp("dask")
    sched_file = tmp / "scheduler.json"
    env = {**os.environ, **WORKER_ENV}
    log = open(tmp / "dask.log", "w")  # noqa: SIM115 - closed below
    procs: list[subprocess.Popen] = []
    try:
        procs.append(
            subprocess.Popen(
                [
                    _dask_exe(),
                    "scheduler",
                    "--host",
                    "127.0.0.1",
                    "--port",
                    "0",
                    "--no-dashboard",
                    "--scheduler-file",
                    str(sched_file),
                ],
                stdout=log,
                stderr=subprocess.STDOUT,
                env=env,
            )
        )
        deadline = time.monotonic() + 60
        while not sched_file.exists() or not sched_file.read_text().strip():
            if time.monotonic() > deadline or procs[0].poll() is not None:
                pytest.fail(f"dask scheduler did not start: {(tmp / 'dask.log').read_text()}")
            time.sleep(0.2)
        address = json.loads(sched_file.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:"), address
        for _ in range(2):
            procs.append(
                subprocess.Popen(
                    [
                        _dask_exe(),
                        "worker",
                        address,
                        "--host",
                        "127.0.0.1",
                        "--nthreads",
                        "1",
                        "--nworkers",
                        "1",
                        "--no-dashboard",
                        "--memory-limit",
                        "0",
                    ],
                    stdout=log,
                    stderr=subprocess.STDOUT,
                    env=env,
                    cwd=tmp,  # not the tests' folder: relative paths must still mean the same
                )
            )
        with Client(address, timeout=30) as c:
            c.wait_for_workers(2, timeout=60)
        yield address
    finally:
        _stop(procs)
        log.close()


@pytest.fixture
def tree():
    return tree_bytes


def tree_bytes(root: Path, skip: tuple[str, ...] = (".mocapkit-manifest",)) -> dict[str, bytes]:
    """Every file under ``root`` (relative POSIX path -> bytes), skipping ``skip`` folders."""
    out = {}
    for p in sorted(root.rglob("*")):
        rel = p.relative_to(root)
        if p.is_file() and not any(part in skip for part in rel.parts):
            out[rel.as_posix()] = p.read_bytes()
    return out
