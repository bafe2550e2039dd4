"""Atomic output (mocapkit.io.atomic): nothing left behind on failure, one-line path errors,
the overwrite refusal under every spelling, all-or-nothing blocks."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from mocapkit.io import atomic
from mocapkit.io.atomic import (
    OutputPathError,
    OverwriteRefusedError,
    all_or_nothing,
    atomic_write_bytes,
    atomic_write_text,
    check_output,
    check_outputs,
    refuse_overwrite,
    same_file,
)


def _listing(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def test_writes_and_replaces(tmp_path: Path) -> None:
    p = atomic_write_text(tmp_path / "a" / "b" / "x.txt", "one")
    assert p.read_text() == "one"
    atomic_write_bytes(p, b"two")
    assert p.read_bytes() == b"two"
    assert _listing(tmp_path) == ["a", "a/b", "a/b/x.txt"]
    assert oct(p.stat().st_mode & 0o777) != oct(0o600)  # not mkstemp's private mode


def test_a_symlink_is_followed_and_kept(tmp_path: Path) -> None:
    """Writing through a link replaces the file it points to; the link stays a link (a rename
    over the link would turn it into a file and leave the target stale)."""
    target = tmp_path / "real" / "report.json"
    target.parent.mkdir()
    target.write_text("old")
    link = tmp_path / "link.json"
    link.symlink_to(target)
    assert check_output(link) == link
    assert atomic_write_text(link, "new") == link
    assert link.is_symlink() and target.read_text() == "new"
    dangling = tmp_path / "dangling.json"
    dangling.symlink_to(tmp_path / "real" / "made.json")
    atomic_write_text(dangling, "made")
    assert dangling.is_symlink() and (tmp_path / "real" / "made.json").read_text() == "made"
    assert _listing(tmp_path) == [
        "dangling.json", "link.json", "real", "real/made.json", "real/report.json",
    ]  # fmt: skip


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes on this system")
def test_a_pipe_or_device_is_refused_not_replaced(tmp_path: Path) -> None:
    """A rename over /dev/stdout or a named pipe would replace it for every later reader."""
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    streams = [Path(p) for p in ("/dev/stdout", "/dev/fd/1") if os.path.lexists(p)]
    for path in (fifo, Path(os.devnull), *streams):
        for call in (check_output, lambda p: atomic_write_text(p, "x")):
            with pytest.raises(OutputPathError, match="not a file; give a file name") as e:
                call(path)
            assert "\n" not in str(e.value)
    assert fifo.is_fifo() and Path(os.devnull).is_char_device()
    assert _listing(tmp_path) == ["pipe.json"]
    if os.path.isdir("/dev/shm") and os.access("/dev/shm", os.W_OK):  # a file there is a file
        shm = Path("/dev/shm") / f"mocapkit-test-{os.getpid()}.json"
        try:
            assert atomic_write_text(shm, "ok").read_text() == "ok"
        finally:
            shm.unlink(missing_ok=True)


def test_parent_is_a_file(tmp_path: Path) -> None:
    f = tmp_path / "a.bvh"
    f.write_text("x")
    for out in (f / "c.bvh", f / "deeper" / "c.bvh"):
        with pytest.raises(OutputPathError) as e:
            atomic_write_text(out, "y")
        assert str(e.value) == f"{out}: cannot write here: {f} is a file, expected a folder"
        assert "\n" not in str(e.value)
    assert f.read_text() == "x"
    assert _listing(tmp_path) == ["a.bvh"]


def test_target_is_a_folder(tmp_path: Path) -> None:
    (tmp_path / "d").mkdir()
    with pytest.raises(OutputPathError, match="is a folder, expected a file name"):
        atomic_write_text(tmp_path / "d", "y")
    assert _listing(tmp_path) == ["d"]


@pytest.mark.parametrize("stage", ["mkstemp", "write", "fsync", "replace"])
def test_no_temp_file_or_new_folder_after_a_failure(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, stage: str
) -> None:
    def boom(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    target = {"mkstemp": atomic.tempfile, "write": os, "fsync": os, "replace": os}[stage]
    name = {"mkstemp": "mkstemp", "write": "write", "fsync": "fsync", "replace": "replace"}[stage]
    monkeypatch.setattr(target, name, boom)
    out = tmp_path / "new" / "deeper" / "x.bvh"
    with pytest.raises(OutputPathError) as e:
        atomic_write_text(out, "data")
    assert str(e.value).startswith(f"{out}: ")
    assert "permission denied" in str(e.value)
    monkeypatch.undo()
    assert _listing(tmp_path) == []  # neither the temp file nor the folders it made


def test_interrupt_leaves_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def interrupt(fd):
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "fsync", interrupt)
    with pytest.raises(KeyboardInterrupt):
        atomic_write_text(tmp_path / "x.bvh", "data")
    monkeypatch.undo()
    assert _listing(tmp_path) == []


def test_check_output(tmp_path: Path) -> None:
    (tmp_path / "f").write_text("x")
    (tmp_path / "d").mkdir()
    assert check_output(tmp_path / "new" / "x.bvh", (".bvh",)) == tmp_path / "new" / "x.bvh"
    with pytest.raises(OutputPathError, match=r"cannot write this file type \(\.txt\)"):
        check_output(tmp_path / "x.txt", (".bvh", ".npz"))
    with pytest.raises(OutputPathError, match="is a file, expected a folder"):
        check_output(tmp_path / "f" / "x.bvh")
    with pytest.raises(OutputPathError, match="is a folder"):
        check_output(tmp_path / "d")
    assert _listing(tmp_path) == ["d", "f"]  # checking creates nothing


@pytest.mark.skipif(os.geteuid() == 0, reason="root ignores permissions (see tests/test_fuzz)")
def test_check_output_read_only_folder(tmp_path: Path) -> None:
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        with pytest.raises(OutputPathError, match="permission denied"):
            check_output(ro / "x.bvh")
        with pytest.raises(OutputPathError, match="permission denied"):
            atomic_write_text(ro / "sub" / "x.bvh", "x")
        assert list(ro.iterdir()) == []
    finally:
        ro.chmod(0o755)


def test_same_file_under_every_spelling(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    Path("a.bvh").write_text("x")
    Path("d").mkdir()
    os.symlink("a.bvh", "link.bvh")
    os.symlink(".", "here")
    os.link("a.bvh", "hard.bvh")
    for spelling in ("a.bvh", "./a.bvh", "d/../a.bvh", ".//a.bvh", "link.bvh", "hard.bvh",
                     "here/a.bvh", str(tmp_path / "a.bvh"), "nodir/../a.bvh"):  # fmt: skip
        assert same_file(spelling, "a.bvh"), spelling
        with pytest.raises(OverwriteRefusedError, match="refusing to overwrite the input file"):
            refuse_overwrite(spelling, ["other.bvh", "a.bvh"])
    assert not same_file("b.bvh", "a.bvh")
    refuse_overwrite("b.bvh", ["a.bvh"])


def test_check_outputs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    Path("a.bvh").write_text("x")
    assert check_outputs(["g.json", None, ("x.bvh", (".bvh",))], ["a.bvh"]) == [
        Path("g.json"),
        Path("x.bvh"),
    ]
    with pytest.raises(OverwriteRefusedError, match=r"a\.bvh: refusing to overwrite"):
        check_outputs(["g.json", "./a.bvh"], ["a.bvh"])
    with pytest.raises(OverwriteRefusedError, match="given for two outputs"):
        check_outputs(["g.json", "./g.json"])


def test_all_or_nothing_writes_all_at_the_end(tmp_path: Path) -> None:
    with all_or_nothing():
        a = atomic_write_text(tmp_path / "a.json", "1")
        atomic_write_text(tmp_path / "sub" / "b.json", "2")
        assert not a.exists()  # held back until the block ends
    assert (tmp_path / "a.json").read_text() == "1"
    assert (tmp_path / "sub" / "b.json").read_text() == "2"
    assert _listing(tmp_path) == ["a.json", "sub", "sub/b.json"]


def test_all_or_nothing_failure_writes_nothing(tmp_path: Path) -> None:
    (tmp_path / "old.json").write_text("old")
    with pytest.raises(RuntimeError), all_or_nothing():
        atomic_write_text(tmp_path / "old.json", "new")
        atomic_write_text(tmp_path / "sub" / "b.json", "2")
        raise RuntimeError("later step failed")
    assert _listing(tmp_path) == ["old.json"]
    assert (tmp_path / "old.json").read_text() == "old"


def test_all_or_nothing_nested_joins_the_outer(tmp_path: Path) -> None:
    with all_or_nothing():
        with all_or_nothing():
            atomic_write_text(tmp_path / "a", "1")
        assert not (tmp_path / "a").exists()
    assert (tmp_path / "a").read_text() == "1"


def test_remove_stale_temporaries_takes_only_what_a_killed_write_leaves(tmp_path):
    from mocapkit.io.atomic import remove_stale_temporaries

    out = tmp_path / "take.bvh"
    atomic_write_text(out, "kept")
    stale = tmp_path / ".take.bvh.ab12_x9z.tmp"  # mkstemp's 8 characters
    stale.write_text("half")
    others = [
        tmp_path / name
        for name in (".take.bvh.tmp", ".other.bvh.ab12_x9z.tmp", "take.bvh.ab12_x9z.tmp",
                     ".take.bvh.long_name_here.tmp")
    ]  # fmt: skip
    for p in others:
        p.write_text("not ours")
    assert remove_stale_temporaries([out, tmp_path / "missing" / "x.bvh"]) == 1
    assert not stale.exists() and out.read_text() == "kept"
    assert all(p.exists() for p in others)


def test_a_folder_made_meanwhile_by_another_writer_is_used(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # parallel jobs (Dask workers) writing into one new folder: the one that loses the race
    # to create it writes its file there all the same, and leaves the folder to the winner
    real = os.mkdir

    def racing(path, *a, **k):
        real(path, *a, **k)  # the other writer got there first
        raise FileExistsError(17, "File exists", str(path))

    monkeypatch.setattr(atomic.os, "mkdir", racing)
    out = tmp_path / "new" / "deeper" / "x.json"
    atomic.atomic_write_text(out, "{}\n")
    assert out.read_text() == "{}\n"


def test_a_folder_made_between_two_looks_at_it_is_no_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # CI flake (a Dask convert job): the folder was not there when one writer asked whether it
    # was a folder, and there (made by another) when it asked whether anything was: "is a
    # file, expected a folder"
    target = tmp_path / "conv"
    real = Path.is_dir
    asked = []

    def late(self: Path) -> bool:
        if self == target and not asked:
            asked.append(self)
            result = real(self)
            os.mkdir(self)  # the other writer, right after this look
            return result
        return real(self)

    monkeypatch.setattr(Path, "is_dir", late)
    out = target / "x.json"
    atomic.atomic_write_text(out, "{}\n")
    assert out.read_text() == "{}\n" and asked
