"""Atomic file output: write to a temporary file beside the target, then rename.

A crash or an error half-way never leaves a truncated or half-written output file behind.
`check_outputs` is the one check every command runs before its work (no output over an
input); `publish_dir` replaces a folder of outputs as a whole and `output_lock` keeps a second
run out of it. Output files get the umask's permissions (`file_mode`), as ``open`` gives.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import shutil
import signal
import tempfile
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path

from aida_kb.errors import FormatError


def make_dirs(directory: str | os.PathLike[str]) -> Path:
    """Create `directory` and its parents if missing; FormatError if that is impossible.

    Fails with a message naming the path when a component is an existing file or the
    location is not writable.
    """
    path = Path(directory)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        blocker = next((p for p in (path, *path.parents) if p.exists() and not p.is_dir()), None)
        why = f"{blocker} is a file, not a directory" if blocker is not None else exc.strerror
        raise FormatError(f"{path}: cannot create the output directory: {why}") from None
    return path


def _same_file(a: Path, b: Path) -> bool:
    """True when `a` and `b` name one file: the same resolved path, or the same inode."""
    if a.resolve() == b.resolve():
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist (yet)
        return False


def _inside(inner: Path, outer: Path) -> bool:
    """True when `inner` is `outer` or lies below it (resolved paths: symlinks followed)."""
    return inner.resolve().is_relative_to(outer.resolve())


def check_outputs(
    outputs: Sequence[str | os.PathLike[str]],
    inputs: Iterable[str | os.PathLike[str]] = (),
    *,
    directories: Sequence[str | os.PathLike[str]] = (),
) -> list[Path]:
    """Fail early (FormatError, one line) unless every output can be written beside the inputs.

    The one check every command runs before its work. `outputs` are files to write,
    `directories` folders to write into, `inputs` every file or folder the command reads.
    Refused: an output file that is an input (same resolved path or the same inode, so
    symlinks and hard links count); a file named twice as an output; an output folder that
    is, contains or lies inside an input. A new file inside an input *folder* is fine
    (``evidence SCENE -o SCENE/evidence.json``). Missing folders are created; they must be
    writable.
    """
    files = [Path(p) for p in outputs]
    folders = [Path(p) for p in directories]
    sources = [Path(p) for p in inputs]
    for i, path in enumerate(files):
        for other in files[:i]:
            if _same_file(path, other):
                raise FormatError(f"{path}: named twice as an output (also as {other})")
        for source in sources:
            if _same_file(path, source):
                raise FormatError(f"{path}: cannot write the output over the input file {source}")
        if path.is_dir():
            raise FormatError(f"{path}: cannot write the output: it is a directory")
    for folder in folders:
        for source in sources:
            if _inside(source, folder) or _inside(folder, source):
                relation = "is or contains" if _inside(source, folder) else "lies inside"
                raise FormatError(
                    f"{folder}: cannot write the outputs there: the folder {relation} "
                    f"the input {source}"
                )
        if folder.exists() and not folder.is_dir():
            raise FormatError(f"{folder}: cannot create the output directory: it is a file")
    for path in files:
        parent = make_dirs(path.parent)
        if not os.access(parent, os.W_OK | os.X_OK):
            raise FormatError(f"{path}: cannot write the output: {parent} is not writable")
    for folder in folders:
        make_dirs(folder)
        if not os.access(folder, os.W_OK | os.X_OK):
            raise FormatError(f"{folder}: cannot write the outputs: it is not writable")
    return files


def check_output(
    target: str | os.PathLike[str], inputs: Iterable[str | os.PathLike[str]] = ()
) -> Path:
    """`check_outputs` for a single output file: fail early if it cannot be written."""
    return check_outputs([target], inputs)[0]


def _umask() -> int:
    """The process's umask (read by setting it and restoring it at once)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def file_mode() -> int:
    """The permissions a new output file gets: ``0o666`` less the umask (as ``open`` does)."""
    return 0o666 & ~_umask()


def dir_mode() -> int:
    """The permissions a new output folder gets: ``0o777`` less the umask (as ``mkdir`` does)."""
    return 0o777 & ~_umask()


@contextlib.contextmanager
def atomic_path(target: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside `target`; on success rename it onto `target`.

    The temporary file keeps the target's suffix, so writers that choose the format by
    extension (``cv2.imwrite``, ``numpy.save``) behave as for the target itself. On an
    exception the temporary file is removed and `target` is left untouched.

    Examples
    --------
    >>> with atomic_path("out/depth.png") as tmp:   # doctest: +SKIP
    ...     cv2.imwrite(str(tmp), image)
    """
    target_path = Path(target)
    if target_path.is_dir():
        raise FormatError(f"{target_path}: cannot write the output: it is a directory")
    make_dirs(target_path.parent)
    try:
        fd, tmp_name = tempfile.mkstemp(
            prefix=f".{target_path.name}.",
            suffix=f".tmp{target_path.suffix}",
            dir=target_path.parent,
        )
    except OSError as exc:
        raise FormatError(f"{target_path}: cannot write the output: {exc.strerror}") from None
    tmp = Path(tmp_name)
    try:
        # mkstemp creates the file 0600; an output gets what the umask gives, as with open()
        os.fchmod(fd, file_mode())
    finally:
        os.close(fd)
    try:
        yield tmp
        os.replace(tmp, target_path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        raise


def write_bytes_atomic(target: str | os.PathLike[str], data: bytes) -> None:
    """Write `data` to `target` atomically."""
    with atomic_path(target) as tmp:
        tmp.write_bytes(data)


def write_text_atomic(target: str | os.PathLike[str], text: str) -> None:
    """Write `text` (UTF-8) to `target` atomically."""
    write_bytes_atomic(target, text.encode("utf-8"))


#: Signals held back while a set of outputs is published: the set lands whole, then they act.
_PUBLISH_SIGNALS = {signal.SIGTERM, signal.SIGINT, signal.SIGHUP}


@contextlib.contextmanager
def output_lock(target: str | os.PathLike[str]) -> Iterator[Path]:
    """Hold an exclusive lock on writing `target` (a lock file ``.NAME.lock`` beside it).

    A second run into the same place fails at once (FormatError) instead of mixing its files
    with the first one's. The lock goes with the process (``flock``): a killed run leaves no
    stale lock, only the empty lock file.
    """
    path = Path(target)
    make_dirs(path.parent)
    lock = path.parent / f".{path.name}.lock"
    try:
        fd = os.open(lock, os.O_RDWR | os.O_CREAT, file_mode())
    except OSError as exc:
        raise FormatError(f"{path}: cannot create the lock {lock}: {exc.strerror}") from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise FormatError(
                f"{path}: another run is writing its outputs there (lock {lock})"
            ) from None
        yield lock
    finally:
        os.close(fd)


def check_publishable(target: str | os.PathLike[str], names: Iterable[str]) -> Path:
    """Fail early unless `target` is missing or a folder holding only files in `names`.

    `publish_dir` replaces the whole folder: anything else in it would be lost.
    """
    path = Path(target)
    if path.exists() and not path.is_dir():
        raise FormatError(f"{path}: cannot write the outputs: it is a file")
    if path.is_dir():
        foreign = sorted(p.name for p in path.iterdir() if p.name not in set(names))
        if foreign:
            raise FormatError(
                f"{path}: not an output folder of this command (it holds {foreign[0]}"
                f"{' and more' if len(foreign) > 1 else ''}); give a new or empty folder"
            )
    return path


@contextlib.contextmanager
def publish_dir(target: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a new folder beside `target`; on success it replaces `target` as a whole.

    The outputs are written into ``.NAME.new-*`` beside the target, then published by
    renames: the old folder aside, the new one into place, the old one removed. A reader sees
    the old set or the new set, never a mix. SIGTERM, SIGINT and SIGHUP are held back from
    the first file to the last rename (they act right after); on an error the new folder is
    removed and `target` is left as it was.
    """
    path = Path(target)
    make_dirs(path.parent)
    held = signal.pthread_sigmask(signal.SIG_BLOCK, _PUBLISH_SIGNALS)
    try:
        try:
            work = Path(tempfile.mkdtemp(prefix=f".{path.name}.new-", dir=path.parent))
        except OSError as exc:
            raise FormatError(f"{path}: cannot write the outputs: {exc.strerror}") from None
        try:
            os.chmod(work, dir_mode())  # mkdtemp makes it 0700
            yield work
            if path.exists():
                old = Path(tempfile.mkdtemp(prefix=f".{path.name}.old-", dir=path.parent))
                os.replace(path, old / path.name)
                os.replace(work, path)
                shutil.rmtree(old, ignore_errors=True)
            else:
                os.replace(work, path)
        except BaseException:
            shutil.rmtree(work, ignore_errors=True)
            raise
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, held)
