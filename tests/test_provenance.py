"""Provenance sidecars: file paths stored relative to the sidecar, read back from anywhere."""

from __future__ import annotations

import json
import os
from pathlib import Path

from mocapkit.provenance import Provenance, Segment, TransitionTaken, find_provenance


def test_paths_are_relative_to_the_sidecar_and_read_back_from_any_folder(tmp_path, monkeypatch):
    work = tmp_path / "work"
    (work / "clips").mkdir(parents=True)
    (work / "out").mkdir()
    for n in ("a.bvh", "b.bvh"):
        (work / "clips" / n).write_text("x")
    monkeypatch.chdir(work)  # the tool ran here, with paths as the user typed them
    prov = Provenance(
        "stitch", "out/walk.bvh", 30.0, 20, ["clips/a.bvh", "clips/b.bvh", "api_clip"],
        {"library": ["clips/b.bvh"], "up": "Y", "blended_from": [{"source": "clips/b.bvh"}]},
        [Segment(0, 10, "clip", "clips/a.bvh", 0, 10), Segment(10, 20, "clip", "api_clip", 3, 13)],
        [TransitionTaken(10, "clips/a.bvh", 9, "api_clip", 3, 0.5)],
    )  # fmt: skip
    (work / "out" / "walk.bvh").write_text("x")
    side = prov.write("out/walk.bvh")
    data = json.loads(side.read_text())
    assert data["output"] == "./walk.bvh"
    assert data["inputs"] == ["../clips/a.bvh", "../clips/b.bvh", "api_clip"]  # a name stays
    assert data["segments"][0]["source"] == "../clips/a.bvh"
    assert data["transitions"][0]["source"] == "../clips/a.bvh"
    assert data["transitions"][0]["target"] == "api_clip"
    assert data["parameters"]["library"] == ["../clips/b.bvh"]
    assert data["parameters"]["blended_from"][0]["source"] == "../clips/b.bvh"
    assert data["parameters"]["up"] == "Y"
    # read from another folder: the paths lead to the same files
    monkeypatch.chdir(tmp_path)
    back = find_provenance(work / "out" / "walk.bvh")
    assert back is not None
    assert [Path(p).resolve() for p in back.inputs[:2]] == [
        (work / "clips" / n).resolve() for n in ("a.bvh", "b.bvh")
    ]
    assert back.inputs[2] == "api_clip" and back.transitions[0].target == "api_clip"
    assert Path(back.segments[0].source).resolve() == (work / "clips" / "a.bvh").resolve()
    assert os.path.exists(back.output) and not os.path.isabs(back.output)
    # a path the user gave absolute stays absolute
    monkeypatch.chdir(work)
    absolute = str((work / "clips" / "a.bvh").resolve())
    prov.inputs[0] = absolute
    data = json.loads(prov.write("out/walk.bvh").read_text())
    assert data["inputs"][0] == absolute and data["inputs"][1] == "../clips/b.bvh"


def test_keys_a_later_version_adds_are_ignored(tmp_path):
    side = tmp_path / "x.bvh.provenance.json"
    side.write_text(json.dumps({
        "format": "mocapkit-provenance-1", "tool": "inbetween", "output": "./x.bvh",
        "fps": 30.0, "frames": 10, "inputs": [], "parameters": {}, "future": 1,
        "segments": [{"output_start": 0, "output_stop": 10, "kind": "clip", "backwards": True}],
        "transitions": [{"output_frame": 5, "source": "a", "source_frame": 1, "target": "b",
                         "target_frame": 2, "cost": 1.0, "weight": 3}],
    }))  # fmt: skip
    (tmp_path / "x.bvh").write_text("x")
    prov = find_provenance(tmp_path / "x.bvh")
    assert prov is not None and prov.segments[0].kind == "clip"
    assert prov.transitions[0].cost == 1.0


def test_a_sidecar_traced_through_its_inputs_own_names_where_every_frame_came_from(tmp_path):
    """``through``: the frames copied from a file mocapkit made become the segments its own
    sidecar gives them, clipped (a time-warped fill in proportion, a backwards one from its
    end), with its transitions inside them; nothing changes where the sidecar cannot be this
    file's (another frame rate, too few frames)."""
    a, f = str(tmp_path / "a.bvh"), str(tmp_path / "f.bvh")
    earlier = Provenance(
        "inbetween", f, 30.0, 100, [a, "lib.bvh"], {"gap": [30, 60]},
        [Segment(0, 30, "clip", a, 0, 30), Segment(30, 60, "inbetween", "lib.bvh", 200, 260),
         Segment(60, 80, "inbetween", "back.bvh", 10, 30, True),
         Segment(80, 100, "clip", a, 80, 100)],
        [TransitionTaken(30, a, 29, "lib.bvh", 200, 1.0), TransitionTaken(60, "lib.bvh", 259,
                                                                           a, 60, 2.0)],
    )  # fmt: skip
    later = Provenance(
        "stitch", "out.bvh", 30.0, 70, [f, "b.bvh"], {"k": 0},
        [Segment(0, 50, "clip", f, 40, 90), Segment(50, 70, "clip", "b.bvh", 5, 25)],
        [TransitionTaken(50, f, 89, "b.bvh", 5, 3.0)],
    )  # fmt: skip
    got = later.through(earlier, f)
    assert got.segments == [
        Segment(0, 20, "inbetween", "lib.bvh", 220, 260),  # output 40:60 of f, warped x2
        Segment(20, 40, "inbetween", "back.bvh", 10, 30, True),
        Segment(40, 50, "clip", a, 80, 90),
        Segment(50, 70, "clip", "b.bvh", 5, 25),
    ]
    assert [(t.output_frame, t.source, t.source_frame) for t in got.transitions] == [
        (20, "lib.bvh", 259), (50, a, 89)]  # fmt: skip
    assert got.inputs == [f, "b.bvh", a, "lib.bvh"]
    assert got.parameters == {"k": 0, "earlier": [{"tool": "inbetween", "gap": [30, 60]}]}
    # the history chains: a third run lists both earlier ones, oldest first
    third = Provenance("inbetween", "o3.bvh", 30.0, 70, ["out.bvh"], {"gap": [1, 2]},
                       [Segment(0, 70, "clip", "out.bvh", 0, 70)])  # fmt: skip
    tools = [e["tool"] for e in third.through(got, "out.bvh").parameters["earlier"]]
    assert tools == ["inbetween", "stitch"]
    from dataclasses import replace

    assert later.through(replace(earlier, fps=25.0), f) is later
    assert later.through(replace(earlier, frames=80), f) is later  # copies frames 40:90
    assert later.through(earlier, str(tmp_path / "other.bvh")) is later
