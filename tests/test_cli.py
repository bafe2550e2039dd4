"""The `mocapkit` command end to end (in-process through click's runner, and one real process)."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from mocapkit import datasets
from mocapkit.cli import main
from mocapkit.io import read_motion, write_motion


@pytest.fixture
def walk_bvh(tmp_path: Path) -> Path:
    synth = datasets.procedural_motion("walk", seconds=3.0, seed=1)
    return write_motion(synth.motion, tmp_path / "walk.bvh")


def run(*args: str) -> tuple[int, str, str]:
    res = CliRunner().invoke(main, list(args))
    return res.exit_code, res.stdout, res.stderr


def test_info_json_describes_the_clip(walk_bvh: Path) -> None:
    code, out, _ = run("info", "--json", str(walk_bvh))
    assert code == 0
    info = json.loads(out)
    m = read_motion(walk_bvh)
    assert info["frames"] == m.num_frames
    assert info["joints"] == m.num_joints
    assert info["frame_time"] == m.frame_time
    assert info["duration_s"] == pytest.approx(m.duration)
    assert info["up_axis"] in ("Y", "+Y")
    assert info["units_guess"] == "m"
    assert set(info["rotation_orders"]) == {"ZXY"}
    c = info["contacts"]
    assert any("Left" in k for k in c) and any("Right" in k for k in c)
    for foot in c.values():
        assert 0.2 < foot["fraction"] < 0.9 and foot["segments"] >= 2
    code, out, _ = run("info", str(walk_bvh))  # the human-readable table
    assert code == 0 and "frames" in out


def test_info_several_files_gives_a_list(walk_bvh: Path, tmp_path: Path) -> None:
    other = write_motion(
        datasets.procedural_motion("wave", seconds=1.0).motion, tmp_path / "wave.bvh"
    )
    code, out, _ = run("info", "--json", str(walk_bvh), str(other))
    assert code == 0
    assert [i["path"] for i in json.loads(out)] == [str(walk_bvh), str(other)]


def test_convert_resample_order_scale_npz(walk_bvh: Path, tmp_path: Path) -> None:
    src = read_motion(walk_bvh)
    out = tmp_path / "w.npz"
    code, stdout, _ = run(
        "convert", str(walk_bvh), str(out), "--fps", "60", "--order", "ZYX", "--scale", "100"
    )
    assert code == 0, stdout
    m = read_motion(out)
    assert m.frame_time == 1 / 60
    assert set(m.skeleton.rotation_orders) == {"ZYX"}
    np.testing.assert_allclose(m.skeleton.offsets, src.skeleton.offsets * 100)
    assert m.duration == pytest.approx(src.duration, abs=2 / 60)
    back = tmp_path / "w.bvh"
    assert run("convert", str(out), str(back))[0] == 0
    assert read_motion(back).allclose(m)


def test_convert_refuses_a_rate_that_leaves_one_frame(walk_bvh: Path, tmp_path: Path) -> None:
    """A rate so low that the take's span is under half a frame would write a single pose
    (newcomer report: --fps 10 on a 5-frame file wrote 1 frame and exit 0)."""
    short = write_motion(read_motion(walk_bvh)[:3], tmp_path / "short.bvh")
    out = tmp_path / "one.bvh"
    code, so, se = run("convert", str(short), str(out), "--fps", "5")
    assert code != 0 and "leaves 1 frame of the take's 3" in so + se and not out.exists()
    assert run("convert", str(short), str(out), "--fps", "20")[0] == 0


def test_convert_and_edit_name_the_rate_as_info_does(walk_bvh: Path, tmp_path: Path) -> None:
    """A frame time written as 0.033333 (6 digits, as many tools write it) is 30 fps in `info`;
    convert and edit said "30.0003 fps" (newcomer report)."""
    from dataclasses import replace

    m = replace(read_motion(walk_bvh), frame_time=0.033333)
    src = write_motion(m, tmp_path / "b.bvh")
    code, so, _ = run("convert", str(src), str(tmp_path / "b.npz"))
    assert code == 0 and "at 30 fps" in so, so
    code, so, _ = run("edit", str(src), str(tmp_path / "e.bvh"), "--trim", "0:30")
    assert code == 0 and "at 30 fps" in so, so


def test_convert_refuses_to_overwrite_input(walk_bvh: Path) -> None:
    before = walk_bvh.read_bytes()
    code, _, err = run("convert", str(walk_bvh), str(walk_bvh))
    assert code == 2 and "refusing to overwrite" in err
    assert walk_bvh.read_bytes() == before


def test_bad_input_one_line_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT a\n{\n  OFFSET 0 0\n}\n")
    code, out, err = run("info", str(bad))
    assert code == 2
    assert err.strip().count("\n") == 0, err
    assert err.startswith(f"mocapkit: error: {bad}:4: ")
    assert "Traceback" not in out + err
    code, _, err = run("info", str(tmp_path / "missing.bvh"))
    assert code == 2 and "cannot read file" in err
    code, _, err = run("convert", str(bad), str(tmp_path / "x.txt"))
    assert code == 2


def test_lenient_reports_repairs(walk_bvh: Path, tmp_path: Path) -> None:
    text = walk_bvh.read_text().replace("Frames: ", "Frames: 1", 1)  # wrong count
    broken = tmp_path / "count.bvh"
    broken.write_text(text)
    assert run("info", str(broken))[0] == 2
    code, _, err = run("info", "--lenient", str(broken))
    assert code == 0 and "repaired" in err
    # a script reading --json sees the repair too, not only stderr; a clean read has no key
    code, out, err = run("info", "--lenient", "--json", str(broken))
    notes = json.loads(out)["warnings"]
    assert code == 0 and notes and all(str(broken) in n for n in notes)
    assert "warnings" not in json.loads(run("info", "--json", str(walk_bvh))[1])


def test_a_lenient_run_that_fails_says_what_it_repaired_first(walk_bvh: Path, tmp_path: Path):
    """A repair may be why a command fails (a header's frame count cut to the one row that
    follows leaves a take too short to clean): the repairs are printed above the error line,
    which stays the last line; other warnings are not, and a plain failure is one line."""
    lines = walk_bvh.read_text().splitlines()
    first = next(i for i, x in enumerate(lines) if x.startswith("Frame Time")) + 1
    short = tmp_path / "short.bvh"
    short.write_text("\n".join(lines[: first + 1]) + "\n")  # one row of many
    code, _, err = run("clean", "--lenient", str(short), "--report", str(tmp_path / "r.json"))
    err_lines = err.strip().splitlines()
    assert code == 2, err
    assert err_lines[-1].startswith(f"mocapkit: error: {short}") and "too short" in err_lines[-1]
    assert any(x.startswith("mocapkit: repaired: ") and "1 row of motion data follows" in x
               for x in err_lines[:-1])  # fmt: skip
    assert all(x.startswith("mocapkit: repaired: ") for x in err_lines[:-1])
    assert not (tmp_path / "r.json").exists()
    code, _, err = run("clean", str(short), "--report", str(tmp_path / "r.json"))  # not lenient
    assert code == 2 and err.strip().count("\n") == 0, err


def test_every_subcommand_has_an_example() -> None:
    for cmd in main.commands:
        code, out, _ = run(cmd, "--help")
        assert code == 0
        assert "Example" in out and f"mocapkit {cmd}" in out, cmd
        # sentences start upper case and names keep theirs (str.capitalize lowered "Dask")
        text = " ".join(out.split())
        assert ". the " not in text, cmd
        assert "local dask" not in text and "running dask" not in text, cmd


def test_demo_runs_and_writes_outputs(tmp_path: Path) -> None:
    code, out, err = run("demo", "--out", str(tmp_path / "d"))
    assert code == 0, out + err
    files = {p.name for p in (tmp_path / "d").iterdir()}
    assert {
        "humanoid_walk.bvh",
        "humanoid_run.bvh",
        "humanoid_wave.bvh",
        "three_circles.csv",
        "humanoid_walk_60fps_zyx.bvh",
        "inbetween_walk.bvh",
        "view_inbetween.html",  # the gap marked from the sidecar
    } <= files
    assert "round trip exact" in out
    page = (tmp_path / "d" / "view_inbetween.html").read_text()
    assert '"kind": "inbetween"' in page or '"kind":"inbetween"' in page


def test_console_script_runs_as_a_real_process(walk_bvh: Path) -> None:
    exe = Path(sys.executable).parent / "mocapkit"
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "mocapkit.cli"]
    res = subprocess.run(
        [*cmd, "info", "--json", str(walk_bvh)], capture_output=True, text=True, timeout=120
    )
    assert res.returncode == 0, res.stderr
    assert json.loads(res.stdout)["frames"] > 0


def test_info_overrides_up_and_units(walk_bvh: Path) -> None:
    code, out, _ = run("info", "--json", "--units", "cm", "--up", "y", str(walk_bvh))
    assert code == 0
    info = json.loads(out)
    assert (info["units_guess"], info["metres_per_unit"], info["up_axis"]) == ("cm", 0.01, "Y")


ASF = """:version 1.10
:name VICON
:units
  mass 1.0
  length 0.45
  angle deg
:root
   order TX TY TZ RX RY RZ
   axis XYZ
   position 0 0 0
   orientation 0 0 0
:bonedata
  begin
     id 1
     name lfemur
     direction 0.34202 -0.939693 0
     length 7.10592
     axis 0 0 20 XYZ
     dof rx ry rz
  end
:hierarchy
  begin
    root lfemur
  end
"""
AMC = """:FULLY-SPECIFIED
:DEGREES
1
root 1 2 3 4 5 6
lfemur -21.2 3.6 -10.5
2
root 1 2 3.5 4 5 6
lfemur 10 0 0
"""


def test_convert_asf_amc_to_bvh(tmp_path: Path) -> None:
    (tmp_path / "07.asf").write_text(ASF)
    (tmp_path / "07_01.amc").write_text(AMC)
    out = tmp_path / "07_01.bvh"
    code, _, err = run(
        "convert",
        str(tmp_path / "07.asf"),
        str(tmp_path / "07_01.amc"),
        str(out),
        "--amc-fps",
        "60",
    )
    assert code == 0, err
    m = read_motion(out)
    assert m.num_frames == 2 and m.frame_time == pytest.approx(1 / 60)
    np.testing.assert_allclose(m.root_positions, [[1, 2, 3], [1, 2, 3.5]])
    # the ASF beside a CMU-style AMC is found on its own
    out2 = tmp_path / "auto.bvh"
    assert run("convert", str(tmp_path / "07_01.amc"), str(out2))[0] == 0
    assert read_motion(out2).num_frames == 2
    # the two inputs swapped, or an ASF with a take that is no AMC (it was ignored)
    asf, amc = str(tmp_path / "07.asf"), str(tmp_path / "07_01.amc")
    code, _, err = run("convert", amc, asf, str(tmp_path / "swapped.bvh"))
    assert code == 2 and "the ASF skeleton comes first" in err
    (tmp_path / "w.bvh").write_bytes(out.read_bytes())
    code, _, err = run("convert", asf, str(tmp_path / "w.bvh"), str(tmp_path / "x.bvh"))
    assert code == 2 and "goes with an .amc take" in err and not (tmp_path / "x.bvh").exists()
    bad = tmp_path / "bad.amc"
    bad.write_text(AMC.replace("lfemur 10 0 0", "lfemur 10 0"))
    code, _, err = run("convert", str(tmp_path / "07.asf"), str(bad), str(tmp_path / "x.bvh"))
    assert code == 2 and f"{bad}:8:" in err


# ----------------------------------------------------- bad input, bad paths, many files (#14)
def _listing(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def test_output_path_faults_are_one_line_and_leave_nothing(walk_bvh: Path) -> None:
    folder = walk_bvh.parent
    before = _listing(folder)
    (folder / "d").mkdir()
    for out, expected in (
        (walk_bvh / "c.bvh", f"{walk_bvh / 'c.bvh'}: cannot write here: {walk_bvh} is a file"),
        (folder / "d", f"{folder / 'd'}: is a folder, expected a file name"),
        (folder / "x.txt", "cannot write this file type (.txt); expected .bvh or .npz"),
    ):
        code, _, err = run("convert", str(walk_bvh), str(out))
        assert code == 2 and err.count("\n") == 1 and err.startswith("mocapkit: error: "), err
        assert expected in err, err
    assert _listing(folder) == sorted([*before, "d"])


def test_graph_build_never_overwrites_its_inputs(tmp_path: Path) -> None:
    clips = tmp_path / "clips"
    for i, kind in enumerate(("walk", "idle")):
        write_motion(datasets.procedural_motion(kind, seconds=1.0, seed=i).motion,
                     clips / f"{kind}.bvh")  # fmt: skip
    before = {p.name: p.read_bytes() for p in clips.iterdir()}
    for extra in (
        ["--out", str(clips / "walk.bvh")],
        ["--out", str(tmp_path / "g.json"), "--graphml", str(clips / ".." / "clips/idle.bvh")],
        ["--out", str(tmp_path / "g.json"), "--plot", str(clips / "x.bvh")],
        ["--out", str(tmp_path / "g.json"), "--plot", str(tmp_path / "g.json")],
    ):
        code, _, err = run("graph", "build", str(clips), "--quiet", *extra)
        assert code == 2 and err.count("\n") == 1, err
    assert {p.name: p.read_bytes() for p in clips.iterdir()} == before
    assert _listing(tmp_path) == ["clips", "clips/idle.bvh", "clips/walk.bvh"]


def test_info_reports_every_file_and_each_failure(walk_bvh: Path, tmp_path: Path) -> None:
    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT a\n{\n  OFFSET 0 0\n}\n")
    other = write_motion(datasets.procedural_motion("wave", seconds=1).motion, tmp_path / "c.bvh")
    code, out, err = run("info", str(walk_bvh), str(bad), str(other))
    assert code == 2
    assert out.count("joints") == 2
    assert err.splitlines() == [err.splitlines()[0]] and err.startswith(f"mocapkit: error: {bad}:")
    code, out, err = run("info", "--json", str(walk_bvh), str(bad), str(tmp_path / "nope.bvh"))
    assert code == 2 and len(err.splitlines()) == 2
    items = json.loads(out)
    assert [i["path"] for i in items] == [str(walk_bvh), str(bad), str(tmp_path / "nope.bvh")]
    assert "frames" in items[0] and set(items[1]) == {"path", "error"}
    assert items[1]["error"].startswith(f"{bad}:4: ")
    assert "no such file" in items[2]["error"]
    # an object for exactly one file; a list for a folder, even of one file, or a pattern
    one = tmp_path / "one"
    one.mkdir()
    write_motion(read_motion(walk_bvh), one / "w.bvh")
    assert isinstance(json.loads(run("info", "--json", str(one / "w.bvh"))[1]), dict)
    assert isinstance(json.loads(run("info", "--json", str(one))[1]), list)
    assert isinstance(json.loads(run("info", "--json", str(one / "*.bvh"))[1]), list)
    # one bad file: its error object on stdout (a script reads JSON whatever failed), one
    # error line on stderr, status 2
    code, out, err = run("info", "--json", str(bad))
    assert code == 2 and err.count("\n") == 1
    assert json.loads(out) == {
        "path": str(bad),
        "error": err.strip().removeprefix("mocapkit: error: "),
    }


def test_info_json_fps_offsets_and_extreme_values(walk_bvh: Path, tmp_path: Path) -> None:
    text = walk_bvh.read_text()
    ft = text.split("Frame Time:")[1].split()[0]
    rounded = tmp_path / "rounded.bvh"
    rounded.write_text(text.replace(f"Frame Time: {ft}", "Frame Time: 0.0333333"))
    info = json.loads(run("info", "--json", str(rounded))[1])
    assert info["fps"] == 30 and info["frame_time"] == 0.0333333
    m = read_motion(rounded)
    assert info["offsets"] == m.skeleton.offsets.tolist() and len(info["parents"]) == m.num_joints
    # extreme but finite offsets: the bounding box overflows; JSON stays strict (null + warning)
    lines = text.splitlines()
    offsets = [i for i, ln in enumerate(lines) if ln.strip().startswith("OFFSET")]
    for i in offsets[1:4]:
        lines[i] = lines[i].split("OFFSET")[0] + "OFFSET 0 1e308 0"
    huge = tmp_path / "huge.bvh"
    huge.write_text("\n".join(lines) + "\n")
    code, out, err = run("info", "--json", str(huge))
    assert code == 0

    def refuse(c: str) -> None:
        raise AssertionError(c)

    info = json.loads(out, parse_constant=refuse)
    assert None in info["bounding_box"]["max"]
    assert err.startswith(f"mocapkit: warning: {huge}: ") and "written as null" in err
    assert "overflow" not in err and "repaired" not in err


def test_info_prints_file_strings_as_text_not_markup(walk_bvh: Path, tmp_path: Path) -> None:
    for name in ("[bold]walk.bvh", "[take 1].bvh", "[link=x]a[i].bvh"):
        p = tmp_path / name
        p.write_bytes(walk_bvh.read_bytes())
        code, out, err = run("info", str(p))
        assert code == 0, err
        assert name in out
    renamed = tmp_path / "renamed.bvh"
    renamed.write_text(walk_bvh.read_text().replace("ROOT Hips", "ROOT [red]Hips[/red]"))
    code, out, err = run("info", "--tree", str(renamed))
    assert code == 0, err
    assert "[red]Hips[/red]" in out


def test_info_up_must_be_an_axis(walk_bvh: Path) -> None:
    for bad in ("W", "YY", "+-Y", ""):
        code, out, err = run("info", "--up", bad, str(walk_bvh))
        assert code == 2 and out == "" and err.count("\n") == 1, err
        assert err.startswith("mocapkit: error: ") and "--up" in err
    assert run("info", "--up", "-z", str(walk_bvh))[0] == 0


def test_only_repairs_say_repaired(monkeypatch: pytest.MonkeyPatch) -> None:
    import warnings

    import click

    from mocapkit.cli.common import friendly_errors
    from mocapkit.io import RepairWarning

    @click.command()
    @friendly_errors
    def cmd() -> None:
        warnings.warn("overflow encountered in multiply", RuntimeWarning, stacklevel=1)
        warnings.warn("invalid value encountered in subtract", RuntimeWarning, stacklevel=1)
        warnings.warn("Mean of empty slice", RuntimeWarning, stacklevel=1)
        warnings.warn("x.bvh: 2 blank rows dropped", RepairWarning, stacklevel=1)
        warnings.warn("x.bvh: 2 blank rows dropped", RepairWarning, stacklevel=1)

    res = CliRunner().invoke(cmd, [])
    assert res.exit_code == 0
    assert res.stderr.splitlines() == [
        "mocapkit: warning: Mean of empty slice",
        "mocapkit: repaired: x.bvh: 2 blank rows dropped",
    ]


def test_view_writes_its_default_page_into_the_current_folder(
    walk_bvh: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    data = tmp_path / "data"
    data.mkdir()
    take = Path(shutil.copy(walk_bvh, data / "walk.bvh"))
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    code, _out, err = run("view", str(take))
    assert code == 0, err
    assert (work / "walk.html").is_file()
    assert _listing(data) == ["walk.bvh"]
    code, _out, err = run("view", str(data))  # a folder: the page is named after it
    assert code == 0 and (work / "data.html").is_file(), err


def test_usage_errors_are_one_line(walk_bvh: Path) -> None:
    for args in (["info", "--bogus", str(walk_bvh)], ["convert"], ["clean", str(walk_bvh.parent)]):
        code, _out, err = run(*args)
        assert code == 2 and err.count("\n") == 1 and err.startswith("mocapkit: error: "), err


def test_info_notes_a_height_no_person_has(walk_bvh: Path, tmp_path: Path) -> None:
    """A guessed unit that leaves the body outside a person's height range is said to be a
    guess; a plausible height, or a unit given or stated by the file, gets no note."""
    from mocapkit.io import read_motion, write_motion

    r = CliRunner().invoke(main, ["info", "--json", str(walk_bvh)])
    assert "units_note" not in json.loads(r.stdout)
    m = read_motion(walk_bvh)  # the procedural humanoid, in metres: x 6 reads as 10 m tall
    giant = write_motion(m.with_skeleton(m.skeleton.scaled(6.0)), tmp_path / "giant.bvh")
    big = read_motion(giant)
    big = big.__class__(big.skeleton, big.rotations, big.root_positions * 6.0, big.frame_time)
    write_motion(big, giant)
    data = json.loads(CliRunner().invoke(main, ["info", "--json", str(giant)]).stdout)
    assert "not a person's" in data["units_note"] and "--units" in data["units_note"]
    text = CliRunner().invoke(main, ["info", str(giant)]).stdout
    assert "not a person's" in text
    given = CliRunner().invoke(main, ["info", "--json", "--units", "m", str(giant)])
    assert "units_note" not in json.loads(given.stdout)


def test_info_warns_when_up_is_not_the_bodys(walk_bvh: Path) -> None:
    code, _out, err = run("info", "--up", "Z", str(walk_bvh))
    assert code == 0 and "up axis Z given, but its body stands along Y" in err
    code, _out, err = run("info", "--up", "Y", str(walk_bvh))
    assert code == 0 and "stands along" not in err


def test_a_reader_that_goes_away_is_no_error(monkeypatch):
    """`mocapkit graph report g.json | head -5` ended with "mocapkit: error: Broken pipe"."""
    import click

    from mocapkit.cli import common
    from mocapkit.cli.common import friendly_errors

    quieted = []
    monkeypatch.setattr(common, "_quiet_stdout", lambda: quieted.append(True))  # keep pytest's fd
    monkeypatch.setattr(common, "_stdout_broken", lambda: True)

    @friendly_errors
    def writes_to_a_closed_pipe() -> None:
        raise BrokenPipeError(32, "Broken pipe")

    with pytest.raises(click.exceptions.Exit) as e:
        writes_to_a_closed_pipe()
    assert e.value.exit_code == 1 and quieted
    # a broken pipe that is not standard output's (a socket) is an error line
    monkeypatch.setattr(common, "_stdout_broken", lambda: False)
    with pytest.raises(click.ClickException, match="Broken pipe"):
        writes_to_a_closed_pipe()


def test_a_failed_command_asked_for_json_on_stdout_prints_its_error_there(
    walk_bvh: Path, tmp_path: Path
) -> None:
    """Newcomer report: ``--json -`` printed nothing on standard output when the command failed,
    so a script reading it got no JSON. Now it gets ``{"error": LINE}`` (the same line as on
    standard error), with exit status 2; a JSON file named by --json is not written."""
    missing = str(tmp_path / "nope.bvh")
    out = str(tmp_path / "o.bvh")
    for args in (
        ["inbetween", missing, "--gap", "10:20", "--library", str(walk_bvh), "--out", out,
         "--json", "-"],
        ["stitch", str(walk_bvh), missing, "--takeoff", "10", "--out", out, "--json", "-"],
        ["retarget", missing, "--to", str(walk_bvh), "--out", out, "--json"],
    ):  # fmt: skip
        code, stdout, stderr = run(*args)
        assert code == 2, (args, stdout, stderr)
        err = json.loads(stdout)["error"]
        assert "nope.bvh" in err and f"mocapkit: error: {err}" in stderr
    code, stdout, _ = run("inbetween", missing, "--gap", "10:20", "--library", str(walk_bvh),
                          "--out", out, "--json", str(tmp_path / "r.json"))  # fmt: skip
    assert code == 2 and stdout == "" and not (tmp_path / "r.json").exists()
    # a mistyped option (click's own check, before the command runs) prints it too, once
    for args in (
        ["inbetween", str(walk_bvh), "--gap", "10:20", "--method", "foo", "--out", out,
         "--json=-"],
        ["inbetween", str(walk_bvh), "--library", str(walk_bvh), "--out", out, "--json", "-"],
        ["graph", "report", missing, "--json"],
    ):  # fmt: skip
        code, stdout, stderr = run(*args)
        assert code == 2 and "mocapkit: error:" in stderr
        assert json.loads(stdout)["error"] in stderr
    code, stdout, _ = run("inbetween", str(walk_bvh), "--gap", "10:20", "--method", "foo",
                          "--out", out)  # fmt: skip
    assert code == 2 and stdout == ""  # no JSON asked for


def test_stitch_prints_its_json_result_only_once_its_files_are_written(
    walk_bvh: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Review: the result was printed inside the all-or-nothing block, so a later failure (the
    plot, the final rename) left a success document on stdout followed by the error's. Now
    standard output holds the error alone, and no output file is left."""
    import mocapkit.viz.figures.stitch as fig

    def broken(*_args, **_kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(fig, "plot_stitch", broken)
    out = tmp_path / "o.bvh"
    code, stdout, stderr = run("stitch", str(walk_bvh), str(walk_bvh), "--takeoff", "30",
                               "--out", str(out), "--plot", str(tmp_path / "p.png"),
                               "--json", "-")  # fmt: skip
    assert code == 2, stderr
    assert set(json.loads(stdout)) == {"error"} and "no space" in stdout.lower()
    assert not out.exists()


@pytest.mark.parametrize(
    "args",
    [
        ("stitch", "{walk}", "{walk}", "--takeoff", "40", "--json", "--out", "{out}"),
        ("inbetween", "{walk}", "--gap", "30:40", "--json", "--out", "{out}"),
        ("clean", "{walk}", "--json", "--out", "{out}"),
    ],
)
def test_json_that_takes_a_file_refuses_an_option_as_its_value(walk_bvh, tmp_path, args):
    """Newcomer: `stitch walk.bvh lib/ --takeoff 60 --json --out j.bvh` (--json written as the
    flag it is in info, edit, graph and retarget) took '--out' as the JSON's file and read
    j.bvh as a library file. Now one line says how to print it (--json -), and nothing is
    written."""
    out = tmp_path / "j.bvh"
    code, _, err = run(*(a.format(walk=walk_bvh, out=out) for a in args))
    assert code == 2 and "--json -" in err and "'--out'" in err
    assert len(err.strip().splitlines()) == 1
    assert not out.exists() and not (tmp_path / "--out").exists()


def test_info_json_dash_says_json_is_a_flag_here(walk_bvh: Path) -> None:
    """Newcomer: `info walk.bvh --json -` (as stitch takes --json -) said "-: cannot read
    file: no such file or folder"; it now says why: --json is a flag here."""
    code, out, err = run("info", str(walk_bvh), "--json", "-")
    assert code == 2 and "standard input is not read" in err and "flag" in err
    assert json.loads(out)[0]["frames"] > 0  # the file given is still reported
