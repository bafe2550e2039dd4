"""The `mocapkit` command end to end (in-process through click's runner, and one real process)."""

from __future__ import annotations

import json
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


def test_every_subcommand_has_an_example() -> None:
    for cmd in main.commands:
        code, out, _ = run(cmd, "--help")
        assert code == 0
        assert "Example" in out and f"mocapkit {cmd}" in out, cmd


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
    } <= files
    assert "round trip exact" in out


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
    bad = tmp_path / "bad.amc"
    bad.write_text(AMC.replace("lfemur 10 0 0", "lfemur 10 0"))
    code, _, err = run("convert", str(tmp_path / "07.asf"), str(bad), str(tmp_path / "x.bvh"))
    assert code == 2 and f"{bad}:8:" in err
