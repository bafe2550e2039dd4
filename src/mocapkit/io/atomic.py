"""Atomic file output: write a temporary file beside the target, then rename it over.

* :func:`atomic_write_bytes` / :func:`atomic_write_text`: readers never see a half-written file,
  and no temporary file (nor a folder it created) is left behind when writing fails. A failure
  about the output path is an :class:`OutputPathError` whose message is one line naming the
  path and what was expected there.
* :func:`check_outputs` (and :func:`check_output`, :func:`refuse_overwrite`): before a command
  reads or writes anything, refuse every output that cannot be written (a folder, a file in the
  way of its folder, a read-only folder, a wrong extension), that is one of the inputs (under
  any spelling: ``./a.bvh``, ``dir/../a.bvh``, a symlink, a hard link) or that is another
  output.
* :func:`all_or_nothing`: within it, atomic writes are held back as temporary files and renamed
  into place together when the block ends without an error; an error removes them all, so a
  command that fails half way writes nothing.
"""

from __future__ import annotations

import contextvars
import errno
import os
import stat
import tempfile
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager, suppress
from dataclasses import dataclass, field
from pathlib import Path

__all__ = [
    "OutputPathError",
    "OverwriteRefusedError",
    "all_or_nothing",
    "atomic_write_bytes",
    "atomic_write_text",
    "check_output",
    "check_outputs",
    "refuse_overwrite",
    "same_file",
]


class OutputPathError(OSError):
    """An output path that cannot be written. ``str(e)`` is ``"PATH: reason"``, one line."""

    def __init__(self, path: str | Path, reason: str, code: int = errno.EINVAL) -> None:
        super().__init__(code, reason, str(path))
        self.path = str(path)
        self.reason = reason

    def __str__(self) -> str:
        return f"{self.path}: {self.reason}"


class OverwriteRefusedError(ValueError):
    """An output that is one of the inputs (or another output): nothing was written."""


@dataclass
class _Pending:
    """The writes held back by :func:`all_or_nothing`: (temporary file, target), and the
    folders they created."""

    moves: list[tuple[str, Path]] = field(default_factory=list)
    folders: list[Path] = field(default_factory=list)


_PENDING: contextvars.ContextVar[_Pending | None] = contextvars.ContextVar(
    "mocapkit_atomic_pending", default=None
)


def _reason(e: OSError) -> str:
    if isinstance(e, PermissionError) or e.errno in (errno.EACCES, errno.EPERM):
        return "permission denied"
    if e.errno == errno.EROFS:
        return "read-only file system"
    if e.errno == errno.ENOSPC:
        return "no space left on the device"
    return e.strerror or str(e)


def _not_a_file(path: Path) -> str | None:
    """Why ``path`` is no place for a file (a pipe, a device, a socket, a process's stream such
    as ``/dev/stdout``, itself or through links), else None: a rename over it would replace it
    (``/dev/stdout`` for every later process, or the file a shell redirected it to) and writing
    into it cannot be atomic."""
    hop = os.path.abspath(path)
    for _ in range(40):  # the link chain, each hop as written (not resolved through /proc)
        if hop.startswith(_STREAM_PREFIXES) or hop in _STREAMS:
            return "is a process's stream, not a file; " + _USE_A_FILE
        if not os.path.islink(hop):
            break
        hop = os.path.join(os.path.dirname(hop), os.readlink(hop))
        hop = os.path.abspath(hop)
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return None
    if stat.S_ISREG(mode) or stat.S_ISDIR(mode):
        return None
    kind = "a pipe" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode) else "a device"
    return f"is {kind}, not a file; " + _USE_A_FILE


_USE_A_FILE = "give a file name (or '-' where the option takes it)"
# a process's open files: their links lead to whatever the shell redirected (a file in
# /dev/shm is an ordinary file and is written as one)
_STREAMS = ("/dev/stdin", "/dev/stdout", "/dev/stderr")
_STREAM_PREFIXES = ("/proc/", "/dev/fd/")


def _final_target(path: Path) -> Path:
    """``path`` with its symlinks followed: writing replaces the file a link points to and keeps
    the link (renaming over the link itself would turn it into a file)."""
    if not path.is_symlink():
        return path
    return Path(os.path.realpath(path))


def _why_not_writable(path: Path) -> str | None:
    """Why ``path`` cannot be written as a file (None when it looks writable): checks the path
    itself, then its nearest existing folder, without creating anything."""
    if str(path) in ("", "."):
        return "expected a file name, got a folder"
    if path.is_dir():
        return "is a folder, expected a file name"
    why = _not_a_file(path)
    if why is not None:
        return why
    path = _final_target(path)
    anc = path.parent
    while True:
        if anc.exists() or anc.is_symlink():
            break
        if anc == anc.parent:
            break
        anc = anc.parent
    folder = anc if str(anc) else Path(".")
    if folder.exists() and not folder.is_dir():
        return f"cannot write here: {folder} is a file, expected a folder"
    if not folder.exists():
        return f"cannot write here: {folder} does not exist"
    if not os.access(folder, os.W_OK | os.X_OK):
        return f"cannot write here: permission denied (the folder {folder} is not writable)"
    return None


def check_output(path: str | Path, suffixes: Sequence[str] | None = None) -> Path:
    """``path`` as a Path if a file can be written there, else :class:`OutputPathError`.

    Refused: a folder, a path under a file, a folder we may not write, and (with
    ``suffixes``, e.g. ``(".bvh", ".npz")``) an extension not among them. Missing folders are
    fine (they are created when writing).
    """
    p = Path(path)
    why = _why_not_writable(p)
    if why is not None:
        raise OutputPathError(p, why)
    if suffixes is not None:
        want = tuple(s.lower() for s in suffixes)
        if p.suffix.lower() not in want:
            raise OutputPathError(
                p,
                f"cannot write this file type ({p.suffix or 'no extension'}); expected "
                f"{' or '.join(want)}",
            )
    return p


def same_file(a: str | Path, b: str | Path) -> bool:
    """Whether ``a`` and ``b`` name the same file: the same inode (hard links, symlinks) when
    both exist, else the same resolved path (``./x``, ``d/../x``, symlinked folders)."""
    try:
        if os.path.samefile(a, b):
            return True
    except (OSError, ValueError):
        pass
    try:
        return Path(a).resolve() == Path(b).resolve()
    except (OSError, RuntimeError):
        return os.path.abspath(a) == os.path.abspath(b)


def refuse_overwrite(output: str | Path, inputs: Iterable[str | Path]) -> None:
    """Raise :class:`OverwriteRefused` (a ValueError) when ``output`` is one of the ``inputs``
    under any spelling (we never overwrite input)."""
    for src in inputs:
        if same_file(output, src):
            also = "" if str(output) == str(src) else f" (as {output})"
            raise OverwriteRefusedError(
                f"{src}: refusing to overwrite the input file{also}; choose another output"
            )


def check_outputs(
    outputs: Iterable[str | Path | tuple[str | Path, Sequence[str] | None] | None],
    inputs: Iterable[str | Path] = (),
) -> list[Path]:
    """Check every output before anything is read or written: each one writable
    (:func:`check_output`; give ``(path, suffixes)`` to check its extension too), none of them
    one of the ``inputs`` (:func:`refuse_overwrite`), no two the same file. ``None`` entries
    (options not given) are skipped. Returns the outputs as Paths."""
    ins = [Path(i) for i in inputs]
    outs: list[Path] = []
    for item in outputs:
        if item is None:
            continue
        path, suffixes = item if isinstance(item, tuple) else (item, None)
        p = Path(path)
        refuse_overwrite(p, ins)
        for other in outs:
            if same_file(p, other):
                also = "" if str(p) == str(other) else f" (also as {other})"
                raise OverwriteRefusedError(
                    f"{p}: given for two outputs{also}; choose another output"
                )
        outs.append(check_output(p, suffixes))
    return outs


def _make_folders(directory: Path, target: Path) -> list[Path]:
    """Create ``directory`` and its missing parents; returns the folders created (deepest
    last). Errors are :class:`OutputPathError` naming ``target``."""
    missing: list[Path] = []
    d = directory
    while not d.is_dir():
        # made a folder meanwhile by another writer (a parallel job): not a file after all
        if (d.exists() or d.is_symlink()) and not d.is_dir():
            raise OutputPathError(
                target, f"cannot write here: {d} is a file, expected a folder", errno.ENOTDIR
            )
        missing.append(d)
        if d == d.parent:
            break
        d = d.parent
    created: list[Path] = []
    try:
        for d in reversed(missing):
            try:
                os.mkdir(d)
            except FileExistsError:
                if d.is_dir():  # made meanwhile by another writer (a parallel job): not ours
                    continue
                raise
            created.append(d)
    except OSError as e:
        _remove_folders(created)
        raise OutputPathError(
            target, f"cannot create the folder {d}: {_reason(e)}", e.errno or errno.EIO
        ) from None
    return created


def _remove_folders(created: Sequence[Path]) -> None:
    for d in reversed(created):
        with suppress(OSError):
            os.rmdir(d)


def _unlink(path: str) -> None:
    with suppress(OSError):
        os.unlink(path)


def _write_error(target: Path, e: OSError) -> OutputPathError:
    if isinstance(e, OutputPathError):
        return e
    if isinstance(e, IsADirectoryError) or target.is_dir():
        return OutputPathError(target, "is a folder, expected a file name", errno.EISDIR)
    return OutputPathError(target, f"cannot write: {_reason(e)}", e.errno or errno.EIO)


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (readers never see a half-written file).

    Missing folders are created. A symlink is followed: the file it points to is replaced and
    the link kept. A pipe, device or socket is refused (a rename would replace it, and a write
    into it cannot be atomic). On any failure nothing is left behind (no temporary file, no
    folder this call created) and an OSError about the path is an :class:`OutputPathError`.
    Inside :func:`all_or_nothing` the final rename waits for the end of the block.
    """
    given = Path(path)
    if given.is_dir():
        raise OutputPathError(given, "is a folder, expected a file name", errno.EISDIR)
    why = _not_a_file(given)
    if why is not None:
        raise OutputPathError(given, why)
    path = _final_target(given)
    directory = path.parent if str(path.parent) else Path(".")
    created = _make_folders(directory, path)
    tmp = None
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
        try:
            # mkstemp makes the file private (0600); give it the permissions open() would
            umask = os.umask(0)
            os.umask(umask)
            os.fchmod(fd, 0o666 & ~umask)
            view = memoryview(data)
            while view:
                view = view[os.write(fd, view) :]
            os.fsync(fd)
        finally:
            os.close(fd)
        pending = _PENDING.get()
        if pending is not None:
            pending.moves.append((tmp, path))
            pending.folders.extend(created)
            return given
        os.replace(tmp, path)
    except BaseException as e:
        if tmp is not None:
            _unlink(tmp)
        _remove_folders(created)
        if isinstance(e, OSError):
            raise _write_error(given, e) from None
        raise
    return given


def remove_stale_temporaries(paths: Iterable[str | Path]) -> int:
    """Remove what atomic writes of ``paths`` left behind when their process was killed
    mid-write (a SIGKILL runs no clean-up): the ``.NAME.XXXXXXXX.tmp`` files beside each path.
    Call it only when no write of these paths is under way, e.g. when a library job that a
    lost worker was writing for has finished. Returns how many files were removed."""
    removed = 0
    for path in paths:
        path = Path(path)
        prefix = f".{path.name}."
        try:
            names = os.listdir(path.parent if str(path.parent) else ".")
        except OSError:
            continue
        for name in names:
            middle = name[len(prefix) : -len(".tmp")]
            if name.startswith(prefix) and name.endswith(".tmp") and len(middle) == 8:
                _unlink(str(path.parent / name))
                removed += 1
    return removed


def atomic_write_text(path: str | Path, text: str) -> Path:
    return atomic_write_bytes(path, text.encode("utf-8"))


@contextmanager
def all_or_nothing() -> Iterator[None]:
    """Hold back every atomic write made inside the block and put them all in place when it
    ends without an error; on an error remove them all (and the folders they created), so
    nothing is written. Nested blocks join the outermost one."""
    if _PENDING.get() is not None:
        yield
        return
    pending = _Pending()
    token = _PENDING.set(pending)
    try:
        yield
    except BaseException:
        for tmp, _ in pending.moves:
            _unlink(tmp)
        _remove_folders(pending.folders)
        raise
    finally:
        _PENDING.reset(token)
    for i, (tmp, target) in enumerate(pending.moves):
        try:
            os.replace(tmp, target)
        except OSError as e:
            for t, _ in pending.moves[i:]:
                _unlink(t)
            raise _write_error(target, e) from None
