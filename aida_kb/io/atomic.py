"""Atomic file output: write to a temporary file beside the target, then rename.

A crash or an error half-way never leaves a truncated or half-written output file behind.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path


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
    target_path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(
        prefix=f".{target_path.name}.", suffix=f".tmp{target_path.suffix}", dir=target_path.parent
    )
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
