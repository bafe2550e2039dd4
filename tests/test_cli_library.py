"""Each subcommand's JSON is its library function's ``to_json()`` (a Python user gets exactly
what the CLI writes), and ``expand_inputs`` reads files, folders, globs and AMC takes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from mocapkit import datasets
from mocapkit.cli import main
from mocapkit.cli.common import CLIError, expand_inputs
from mocapkit.io import read_motion, write_motion
from mocapkit.jsonio import to_jsonable


def run(*args: str) -> tuple[int, str, str]:
    res = CliRunner().invoke(main, list(args))
    return res.exit_code, res.stdout, res.stderr


@pytest.fixture(scope="module")
def clips(tmp_path_factory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("lib")
    out = {"dir": d}
    for name, kind, secs, seed in (
        ("walk", "walk", 4.0, 0),
        ("idle", "idle", 4.0, 3),
        ("run", "run", 3.0, 1),
    ):
        out[name] = write_motion(
            datasets.procedural_motion(kind, secs, seed=seed).motion, d / f"{name}.bvh"
        )
    (d / "labels.json").write_text("{}")  # like Bandai's label files: skipped in folders
    return out


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


# ------------------------------------------------------------------------------ expand_inputs
def test_expand_inputs_files_folders_globs_and_duplicates(clips) -> None:
    d = clips["dir"]
    got = expand_inputs([str(d)])
    assert [p.name for p in got] == ["idle.bvh", "run.bvh", "walk.bvh"]  # no labels.json
    got = expand_inputs([str(d / "w*.bvh"), str(clips["walk"]), str(d)])
    assert [p.name for p in got] == ["walk.bvh", "idle.bvh", "run.bvh"]
    assert [p.name for p in expand_inputs([str(d)], exclude=[clips["run"]])] == [
        "idle.bvh",
        "walk.bvh",
    ]
    assert [p.name for p in expand_inputs([str(d / "*")])] == ["idle.bvh", "run.bvh", "walk.bvh"]
    assert len(expand_inputs([str(clips["walk"])] * 2, unique=False)) == 2


def test_folders_are_searched_with_their_sub_folders(clips, tmp_path) -> None:
    import shutil

    lib = tmp_path / "lib"
    for sub, name in (("01", "walk"), ("02/deep", "run"), (".hidden", "idle"), ("", "idle")):
        (lib / sub).mkdir(parents=True, exist_ok=True)
        shutil.copy(clips[name], lib / sub / f"{name}.bvh")
    (lib / "02" / ".partial.bvh").write_text("HIERARCHY")  # hidden: an unfinished download
    (lib / "loop").symlink_to(lib)  # a link back up is not listed again
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    shutil.copy(clips["run"], elsewhere / "run2.bvh")
    (lib / "linked").symlink_to(elsewhere)  # a linked sub-folder is a sub-folder
    got = expand_inputs([str(lib)])
    assert [p.relative_to(lib).as_posix() for p in got] == [
        "01/walk.bvh", "02/deep/run.bvh", "idle.bvh", "linked/run2.bvh",
    ]  # fmt: skip
    # a library job reads the sub-folders too, and convert leaves its own outputs out
    code, out, err = run("convert", str(lib), "--out-dir", str(lib / "glb"), "--to", "npz")
    assert code == 0 and "converted 4 of 4" in out, err
    code, out, err = run("convert", str(lib), "--out-dir", str(lib / "glb"), "--to", "npz")
    assert code == 0 and "converted 4 of 4" in out and "4 file(s) that earlier runs" in err, err
    # ... also when converting into another folder: an earlier output is no input
    code, out, err = run("convert", str(lib), "--out-dir", str(lib / "bvh2"), "--to", "bvh")
    assert code == 0 and "converted 4 of 4" in out, err
    # the layout is kept: one name in two sub-folders is two outputs
    shutil.copy(clips["walk"], lib / "02" / "walk.bvh")
    out_dir = tmp_path / "conv"
    code, out, err = run("convert", str(lib), "--out-dir", str(out_dir), "--to", "npz")
    assert code == 0 and "converted 5 of 5" in out, err
    assert sorted(p.relative_to(out_dir).as_posix() for p in out_dir.rglob("*.npz")) == [
        "01/walk.npz", "02/deep/run.npz", "02/walk.npz", "idle.npz", "linked/run2.npz",
    ]  # fmt: skip
    code, out, err = run("convert", str(lib), "--out-dir", str(out_dir), "--to", "npz")
    assert code == 0 and "5 already complete" in out, err  # resumed, sub-folders too


def test_expand_inputs_errors_are_one_line(clips, tmp_path) -> None:
    with pytest.raises(CLIError, match="no such file"):
        expand_inputs([str(tmp_path / "missing.bvh")])
    (tmp_path / "empty").mkdir()
    none = r"no \.bvh/\.npz/\.amc/\.glb/\.gltf files in this folder or its sub-folders"
    with pytest.raises(CLIError, match=none):
        expand_inputs([str(tmp_path / "empty")])
    with pytest.raises(CLIError, match="match this pattern"):
        expand_inputs([str(tmp_path / "*.bvh")])
    code, _, err = run("info", str(tmp_path / "empty"))
    assert code == 2 and err.count("\n") == 1 and "no .bvh" in err


def test_expand_inputs_amc_needs_its_asf(tmp_path) -> None:
    cmu = tmp_path / "cmu"
    cmu.mkdir()
    (cmu / "07.asf").write_text(ASF)
    (cmu / "07_01.amc").write_text(AMC)
    (cmu / "07_02.amc").write_text(AMC)
    got = expand_inputs([str(cmu)])
    assert [p.name for p in got] == ["07_01.amc", "07_02.amc"]  # the .asf is not a take
    code, out, err = run("info", "--json", str(cmu))
    assert code == 0, err
    infos = json.loads(out)
    assert [i["frames"] for i in infos] == [2, 2]
    lone = tmp_path / "lone"
    lone.mkdir()
    (lone / "09_01.amc").write_text(AMC)
    with pytest.raises(CLIError, match="ASF"):
        expand_inputs([str(lone)])
    code, _, err = run("info", str(lone / "09_01.amc"))
    assert code == 2 and "ASF" in err and err.count("\n") == 1


# ------------------------------------------------------------------------- CLI == library
def test_info_json_is_the_summary(clips) -> None:
    from mocapkit.summary import summarize, summarize_file

    code, out, err = run("info", "--json", str(clips["walk"]))
    assert code == 0, err
    lib = summarize_file(clips["walk"])
    assert json.loads(out) == to_jsonable(lib.to_json())
    m = read_motion(clips["walk"])
    assert summarize(m, str(clips["walk"])).to_json() == lib.to_json()
    code, out, _ = run("info", "--json", "--up", "Y", "--units", "cm", str(clips["dir"]))
    assert code == 0
    paths = sorted(clips["dir"].glob("*.bvh"))
    assert json.loads(out) == [
        to_jsonable(summarize_file(p, up="Y", units="cm").to_json()) for p in paths
    ]


def test_convert_writes_what_convert_file_writes(clips, tmp_path) -> None:
    from mocapkit.convert import convert_file

    a, b = tmp_path / "cli.bvh", tmp_path / "lib.bvh"
    code, out, err = run("convert", str(clips["run"]), str(a), "--fps", "60", "--order", "ZYX")
    assert code == 0, err
    res = convert_file(clips["run"], b, fps=60.0, order="ZYX")
    assert a.read_bytes() == b.read_bytes()
    assert f"{res.motion.num_frames} frames" in out
    with pytest.raises(ValueError, match="overwrite"):
        convert_file(clips["run"], clips["run"])


def test_clean_report_is_clean_run_to_json(clips, tmp_path) -> None:
    from mocapkit import clean

    rep = tmp_path / "r.json"
    code, _, err = run(
        "clean", str(clips["walk"]), "--context", str(clips["idle"]), "--report", str(rep),
        "--quiet",
    )  # fmt: skip
    assert code == 0, err
    cli = json.loads(rep.read_text())
    lib = clean.run(
        read_motion(clips["walk"]),
        [read_motion(clips["idle"])],
        source=str(clips["walk"]),
        context_names=[str(clips["idle"])],
    ).to_json()
    cli.pop("analysis_seconds")
    lib.pop("analysis_seconds")
    assert cli.pop("warnings") == []  # the CLI's only addition: the warnings it printed
    assert cli == to_jsonable(lib)


def test_stitch_json_is_stitch_to_json(clips, tmp_path) -> None:
    from mocapkit.stitch import stitch

    js = tmp_path / "s.json"
    code, _, err = run(
        "stitch", str(clips["walk"]), str(clips["dir"] / "*.bvh"), "--takeoff", "50:60",
        "--method", "slerp", "--max-inject", "12", "--json", str(js),
    )  # fmt: skip
    assert code == 0, err
    cli = json.loads(js.read_text())
    # the glob holds the query: the CLI leaves it out of the library (its own next frames)
    data = [p for p in sorted(clips["dir"].glob("*.bvh")) if not p.samefile(clips["walk"])]
    assert "left out of the library" in err
    res = stitch(
        read_motion(clips["walk"]),
        "50:60",
        [read_motion(p) for p in data],
        method="slerp",
        k_max=12,
        query_name=str(clips["walk"]),
        data_names=[str(p) for p in data],
    )
    lib = res.to_json()
    assert res.method == "slerp" and len(lib["lscore_by_k"]) == 13
    cli.pop("search_seconds")
    lib.pop("search_seconds")
    assert cli.pop("warnings") == []  # the CLI's only addition: the warnings it printed
    assert cli == to_jsonable(lib)


def test_graph_build_and_report_are_the_library_objects(clips, tmp_path) -> None:
    from mocapkit.graph import build_graph, load_graph

    out = tmp_path / "g.json"
    code, _, err = run(
        "graph", "build", str(clips["dir"]), "--out", str(out), "--transitions", "20", "--quiet"
    )
    assert code == 0, err
    cli = json.loads(out.read_text())
    files = sorted(clips["dir"].glob("*.bvh"))
    g, _, _ = build_graph(
        [read_motion(p) for p in files],
        paths=[f.name for f in files],
        transitions=20,
    )
    lib = to_jsonable(g.to_json())
    for d in (cli, lib):
        for k in ("tile_seconds", "graph_file"):
            d["stats"].pop(k, None)
        for c in d["clips"]:
            c["path"] = Path(c["path"]).name
    assert cli == lib
    code, so, err = run("graph", "report", str(out), "--json")
    assert code == 0, err
    assert json.loads(so) == to_jsonable(load_graph(out).report(out.parent).to_json())


def test_graph_synth_is_synthesize(clips, tmp_path) -> None:
    from mocapkit.graph import load_graph, synthesize
    from mocapkit.graph.synth import load_clips

    g = tmp_path / "g.json"
    assert run("graph", "build", str(clips["dir"]), "--out", str(g), "--quiet")[0] == 0
    bvh = tmp_path / "w.bvh"
    code, so, err = run("graph", "synth", str(g), "--seconds", "3", "--out", str(bvh))
    assert code == 0, err
    graph = load_graph(g)
    res = synthesize(graph, load_clips(graph, g.parent), seconds=3.0, seed=0)
    assert read_motion(bvh).allclose(read_motion(write_motion(res.motion, tmp_path / "l.bvh")))
    assert f"{res.transitions} transitions" in so


def test_view_page_is_view_files(clips, tmp_path) -> None:
    from mocapkit.viz.viewer import view_files

    a = tmp_path / "a.html"
    code, _, err = run("view", str(clips["dir"] / "[iw]*.bvh"), "--out", str(a))
    assert code == 0, err
    b = view_files([clips["dir"] / "idle.bvh", clips["dir"] / "walk.bvh"], tmp_path / "b.html")
    assert a.read_text() == b.read_text()


def test_cli_json_is_strict_and_warns_about_non_finite(clips, monkeypatch) -> None:
    import mocapkit.cli.io_commands as io_commands

    class Fake:
        def to_json(self) -> dict:
            return {"path": "x", "fps": float("nan"), "box": np.array([1.0, np.inf])}

    monkeypatch.setattr(io_commands, "summarize_file", lambda *a, **k: Fake())
    code, out, err = run("info", "--json", str(clips["walk"]))
    assert code == 0
    got = json.loads(out)
    notes = got.pop("warnings")  # the script sees why two values are null
    assert got == {"path": "x", "fps": None, "box": [1.0, None]}
    assert len(notes) == 1 and "fps, box[1]" in notes[0] and str(clips["walk"]) in notes[0]
    assert "NaN" not in out and "Infinity" not in out
    assert "mocapkit: warning:" in err and "fps" in err and "box[1]" in err


def test_no_json_dumps_or_numpy_math_in_the_cli() -> None:
    import mocapkit.cli as cli

    folder = Path(cli.__file__).parent
    for f in folder.glob("*.py"):
        text = f.read_text()
        assert "json.dumps" not in text, f.name
        assert "import numpy" not in text, f.name
        assert "forward_kinematics" not in text, f.name
        assert "foot_contacts" not in text, f.name


def test_matplotlib_only_under_viz() -> None:
    import mocapkit

    root = Path(mocapkit.__file__).parent
    for f in root.rglob("*.py"):
        rel = f.relative_to(root).as_posix()
        if rel.startswith("viz/") or rel == "_optional.py":
            continue
        assert "matplotlib" not in f.read_text(), rel


def test_reconstruct_writes_what_clean_reconstruct_returns(clips, tmp_path) -> None:
    from mocapkit.clean import reconstruct

    keep = ["Hips", "Neck", "LeftArm", "RightArm", "LeftUpLeg", "RightUpLeg"]
    out = tmp_path / "full.bvh"
    code, _, err = run(
        "reconstruct", str(clips["walk"]), "--database", str(clips["dir"] / "[ir]*.bvh"),
        "--out", str(out), "--joints", ",".join(keep),
    )  # fmt: skip
    assert code == 0, err
    db = [read_motion(clips["dir"] / n) for n in ("idle.bvh", "run.bvh")]
    lib = reconstruct(read_motion(clips["walk"]), db, keep)
    assert read_motion(out).allclose(read_motion(write_motion(lib, tmp_path / "lib.bvh")))


def test_view_of_a_folder_shows_the_files_it_can_read(clips, tmp_path) -> None:
    import shutil

    lib = tmp_path / "lib"
    lib.mkdir()
    shutil.copy(clips["walk"], lib / "walk.bvh")
    shutil.copy(clips["run"], lib / "run.bvh")
    (lib / "broken.bvh").write_text("HIERARCHY\nROOT Hips\n")
    page = tmp_path / "v.html"
    code, out, err = run("view", str(lib), "--out", str(page), "--up", "Z")
    assert code == 2 and page.exists() and "wrote" in out  # the page shows the other two
    assert "left out of the page" in err and "broken.bvh" in err and "Traceback" not in err
    assert err.count("--up Z, but its body stands along Y") == 2  # each file shown, judged
    code, _, err = run("view", str(lib / "broken.bvh"), "--out", str(tmp_path / "b.html"))
    assert code == 2 and not (tmp_path / "b.html").exists() and err.count("\n") == 1


def test_clean_folder_says_when_a_take_is_cleaned_against_itself_alone(tmp_path) -> None:
    """Newcomer report: in folder mode, takes whose related takes all have another skeleton
    were cleaned with no context and nothing said so (only their report's "context": [])."""
    from mocapkit.edit.joints import rename_joints

    walk = datasets.procedural_motion("walk", 6.0, seed=1).motion
    other = rename_joints(walk, {walk.skeleton.names[1]: "Renamed"})
    lib = tmp_path / "lib"
    write_motion(walk, lib / "a.bvh")
    write_motion(other, lib / "b.bvh")
    code, out, err = run("clean", str(lib), "--report-dir", str(tmp_path / "rep"),
                         "--context-by", "all")  # fmt: skip
    assert code == 0, err
    assert (
        "a.bvh: cleaned against itself alone: its related takes were left out (b.bvh: a "
        "different skeleton" in out
    )
    # takes that do have context say nothing of it
    write_motion(walk, lib / "c.bvh")
    code, out, err = run("clean", str(lib), "--report-dir", str(tmp_path / "rep2"),
                         "--context-by", "all")  # fmt: skip
    assert code == 0, err
    assert "a.bvh: cleaned against itself alone" not in out
    assert "b.bvh: cleaned against itself alone" in out
