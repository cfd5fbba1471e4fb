"""Atomic file output: write to a temporary file beside the target, then rename.

A crash or an error half-way never leaves a truncated or half-written output file behind.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterable, Iterator
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


def check_output(
    target: str | os.PathLike[str], inputs: Iterable[str | os.PathLike[str]] = ()
) -> Path:
    """Fail early (FormatError) if `target` cannot be written; create its folder if missing.

    For commands that work for a while before writing: a wrong ``-o`` is reported at once.
    `inputs` are the files the command reads; writing over one of them is refused too.
    """
    path = Path(target)
    for source in inputs:
        if Path(source).exists() and path.exists() and path.samefile(source):
            raise FormatError(f"{path}: cannot write the output over the input file {source}")
    if path.is_dir():
        raise FormatError(f"{path}: cannot write the output: it is a directory")
    folder = make_dirs(path.parent)
    if not os.access(folder, os.W_OK | os.X_OK):
        raise FormatError(f"{path}: cannot write the output: {folder} is not writable")
    return path


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
    os.close(fd)
    tmp = Path(tmp_name)
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
