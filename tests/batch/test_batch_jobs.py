"""Library jobs give the same bytes in-process, on a local Dask cluster (2 worker processes)
and on a `dask scheduler` + 2 `dask worker` processes; a killed worker loses nothing; an
interrupted job resumes without redoing finished takes."""

from __future__ import annotations

import contextlib
import json
import os
import signal
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from mocapkit.batch import JobError, LibraryCleanConfig, Runner, clean_library, context_of
from mocapkit.cli import main
from mocapkit.cli.io_commands import info_item
from mocapkit.convert import convert_many
from mocapkit.graph.distance import tile_runner, tiled_local_minima
from mocapkit.graph.graph import build_graph
from mocapkit.io import read_motion, write_motion

CFG = LibraryCleanConfig(context_by="all", context_max=3)


def _takes(lib: Path) -> list[Path]:
    return sorted(p for p in lib.glob("*.bvh") if not p.name.startswith("broken"))


def _graph_json(path: Path) -> dict:
    g = json.loads(path.read_text())
    g.get("stats", {}).pop("tile_seconds", None)  # wall time, the one field that differs
    return g


@pytest.fixture(scope="session")
def reference(library, clips, tmp_path_factory):
    """Every job run in-process once: clean, convert, graph (and fine tile minima)."""
    out = tmp_path_factory.mktemp("ref")
    res = clean_library(library, out / "fixed", out / "reports", CFG)
    conv = convert_many(sorted(library.glob("*.bvh")), out / "conv", "bvh", fps=24.0)
    motions = [read_motion(p) for p in _takes(clips)]
    paths = [p.name for p in _takes(clips)]
    g, db, _ = build_graph(motions, paths=paths)
    g.save(out / "graph.json")
    mins = tiled_local_minima(db, 1, 16, np.float64, task_side=2)
    st = _stitch(library, out)
    return {"dir": out, "clean": res, "convert": conv, "db": db, "minima": mins,
            "motions": motions, "paths": paths, "stitch": st}  # fmt: skip


def _stitch(library: Path, out: Path, *runner: str) -> dict:
    """``mocapkit stitch`` of the first walk onto the library (broken take included), in shards
    of 32 takes; its JSON (wall time left out) and the stitched take's bytes."""
    data = sorted(library.glob("*.bvh"))
    query = library / "walk_000.bvh"
    out.mkdir(parents=True, exist_ok=True)
    r = CliRunner().invoke(main, ["stitch", str(query), *map(str, data), "--takeoff", "20:40",
                                  "--json", str(out / "st.json"), "--out", str(out / "st.bvh"),
                                  *runner])  # fmt: skip
    assert r.exit_code == 2, r.output  # the broken take; the stitch is written
    assert "left out of the library: " in r.output and "broken_000.bvh" in r.output
    js = json.loads((out / "st.json").read_text())
    js.pop("search_seconds")
    js.pop("output")
    return {"json": js, "bvh": (out / "st.bvh").read_bytes()}


def _same_minima(a, b) -> None:
    for k in ("i", "j", "cost"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k))
    assert a.pairs == b.pairs


def test_context_of_is_nearest_in_name_order():
    takes = ["a/x_001.bvh", "a/x_002.bvh", "a/x_003.bvh", "a/y_001.bvh", "b/x_001.bvh"]
    by_prefix = context_of(takes, "prefix", 1)
    assert by_prefix["a/x_002.bvh"] == ["a/x_001.bvh"]
    assert by_prefix["b/x_001.bvh"] == []  # alone in its folder
    assert context_of(takes, "folder", 8)["b/x_001.bvh"] == []
    assert context_of(takes, "all", 2)["a/x_003.bvh"] == ["a/x_002.bvh", "a/y_001.bvh"]


def test_prefix_context_widens_to_the_content_when_a_style_has_few_takes():
    """Bandai-1 has one take per content and style (dash_normal_001): its related takes are the
    other styles of the same content (dash_*), not none; a style with enough takes keeps its
    own; a name no prefix groups with three others falls back to its folder."""
    takes = [f"d/dash_{s}_001.bvh" for s in ("angry", "happy", "normal", "sad")]
    takes += [f"d/walk_normal_00{k}.bvh" for k in range(1, 6)] + ["d/walk_sad_001.bvh"]
    takes += ["d/walk-back_normal_001.bvh", "d/zz.bvh"]
    ctx = context_of(takes, "prefix", 8)
    assert ctx["d/dash_normal_001.bvh"] == [
        f"d/dash_{s}_001.bvh" for s in ("angry", "happy", "sad")
    ]
    assert ctx["d/walk_normal_003.bvh"] == [f"d/walk_normal_00{k}.bvh" for k in (1, 2, 4, 5)]
    # walk_sad's style has no other take: every walk_ take, never walk-back's
    assert ctx["d/walk_sad_001.bvh"] == [f"d/walk_normal_00{k}.bvh" for k in range(1, 6)]
    assert len(ctx["d/zz.bvh"]) == 8 and "d/zz.bvh" not in ctx["d/zz.bvh"]
    # a whole name is a prefix too: walk.bvh beside walk_1..3 is one of them
    odd = context_of(["e/walk.bvh", "e/walk_1.bvh", "e/walk_2.bvh", "e/walk_3.bvh", "e/z_1.bvh"],
                     "prefix", 8)  # fmt: skip
    assert odd["e/walk.bvh"] == ["e/walk_1.bvh", "e/walk_2.bvh", "e/walk_3.bvh"]
    assert odd["e/walk_2.bvh"] == ["e/walk.bvh", "e/walk_1.bvh", "e/walk_3.bvh"]


def test_in_process_reference(reference, library):
    res = reference["clean"]
    assert res.cleaned == len(res.records) - 1 == 12  # the broken take failed
    assert [r["take"] for r in res.failed] == ["broken_000.bvh"]
    summary = json.loads(res.summary_path.read_text())
    assert summary["failed"] == 1 and summary["errors"][0]["take"] == "broken_000.bvh"
    assert "broken_000.bvh" in summary["errors"][0]["error"]
    assert len(summary["ranking"]) == 12
    html = res.overview_path.read_text()
    assert html.count("<svg") == 12 and "broken_000.bvh" in html
    # flagged spans are start:stop (stop excluded), as segments' start and stop: their union
    for r in (r for r in res.records if "error" not in r):
        covered = np.zeros(r["frames"], bool)
        for seg in r["segments"]:
            covered[seg["start"] : seg["stop"]] = True
        spans = np.zeros(r["frames"], bool)
        for a, b in r["flagged_spans"]:
            spans[a:b] = True
        np.testing.assert_array_equal(spans, covered)
    assert any(r.get("flagged_spans") for r in res.records)
    assert len(reference["minima"].i) > 0
    assert reference["convert"].failed[0].source.name == "broken_000.bvh"


def test_local_cluster_same_bytes(reference, local_runner, library, tmp_path, tree):
    ref = reference["dir"]
    res = clean_library(library, tmp_path / "fixed", tmp_path / "reports", CFG,
                        runner=local_runner)  # fmt: skip
    assert res.cleaned == 12
    assert tree(tmp_path / "fixed") == tree(ref / "fixed")
    assert tree(tmp_path / "reports") == tree(ref / "reports")
    conv = convert_many(sorted(library.glob("*.bvh")), tmp_path / "conv", "bvh", fps=24.0,
                        runner=local_runner)  # fmt: skip
    assert [i.to_json()["source"] for i in conv.items] == [
        i.to_json()["source"] for i in reference["convert"].items
    ]
    assert [i.error for i in conv.items] == [i.error for i in reference["convert"].items]
    assert tree(tmp_path / "conv") == tree(ref / "conv")
    mins = tiled_local_minima(reference["db"], 1, 16, np.float64, task_side=2,
                              runner=local_runner)  # fmt: skip
    _same_minima(mins, reference["minima"])
    with tile_runner(local_runner):
        g, _, _ = build_graph(reference["motions"], paths=reference["paths"])
    g.save(tmp_path / "graph.json")
    assert _graph_json(tmp_path / "graph.json") == _graph_json(ref / "graph.json")
    assert len(local_runner.stats.peak_rss) == 2  # both workers ran tasks
    from mocapkit.stitch.library import stitch_library

    data = sorted(library.glob("*.bvh"))
    q = read_motion(library / "walk_000.bvh")
    here = stitch_library(q, "20:40", data, shard_files=3)
    there = stitch_library(q, "20:40", data, shard_files=3, runner=local_runner)
    assert here.transition.as_dict() == there.transition.as_dict()
    np.testing.assert_array_equal(here.motion.rotations, there.motion.rotations)


def test_scheduler_processes_same_bytes(reference, scheduler_address, library, clips, tmp_path,
                                        tree):  # fmt: skip
    ref = reference["dir"]
    cli = CliRunner()
    r = cli.invoke(main, ["clean", str(library), "--out-dir", str(tmp_path / "fixed"),
                          "--report-dir", str(tmp_path / "reports"), "--context-by", "all",
                          "--context-max", "3", "--scheduler", scheduler_address])  # fmt: skip
    assert r.exit_code == 2, r.output  # the broken take
    assert "broken_000.bvh" in r.output and "13 takes: 12 cleaned" in r.output
    assert tree(tmp_path / "fixed") == tree(ref / "fixed")
    assert tree(tmp_path / "reports") == tree(ref / "reports")
    r = cli.invoke(main, ["convert", str(library), "--out-dir", str(tmp_path / "conv"), "--to",
                          "bvh", "--fps", "24", "--scheduler", scheduler_address])  # fmt: skip
    assert r.exit_code == 2 and "converted 12 of 13" in r.output, r.output
    assert tree(tmp_path / "conv") == tree(ref / "conv")
    r = cli.invoke(main, ["graph", "build", *map(str, _takes(clips)), "--out",
                          str(tmp_path / "graph.json"), "--quiet", "--scheduler",
                          scheduler_address])  # fmt: skip
    assert r.exit_code == 0, r.output
    assert "memory per worker" in r.output
    g_in = cli.invoke(main, ["graph", "build", *map(str, _takes(clips)), "--out",
                             str(tmp_path / "graph_in.json"), "--quiet"])  # fmt: skip
    assert g_in.exit_code == 0, g_in.output
    assert _graph_json(tmp_path / "graph.json") == _graph_json(tmp_path / "graph_in.json")
    from mocapkit.graph.distance import tiled_local_minima as tlm

    with Runner(scheduler=scheduler_address) as runner:
        mins = tlm(reference["db"], 1, 16, np.float64, task_side=2, runner=runner)
        infos = runner.map(len, ["ab", "c"])
    _same_minima(mins, reference["minima"])
    assert infos == [2, 1]
    assert (
        _stitch(library, tmp_path / "st", "--scheduler", scheduler_address) == (reference["stitch"])
    )


def test_relative_paths_mean_the_clients_files_on_workers_started_elsewhere(
    scheduler_address, library, tmp_path, monkeypatch
):
    """Newcomer report: with `dask worker` started from another folder, `clean lib/ --out-dir
    fixed/ --scheduler ...` failed every take ("cannot read file") and, with the library given
    absolute, wrote the repaired takes to the workers' folder."""
    lib = tmp_path / "lib"
    lib.mkdir()
    for p in _takes(library)[1:4]:
        (lib / p.name).write_bytes(p.read_bytes())
    monkeypatch.chdir(tmp_path)
    cli = CliRunner()
    r = cli.invoke(main, ["clean", "lib", "--out-dir", "fixed", "--report-dir", "rep",
                          "--scheduler", scheduler_address])  # fmt: skip
    assert r.exit_code == 0, r.output
    assert sorted(p.name for p in (tmp_path / "fixed").glob("*.bvh")) == sorted(
        p.name for p in lib.glob("*.bvh")
    )
    assert len(list((tmp_path / "rep" / "takes").glob("*.json"))) == 3
    r = cli.invoke(main, ["info", "--json", "lib", "--scheduler", scheduler_address])
    assert r.exit_code == 0 and len(json.loads(r.stdout)) == 3, r.output


def test_a_failed_take_is_tried_again_and_colliding_outputs_are_refused(
    library, tmp_path, monkeypatch
):
    """Newcomer report: a take that failed for a reason outside its file (its ASF not beside
    it yet) stayed failed on every rerun, as its manifest entry vouched for the failure; and
    03_02.amc and 03_02.bvh wrote the same repaired take and report, each over the other."""
    import mocapkit.clean

    lib = tmp_path / "lib"
    lib.mkdir()
    takes = _takes(library)[1:3]
    for p in takes:
        (lib / p.name).write_bytes(p.read_bytes())
    real = mocapkit.clean.run
    calls = {"n": 0}

    def fails_once(*args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 1:
            raise ValueError("not yet")
        return real(*args, **kwargs)

    monkeypatch.setattr(mocapkit.clean, "run", fails_once)
    first = clean_library(lib, tmp_path / "fixed", tmp_path / "rep", CFG)
    assert (first.cleaned, len(first.failed)) == (1, 1)
    again = clean_library(lib, tmp_path / "fixed", tmp_path / "rep", CFG)
    assert (again.resumed, again.cleaned, len(again.failed)) == (1, 1, 0)
    # the same name with another extension: the first in name order is cleaned, the other
    # refused in one line, and nothing is overwritten
    write_motion(read_motion(takes[0]), lib / (takes[0].stem + ".npz"))
    both = clean_library(lib, tmp_path / "fixed", tmp_path / "rep", CFG)
    (bad,) = both.failed
    assert bad["take"].endswith(".npz") and "rename one of them" in bad["error"]
    assert both.cleaned + both.resumed == 2  # (the .npz joined the others' context)


def test_info_folder_same_json_on_cluster(scheduler_address, library):
    cli = CliRunner()
    a = cli.invoke(main, ["info", "--json", str(library)])
    b = cli.invoke(main, ["info", "--json", str(library), "--scheduler", scheduler_address])
    assert a.exit_code == b.exit_code == 2
    assert a.stdout == b.stdout and json.loads(a.stdout)[0]["path"].endswith("broken_000.bvh")


def test_worker_killed_mid_job(reference, local_runner, library, tmp_path, tree):
    """SIGKILL one worker process while the library clean runs: the nanny restarts it, the
    scheduler reruns the lost tasks, the job completes with the same bytes."""
    client = local_runner.client
    killed: list[int] = []

    def progress(done: int, total: int) -> None:
        if done == 2 and not killed:
            busy = [w for w, keys in client.processing().items() if keys]
            pids = local_runner.worker_pids()
            target = busy[0] if busy else next(iter(pids))
            killed.append(pids[target])
            os.kill(pids[target], signal.SIGKILL)

    res = clean_library(library, tmp_path / "fixed", tmp_path / "reports", CFG,
                        runner=local_runner, progress=progress)  # fmt: skip
    assert killed, "no worker was killed"
    assert res.cleaned == 12
    assert tree(tmp_path / "fixed") == tree(reference["dir"] / "fixed")
    assert tree(tmp_path / "reports") == tree(reference["dir"] / "reports")
    assert not [p for p in tmp_path.rglob("*.tmp")], "a killed write's temporary file is left"
    client.wait_for_workers(2, timeout=60)
    assert killed[0] not in local_runner.worker_pids().values()


def test_interrupted_job_resumes(library, tmp_path, tree, reference, monkeypatch):
    seen: list[str] = []

    def stop_after_four(r: dict) -> None:
        seen.append(r["take"])
        if len(seen) == 4:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        clean_library(library, tmp_path / "fixed", tmp_path / "reports", CFG,
                      on_take=stop_after_four)  # fmt: skip
    res = clean_library(library, tmp_path / "fixed", tmp_path / "reports", CFG)
    assert (res.resumed, res.cleaned, len(res.failed)) == (3, 9, 1)  # broken_000 came first
    assert tree(tmp_path / "fixed") == tree(reference["dir"] / "fixed")
    assert tree(tmp_path / "reports") == tree(reference["dir"] / "reports")
    monkeypatch.chdir(tmp_path)  # the same folders spelled another way
    again = clean_library(os.path.relpath(library), "fixed", "./reports/", CFG)
    assert (again.resumed, again.cleaned, len(again.failed)) == (12, 0, 1)


def test_changed_input_or_output_is_redone(library, tmp_path, tmp_path_factory):
    lib = tmp_path_factory.mktemp("lib2") / "lib"
    lib.mkdir()
    for p in _takes(library)[:6]:
        (lib / p.name).write_bytes(p.read_bytes())
    cfg = LibraryCleanConfig(context_by="prefix", context_max=2)
    first = clean_library(lib, tmp_path / "f", tmp_path / "r", cfg)
    assert first.cleaned == 6
    # idle_000's bytes change: it and the takes whose context holds it are redone
    victim = lib / "idle_000.bvh"
    victim.write_bytes(victim.read_bytes().replace(b"Frame Time", b"Frame  Time", 1))
    ctx = context_of([p.name for p in sorted(lib.glob("*.bvh"))], "prefix", 2)
    expect = 1 + sum("idle_000.bvh" in c for c in ctx.values())
    again = clean_library(lib, tmp_path / "f", tmp_path / "r", cfg)
    assert again.cleaned == expect
    # an output removed or corrupted is redone; a changed setting redoes everything
    (tmp_path / "f" / "run_001.bvh").write_text("corrupt")
    assert clean_library(lib, tmp_path / "f", tmp_path / "r", cfg).cleaned == 1
    other = LibraryCleanConfig(context_by="prefix", context_max=1)
    assert clean_library(lib, tmp_path / "f", tmp_path / "r", other).cleaned == 6


def test_reports_alone_then_with_repaired_takes(library, tmp_path, reference, tree):
    """Without out_dir only the reports are written (the same as with it, less the repaired
    take's name); a later run with out_dir redoes the takes, to write what is missing."""
    alone = clean_library(library, None, tmp_path / "r", CFG)
    assert (alone.cleaned, len(alone.failed)) == (12, 1)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r"]
    ref = json.loads((reference["dir"] / "reports" / "summary.json").read_text())
    got = json.loads((tmp_path / "r" / "summary.json").read_text())
    for a, b in zip(ref["records"], got["records"], strict=True):
        assert b.get("output") is None
        a.pop("output", None), b.pop("output", None)
        assert a == b
    both = clean_library(library, tmp_path / "f", tmp_path / "r", CFG)
    assert both.cleaned == 12
    assert tree(tmp_path / "f") == tree(reference["dir"] / "fixed")


def test_output_inside_library_refused(library):
    with pytest.raises(ValueError, match="inside the library"):
        clean_library(library, library / "fixed", library.parent / "r", CFG)


def test_unreachable_scheduler_is_one_line():
    with pytest.raises(JobError, match=r"cannot reach the Dask scheduler at tcp://127\.0\.0\.1:9"):
        Runner(scheduler="tcp://127.0.0.1:9", timeout=2).start()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--out", "x.bvh"], "is a folder: --out works on one take"),
        (["--out-dir", "F"], "give --report-dir DIR (and --out-dir DIR for the repaired takes)"),
        (["--out-dir", "F", "--report-dir", "R", "--explain", "Hips:3"], "--explain works on one"),
    ],
)
def test_clean_folder_mode_misuse_is_one_line(library, tmp_path, args, message):
    r = CliRunner().invoke(main, ["clean", str(library), *args])
    assert r.exit_code == 2 and message in r.output, r.output
    assert len(r.output.strip().splitlines()) == 1 and "Traceback" not in r.output


def test_clean_file_refuses_folder_options(library, tmp_path):
    take = _takes(library)[0]
    r = CliRunner().invoke(main, ["clean", str(take), "--out-dir", str(tmp_path), "--workers", "2"])
    assert r.exit_code == 2 and "--out-dir, --workers: only for a folder of takes" in r.output
    assert not any(tmp_path.iterdir())


def test_folder_convert_resumes(library, tmp_path, tree):
    """A rerun of a folder convert skips what is complete and unchanged; a changed source, a
    removed output or other options are converted again."""
    import shutil

    lib = tmp_path / "lib"
    shutil.copytree(library, lib)
    out = tmp_path / "out"
    srcs = sorted(lib.glob("*.bvh"))
    first = convert_many(srcs, out, "bvh", fps=24.0)
    assert first.resumed == 0 and len(first.failed) == 1
    before = tree(out)
    again = convert_many(srcs, out, "bvh", fps=24.0)
    assert again.resumed == 12 and [i.error for i in again.failed] == [
        i.error for i in first.failed
    ]
    assert [i.to_json() for i in again.items] == [i.to_json() for i in first.items]
    walk = lib / "walk_001.bvh"
    walk.write_text(walk.read_text().replace("Frame Time:", "Frame Time: ", 1))
    (out / "run_000.bvh").unlink()
    third = convert_many(srcs, out, "bvh", fps=24.0)
    redone = sorted(i.source.name for i in third.items if i.ok and not i.resumed)
    assert redone == ["run_000.bvh", "walk_001.bvh"] and third.resumed == 10
    assert tree(out) == before
    spelled = [os.path.relpath(p) for p in srcs]
    assert convert_many(spelled, os.path.relpath(out) + "/", "bvh", fps=24.0).resumed == 12
    assert convert_many(srcs, out, "bvh", fps=30.0).resumed == 0
    args = ["convert", str(lib), "--out-dir", str(out), "--to", "bvh", "--fps", "30"]
    r = CliRunner().invoke(main, args)
    assert "converted 12 of 13 inputs" in r.output and "already complete" not in r.output
    r = CliRunner().invoke(main, args)
    assert "converted 12 of 13 inputs" in r.output and "(12 already complete and unchanged)" in (
        r.output
    )
    assert r.output.count("wrote ") == 0 and r.exit_code == 2  # the broken take, again


def test_workers_reuse_freed_memory(local_runner, scheduler_address):
    """Dask's nanny sets MALLOC_TRIM_THRESHOLD_, which turns off glibc's adaptive mmap
    threshold: every 4 MiB temporary is mapped and faulted in afresh (1,024 faults each; tile
    tasks ran 1.4x slower). Tasks run by mocapkit's runner reuse freed memory, on a local
    cluster and on workers started with plain `dask worker`."""

    def _page_faults(_: int) -> int:  # local: sent by value to the `dask worker` processes
        """Minor page faults of 100 allocations of a 4 MiB array (each freed before the
        next)."""
        import resource

        import numpy as np

        np.ones(1 << 19)
        f0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
        for _ in range(100):
            a = np.ones(1 << 19)
            del a
        return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0

    assert _page_faults(0) < 5_000  # this process: glibc adapts
    for runner in (local_runner, Runner(scheduler=scheduler_address)):
        with contextlib.ExitStack() as stack:
            if runner is not local_runner:
                stack.enter_context(runner)
            assert set(runner.client.run(os.environ.get, "MALLOC_TRIM_THRESHOLD_").values()) == {
                "65536"
            }  # what the nanny set
            assert max(runner.map(_page_faults, [0, 1, 2, 3])) < 5_000


def test_tasks_run_in_the_clients_folder_one_folder_at_a_time(tmp_path, monkeypatch):
    """The worker-side guard of the folder: a task wanting a folder the worker lacks waits for
    tasks in another folder and runs in the worker's own; a worker whose own folder vanished
    does not hang (review of the first version)."""
    import threading
    import time

    from mocapkit.batch.runner import _ClientFolder

    cf = _ClientFolder()
    a, home = tmp_path / "a", tmp_path / "home"
    a.mkdir()
    home.mkdir()
    monkeypatch.chdir(home)
    seen: dict[str, str] = {}

    def task(name: str, folder: str, hold: float) -> None:
        with cf.inside(folder):
            seen[name] = os.getcwd()
            time.sleep(hold)

    t1 = threading.Thread(target=task, args=("a", str(a), 0.3))
    t1.start()
    time.sleep(0.05)
    t2 = threading.Thread(target=task, args=("missing", str(tmp_path / "nope"), 0.0))
    t2.start()
    t1.join(5)
    t2.join(5)
    assert seen == {"a": str(a), "missing": str(home)} and os.getcwd() == str(home)
    gone = tmp_path / "gone"
    gone.mkdir()
    monkeypatch.chdir(gone)
    t3 = threading.Thread(target=task, args=("b", str(a), 0.2))
    t3.start()
    time.sleep(0.05)
    gone.rmdir()
    t4 = threading.Thread(target=task, args=("c", str(home), 0.0))
    t4.start()
    t3.join(5)
    t4.join(5)
    assert not t3.is_alive() and not t4.is_alive() and seen["c"] == str(home)
    os.chdir(home)


def _warns_three(i: int) -> int:
    """A task that warns three messages of its own, pausing between them so that a worker's
    threads interleave."""
    import time
    import warnings

    for k in range(3):
        time.sleep(0.01 * ((7 * i + k) % 5))
        warnings.warn(f"task {i} warning {k}", UserWarning, stacklevel=1)
    return i


def test_each_tasks_warnings_reach_the_client_and_its_own_report_on_a_threaded_worker(
    tmp_path,
):
    """A worker with several threads runs several tasks at once. The per-task capture was
    ``warnings.catch_warnings``, which is process-wide: tasks restored each other's, so some
    warnings went to the worker's standard error and never to the client (40 tasks of three
    warnings on 4 threads: 14 of 120 lost), and one take's could land in another's report.
    Now each thread's are collected apart: every warning comes back once, each take's report
    holds its own repair and no other take's, and so does each file's `info` JSON (reviewer:
    info still caught per task process-wide)."""
    import warnings

    from mocapkit import datasets

    lib = tmp_path / "lib"
    lib.mkdir()
    lines = write_motion(datasets.procedural_motion("walk", 3.0, seed=1).motion,
                         tmp_path / "w.bvh").read_text().splitlines(keepends=True)  # fmt: skip
    at = lines.index("MOTION\n") + 3
    for n in range(8):  # a blank row at a line of its own in each take: one repair each
        row = at + 5 * n
        (lib / f"take_{n}.bvh").write_text("".join([*lines[:row], "\n", *lines[row:]]))
    cfg = LibraryCleanConfig(context_max=0, lenient=True)
    with (
        Runner(workers=1, threads_per_worker=4) as runner,
        warnings.catch_warnings(record=True) as caught,
    ):
        warnings.simplefilter("always")
        runner.map(_warns_three, list(range(40)))
        clean_library(lib, None, tmp_path / "rep", cfg, runner=runner)
        infos = runner.map(
            info_item, [(p.name, p, None, None, None, True) for p in sorted(lib.glob("*.bvh"))]
        )
    said = [str(w.message) for w in caught]
    tasks = [m for m in said if m.startswith("task ")]
    assert sorted(tasks) == sorted(f"task {i} warning {k}" for i in range(40) for k in range(3))
    for n in range(8):
        own = json.loads((tmp_path / "rep" / "takes" / f"take_{n}.json").read_text())["warnings"]
        assert len(own) == 1 and f"take_{n}.bvh:{at + 5 * n + 1}: " in own[0], own
        assert sum(f"take_{n}.bvh:" in m for m in said) == 2  # cleaning it, and info
        assert len(infos[n]["warnings"]) == 1 and f"take_{n}.bvh:" in infos[n]["warnings"][0]
    # in-process under Python's default filters (which show a warning once per line): the
    # same reports, byte for byte (reviewer: a repeated warning was missing in-process)
    with warnings.catch_warnings():
        warnings.resetwarnings()
        warnings.simplefilter("default")
        clean_library(lib, None, tmp_path / "here", cfg)
    for n in range(8):
        name = f"takes/take_{n}.json"
        assert (tmp_path / "here" / name).read_bytes() == (tmp_path / "rep" / name).read_bytes()
