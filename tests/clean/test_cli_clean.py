"""``mocapkit clean`` / ``mocapkit reconstruct`` / the demo step, in-process."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from mocapkit import datasets
from mocapkit.clean import inject
from mocapkit.cli import main
from mocapkit.io import read_motion, write_motion


def run(*args: str):
    res = CliRunner().invoke(main, list(args))
    return res.exit_code, res.stdout, res.stderr


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("clean")
    walk = datasets.procedural_motion("walk", seconds=5.0, seed=7).motion
    names = list(walk.skeleton.names)
    inj = inject(walk, "flip", names.index("LeftForeArm"), np.random.default_rng(0), start=60)
    ctx_dir = d / "ctx"
    ctx_dir.mkdir()
    for s in (8, 9):
        m = datasets.procedural_motion("walk", seconds=4.0, seed=s).motion
        write_motion(m, ctx_dir / f"walk{s}.bvh")
    return {
        "dir": d,
        "input": write_motion(inj.motion, d / "take.bvh"),
        "clean": write_motion(walk, d / "clean.bvh"),
        "ctx": ctx_dir,
        "frames": np.flatnonzero(inj.frames),
    }


def test_clean_writes_report_mdm_plot_and_repair(files) -> None:
    d = files["dir"]
    out, rep, mdm, png = d / "fixed.bvh", d / "r.json", d / "m.npy", d / "m.png"
    code, _, stderr = run(
        "clean", str(files["input"]), "--context", str(files["ctx"]), "--out", str(out),
        "--report", str(rep), "--mdm", str(mdm), "--plot", str(png), "--quiet",
    )  # fmt: skip
    assert code == 0, stderr
    report = json.loads(rep.read_text())
    take = read_motion(files["input"])
    for key in ("input", "fps", "frames", "joints", "threshold", "segments", "repaired_cells"):
        assert key in report
    assert report["frames"] == take.num_frames
    assert report["joints"] == list(take.skeleton.names)
    assert report["threshold"] == 0.5
    seg = [s for s in report["segments"] if s["joint"] == "LeftForeArm"]
    fr = files["frames"]
    assert any(s["start"] <= fr.min() and s["end"] >= fr.max() for s in seg)
    for s in report["segments"]:
        assert {"joint", "start", "end", "peak"} <= set(s)
    arr = np.load(mdm)
    assert arr.dtype == np.float32 and arr.shape == (take.num_frames, take.num_joints)
    assert arr.min() >= 0.0 and arr.max() <= 1.0
    assert png.read_bytes()[:4] == b"\x89PNG"
    fixed = read_motion(out)
    assert fixed.num_frames == take.num_frames
    assert report["repaired_cells"] > 0


def test_clean_without_out_writes_only_the_report(files, tmp_path) -> None:
    rep = tmp_path / "only.json"
    code, stdout, _ = run("clean", str(files["input"]), "--report", str(rep))
    assert code == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["only.json"]
    assert "LeftForeArm" in stdout
    # ranges printed as the CLI takes them, A:B with B excluded; the report has both ends
    for s in json.loads(rep.read_text())["segments"][:50]:  # the first 50 are printed
        assert s["stop"] == s["end"] + 1
        assert f"frames {s['start']:5d}:{s['stop']:<5d}" in stdout


def test_clean_report_on_standard_output_is_json_alone(files, tmp_path) -> None:
    """``--report -`` gives a script the JSON alone on stdout (the summary goes to stderr);
    a stream or a pipe given as a file name is refused, not replaced."""
    code, stdout, stderr = run("clean", str(files["input"]), "--report", "-")
    assert code == 0
    rep = json.loads(stdout)
    assert rep["flagged_cells"] > 0 and "LeftForeArm" in stderr
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    code, stdout, stderr = run("clean", str(files["input"]), "--report", str(fifo))
    assert code == 2 and fifo.is_fifo()
    assert stderr.strip() == (
        f"mocapkit: error: {fifo}: is a pipe, not a file; give a file name (or '-' where the "
        "option takes it)"
    )


def test_clean_json_prints_the_report_and_errors_as_json(files, tmp_path) -> None:
    """``--json -`` (as stitch and inbetween spell it; ``--report`` is the same option) prints
    the report alone on stdout, and a failure, a mistyped option too, as ``{"error": LINE}``
    there: a script reading stdout always gets JSON."""
    code, stdout, stderr = run("clean", str(files["input"]), "--json", "-")
    assert code == 0
    assert json.loads(stdout)["flagged_cells"] > 0 and "LeftForeArm" in stderr
    # with --out, how each segment was repaired: the injected flip turned back, in the report
    # and on its summary line (newcomer: the report did not say)
    out = tmp_path / "fixed.bvh"
    code, stdout, stderr = run("clean", str(files["input"]), "--json", "-", "--out", str(out))
    rep = json.loads(stdout)
    arm = [s for s in rep["segments"] if s["joint"] == "LeftForeArm"]
    assert arm and arm[0]["repair"].get("turned back", 0) >= 3
    assert set(rep["repair_methods_are"]) >= {"median", "turned back", "reflected"}
    for s in rep["segments"]:
        assert sum(s["repair"].values()) == s["stop"] - s["start"]
    assert "LeftForeArm" in stderr and "repaired: turned back" in stderr
    for args in (
        [str(tmp_path / "missing.bvh"), "--json", "-"],
        [str(files["input"]), "--json", "-", "--explain", "Nope:3"],
        [str(files["input"]), "--json", "-", "--bogus"],
        [str(files["input"]), "--report", "-", "--bogus"],  # the same option under its old name
        [str(files["input"]), "--report=-", "--threshold", "abc"],
    ):
        code, stdout, stderr = run("clean", *args)
        assert code == 2
        err = json.loads(stdout)["error"]
        assert err and "\n" not in err and err in stderr
    out = tmp_path / "r.json"
    code, _, _ = run("clean", str(files["input"]), "--json", str(out), "--quiet")
    assert code == 0 and json.loads(out.read_text())["flagged_cells"] > 0


def test_clean_report_carries_what_standard_error_warns(files, tmp_path) -> None:
    """A row repaired on reading (--lenient) is said in the JSON report as on standard error:
    a script that reads only the report learns the take was not read as written."""
    lines = Path(files["clean"]).read_text().splitlines(keepends=True)
    at = lines.index("MOTION\n") + 10
    blank = tmp_path / "blank.bvh"
    blank.write_text("".join([*lines[:at], "\n", *lines[at:]]))
    code, stdout, stderr = run("clean", str(blank), "--lenient", "--json", "-")
    assert code == 0, stderr
    said = json.loads(stdout)["warnings"]
    assert said == [f"repaired: {blank}:{at + 1}: skipped blank line(s) inside the motion data"]
    assert f"mocapkit: {said[0]}" in stderr
    code, stdout, _ = run("clean", str(files["clean"]), "--json", "-")
    assert code == 0 and json.loads(stdout)["warnings"] == []


def test_folder_mode_reports_carry_their_takes_warnings(files, tmp_path) -> None:
    """Folder mode: each take's report carries what was warned reading it, as a single take's
    report does (a blank row skipped with --lenient), and standard error still says it once;
    what reading a context take warned is that take's, and a context take that could not be
    read is named in the report."""
    lib = tmp_path / "lib"
    lib.mkdir()
    lines = Path(files["clean"]).read_text().splitlines(keepends=True)
    at = lines.index("MOTION\n") + 10
    (lib / "a_blank.bvh").write_text("".join([*lines[:at], "\n", *lines[at:]]))
    (lib / "b_plain.bvh").write_text("".join(lines))
    code, _, stderr = run("clean", str(lib), "--report-dir", str(tmp_path / "rep"), "--lenient")
    assert code == 0, stderr
    said = json.loads((tmp_path / "rep" / "takes" / "a_blank.json").read_text())["warnings"]
    assert len(said) == 1 and said[0].startswith("repaired: ") and f":{at + 1}: " in said[0]
    assert said[0] in stderr and stderr.count(said[0]) == 1
    # newcomer: the other take's report listed what reading its context (the first take)
    # repaired, unlabelled; that is the first take's, and its own report has it
    other = json.loads((tmp_path / "rep" / "takes" / "b_plain.json").read_text())
    assert other["warnings"] == [] and other["context"] == ["a_blank.bvh"]
    assert other["context_skipped"] == []
    # read strictly, the blank row fails the first take; the other's report says its context
    # lost it (newcomer: it shrank with no word)
    code, _, stderr = run("clean", str(lib), "--report-dir", str(tmp_path / "strict"))
    assert code == 2 and "a_blank.bvh" in stderr
    other = json.loads((tmp_path / "strict" / "takes" / "b_plain.json").read_text())
    assert other["context"] == [] and "a_blank.bvh" in other["context_skipped"][0]


def test_clean_baseline_and_errors(files, tmp_path) -> None:
    rep = tmp_path / "b.json"
    code, _, stderr = run(
        "clean", str(files["input"]), "--context", str(files["ctx"]), "--baseline", "c",
        "--report", str(rep), "--quiet",
    )  # fmt: skip
    assert code == 0, stderr
    assert json.loads(rep.read_text())["method"] == "baseline c"
    code, _, stderr = run("clean", str(files["input"]), "--baseline", "a")
    assert code == 2 and "--context" in stderr
    code, _, stderr = run("clean", str(files["input"]), "--out", str(files["input"]))
    assert code == 2 and "overwrite" in stderr
    code, _, stderr = run("clean", str(files["input"]), "--context", str(tmp_path / "nope"))
    assert code == 2 and "no such" in stderr


def test_reconstruct_command(files, tmp_path) -> None:
    full = read_motion(files["clean"])
    keep = ["Neck", "LeftArm", "RightArm", "LeftForeArm", "RightForeArm", "LeftUpLeg",
            "RightUpLeg", "LeftLeg", "RightLeg"]  # fmt: skip
    out = tmp_path / "full.bvh"
    code, _, stderr = run(
        "reconstruct", str(files["clean"]), "--database", str(files["ctx"]), "--out", str(out),
        "--joints", ",".join(keep),
    )  # fmt: skip
    assert code == 0, stderr
    rec = read_motion(out)
    assert rec.num_frames == full.num_frames and rec.num_joints == full.num_joints


def test_demo_includes_cleaning(tmp_path) -> None:
    from mocapkit.cli.clean_commands import cleaning_step
    from mocapkit.cli.demo import DEMO_STEPS

    assert any(rank == 30 and step is cleaning_step for rank, _, step in DEMO_STEPS)
    from click import Command

    res = CliRunner().invoke(Command("x", callback=lambda: cleaning_step(tmp_path)), [])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "humanoid_walk_repaired.bvh").exists()
    assert (tmp_path / "humanoid_walk_mdm.png").exists()
    assert "recall 1.00" in res.output


def test_clean_with_contact(files, tmp_path) -> None:
    out = tmp_path / "c.bvh"
    code, _, stderr = run(
        "clean", str(files["input"]), "--out", str(out), "--contact", "LeftHand:55-70", "--quiet",
    )  # fmt: skip
    assert code == 0, stderr
    assert read_motion(out).num_frames == read_motion(files["input"]).num_frames
    code, _, stderr = run("clean", str(files["input"]), "--contact", "Nope:1-2")
    assert code == 2 and "Nope" in stderr
    code, _, stderr = run("clean", str(files["input"]), "--contact", "LeftHand:5-2000")
    assert code == 2
    # the one range syntax: frames 55..70 are 55:71 (end excluded), or the same in seconds
    fps = read_motion(files["input"]).fps
    for spec in ("LeftHand@55:71", f"LeftHand@{55 / fps!r}s:{71 / fps!r}s"):
        other = tmp_path / f"c{len(spec)}.bvh"
        code, _, stderr = run("clean", str(files["input"]), "--out", str(other), "--contact",
                              spec, "--quiet")  # fmt: skip
        assert code == 0, stderr
        assert read_motion(other).allclose(read_motion(out), 1e-9, 1e-9)
    for bad, words in (("LeftHand@70:55", "reversed"),
                       ("LeftHand@5:2000", "--contact 'LeftHand@5:2000': frames 5:2000 past"),
                       ("LeftHand@x:3", "--contact 'LeftHand@x:3': expected A:B"),
                       ("LeftHand@1:5@x", "expected JOINT@A:B")):  # fmt: skip
        code, _, stderr = run("clean", str(files["input"]), "--contact", bad)
        assert code == 2 and words in stderr and len(stderr.splitlines()) == 1, stderr


def test_clean_explains_a_cell_and_reports_reasons(files) -> None:
    d = files["dir"]
    rep = d / "rx.json"
    f0 = int(files["frames"][2])
    code, out, stderr = run(
        "clean", str(files["input"]), "--context", str(files["ctx"]), "--report", str(rep),
        "--explain", f"LeftForeArm:{f0}", "--explain", "Head:0.5s",
    )  # fmt: skip
    assert code == 0, stderr
    assert f"LeftForeArm frame {f0}" in out and "FLAGGED by" in out
    assert "Head frame 15 (0.500 s): not flagged" in out
    for rule in ("mdm", "cancelling-jumps", "frozen", "recurring", "noise", "wrong-way-hinge"):
        assert f"  {rule} " in out
    report = json.loads(rep.read_text(), parse_constant=lambda c: pytest.fail(c))
    assert report["rules"][0] == "mdm" and report["config"]["threshold"] == 0.5
    seg = [s for s in report["segments"] if s["joint"] == "LeftForeArm"]
    assert seg and all(s["reasons"] and "mdm_peak" in s["evidence"] for s in seg)
    ex = report["explain"]
    assert ex[0]["flagged"] and ex[0]["reasons"] and not ex[1]["flagged"]
    assert [r["rule"] for r in ex[0]["rules"]] == report["rules"]


@pytest.mark.parametrize(
    "spec, msg",
    [("LeftForeArm", "expected JOINT:FRAME"), ("Nope:3", "no joint named"),
     ("Knee_L:3", "no joint named 'Knee_L' (did you mean LeftLeg?)"),
     ("leftforearm:3", "(did you mean LeftForeArm?)"),
     ("Head:x", "expected a frame (60) or a time (2.0s), got 'x'"),
     ("Head:99999", "--explain 'Head:99999': frame 99999 past the end of the take")],
)  # fmt: skip
def test_clean_explain_bad_input_is_one_line(files, spec, msg) -> None:
    code, _, stderr = run("clean", str(files["input"]), "--explain", spec, "--quiet")
    assert code != 0 and msg in stderr and len(stderr.strip().splitlines()) == 1


def test_clean_plot_must_be_named_png(files, tmp_path) -> None:
    """The plot is a PNG image: a name that another program would read as text (x.txt) is
    refused before any work, in one line, and nothing is written."""
    out = tmp_path / "x.txt"
    code, _, stderr = run("clean", str(files["input"]), "--plot", str(out), "--quiet")
    assert code == 2 and "name it .png" in stderr and len(stderr.strip().splitlines()) == 1
    assert not out.exists()
    out = tmp_path / "m.csv"  # the MDM is binary .npy: not under a text name
    code, _, stderr = run("clean", str(files["input"]), "--mdm", str(out), "--quiet")
    assert code == 2 and "name it .npy" in stderr and len(stderr.strip().splitlines()) == 1
    assert not out.exists()


def test_clean_a_one_frame_take_says_it_is_too_short(files, tmp_path) -> None:
    """One frame has nothing to compare: the error says so (it said no joint rotates)."""
    one = write_motion(read_motion(files["clean"])[:1], tmp_path / "one.bvh")
    code, _, stderr = run("clean", str(one))
    assert code == 2
    assert "the take is too short: 1 frame(s) (0.033 s)" in stderr
    assert len(stderr.strip().splitlines()) == 1


def test_clean_a_take_held_still_says_no_joint_rotates(files, tmp_path) -> None:
    """A take whose joints never rotate (a VR file of the corpus) gets one line saying so
    (newcomer: "only 0 joint(s) move" read oddly)."""
    still = read_motion(files["clean"])[:120]
    still.rotations[:] = still.rotations[0]
    code, _, stderr = run("clean", str(write_motion(still, tmp_path / "still.bvh")))
    assert code == 2 and len(stderr.strip().splitlines()) == 1
    assert "nothing to compare: no joint rotates" in stderr


def test_explain_reads_frames_and_times_as_every_option_does() -> None:
    """--explain JOINT:TIME uses the CLI's one reading of a position: a time inside the last
    frame's span is the last frame (as --trim takes it), not "outside"."""
    from mocapkit.cli.clean_commands import parse_explain
    from mocapkit.cli.common import CLIError
    from mocapkit.datasets import procedural_motion

    m = procedural_motion("walk", seconds=2.0, fps=30.0, seed=1).motion
    head = m.skeleton.index("Head")
    assert parse_explain("Head:0.5s", m) == (head, 15)
    assert parse_explain(f"Head:{m.duration - 0.01:.3f}s", m) == (head, m.num_frames - 1)
    with pytest.raises(CLIError, match=r"past the end of the take \(60 frames, 2 s at 30 fps"):
        parse_explain(f"Head:{m.num_frames}", m)
