"""A scene's image files: view images, label images and depth maps, read within the limits of
`aida_kb.limits` (every problem a one-line `FormatError` naming the file) and written
atomically."""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterator
from pathlib import Path
from tokenize import TokenError
from typing import Any

import numpy as np
import numpy.typing as npt

from aida_kb.errors import FormatError
from aida_kb.io.atomic import atomic_path
from aida_kb.limits import MAX_IMAGE_BYTES, image_header_size, image_size_problem, read_limited

__all__ = ["read_depth", "read_image", "read_labels", "write_npy", "write_png"]


def _existing_file(file: Path) -> Path:
    """`file`, or a FormatError saying that there is none (before OpenCV logs its own)."""
    if not file.is_file():
        raise FormatError(f"{file}: no such file" if not file.exists() else f"{file}: not a file")
    return file


def _image_bytes(file: Path) -> npt.NDArray[np.uint8]:
    """The encoded bytes of an image file whose header size is within the limits.

    A regular file of at most `MAX_IMAGE_BYTES`; PNG, JPEG, BMP and PNM headers are read
    before anything is decoded (a 20000x15000 PNG is refused unread), other formats are
    checked once decoded (`_decoded`).
    """
    _existing_file(file)
    try:
        data = read_limited(file, MAX_IMAGE_BYTES)
    except OSError as exc:
        raise FormatError(f"{file}: cannot be read: {exc.strerror or exc}") from None
    size = image_header_size(data)
    problem = None if size is None else image_size_problem(*size)
    if problem is not None:
        raise FormatError(f"{file}: {problem}")
    return np.frombuffer(data, np.uint8)


@contextlib.contextmanager
def _quiet_stderr() -> Iterator[None]:
    """Silence file descriptor 2 (libpng and libjpeg print their own lines on a broken file;
    the one-line FormatError says it instead)."""
    try:
        saved = os.dup(2)
        devnull = os.open(os.devnull, os.O_WRONLY)
    except OSError:  # no descriptor to spare: let the libraries speak
        yield
        return
    try:
        sys.stderr.flush()
        os.dup2(devnull, 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(devnull)


def _decoded(file: Path, data: npt.NDArray[np.uint8], flags: int) -> npt.NDArray[Any]:
    import cv2

    with _quiet_stderr():
        img = cv2.imdecode(data, flags) if data.size else None
    if img is None:
        raise FormatError(f"{file}: not a readable image")
    problem = image_size_problem(img.shape[1], img.shape[0])
    if problem is not None:
        raise FormatError(f"{file}: {problem}")
    return np.asarray(img)


def read_image(path: str | os.PathLike[str], *, grey: bool = False) -> npt.NDArray[np.uint8]:
    """Load an 8-bit view image: (H, W) if grey, else (H, W, 3) BGR (grey files are expanded)."""
    import cv2

    file = Path(path)
    data = _image_bytes(file)
    # look at the stored depth first: IMREAD_COLOR would silently scale 16 bits down to 8
    raw = _decoded(file, data, cv2.IMREAD_UNCHANGED)
    if raw.dtype != np.uint8:
        raise FormatError(f"{file}: expected an 8-bit image, got {raw.dtype}")
    del raw
    img = _decoded(file, data, cv2.IMREAD_GRAYSCALE if grey else cv2.IMREAD_COLOR)
    return np.asarray(img, dtype=np.uint8)


def read_labels(path: str | os.PathLike[str]) -> npt.NDArray[np.uint16]:
    """Load a 16-bit label image (H, W); 0 = unlabelled."""
    import cv2

    file = Path(path)
    img = _decoded(file, _image_bytes(file), cv2.IMREAD_UNCHANGED)
    if img.ndim != 2:
        raise FormatError(f"{file}: a label image must have one channel, has {img.shape[2]}")
    if img.dtype not in (np.uint16, np.uint8):
        raise FormatError(f"{file}: a label image must be 8- or 16-bit, got {img.dtype}")
    return np.asarray(img, dtype=np.uint16)


def read_depth(path: str | os.PathLike[str]) -> npt.NDArray[np.float32]:
    """Load a depth map (H, W) float32, metres along the left camera's z axis, NaN = none."""
    file = Path(path)
    try:
        # the header first: a shape beyond the image limit is refused before the array is read
        with _existing_file(file).open("rb") as fh:
            fmt = np.lib.format
            version = fmt.read_magic(fh)
            read_header = (
                fmt.read_array_header_1_0 if version == (1, 0) else fmt.read_array_header_2_0
            )
            shape, _, _ = read_header(fh)
    except (OSError, ValueError, SyntaxError, TokenError) as exc:  # numpy parses the header
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise FormatError(f"{file}: not a numpy .npy array: {why}") from None
    if len(shape) == 2:
        problem = image_size_problem(shape[1], shape[0])
        if problem is not None:
            raise FormatError(f"{file}: {problem}")
    try:
        arr = np.load(file, allow_pickle=False)
    except (OSError, ValueError) as exc:
        raise FormatError(f"{file}: not a numpy .npy array: {exc}") from None
    if arr.ndim != 2 or arr.dtype != np.float32:
        raise FormatError(
            f"{file}: expected a 2-D float32 depth map, got {arr.dtype} of shape {arr.shape}"
        )
    known = arr[~np.isnan(arr)]
    if known.size and not (np.all(np.isfinite(known)) and known.min() > 0):
        raise FormatError(f"{file}: depths must be positive finite metres (NaN = no surface)")
    return np.asarray(arr, dtype=np.float32)


def write_png(path: Path, image: npt.NDArray[Any]) -> None:
    """Write an 8- or 16-bit image as PNG, atomically."""
    import cv2

    with atomic_path(path) as tmp:
        if not cv2.imwrite(str(tmp), image, [cv2.IMWRITE_PNG_COMPRESSION, 3]):
            raise FormatError(f"{path}: could not be written as PNG")


def write_npy(path: Path, array: npt.NDArray[Any]) -> None:
    """Write an array as .npy (no pickles), atomically."""
    with atomic_path(path) as tmp, tmp.open("wb") as fh:
        np.save(fh, array, allow_pickle=False)
