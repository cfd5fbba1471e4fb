"""Stereo calibrations in the common text forms, read into a `StereoCalib` (`aida-kb scene init`).

- **OpenCV FileStorage** (``.yaml``/``.yml``/``.xml``/``.json`` with K1 D1 K2 D2 R T
  image_width image_height): the scene format's own calib.yaml (`aida_kb.io.calib.read_calib`).
- **Middlebury** ``calib.txt`` (the 2014 stereo datasets): ``cam0=[f 0 cx; 0 f cy; 0 0 1]``,
  ``cam1=[...]``, ``baseline=`` in millimetres, ``width=``, ``height=``, ``ndisp=`` ... The images
  are rectified: R = I and the right camera sits `baseline` to the right (T = (-b, 0, 0)).
- **A pair of 3x4 projection matrices** (``P1: 12 numbers`` / ``P2: ...``, or ``P0``/``P1`` as
  KITTI writes them, ``=`` or ``:``, optionally as ``[a b c d; e f g h; i j k l]``): each is
  decomposed into K [R | t]; the left camera's frame becomes the rig's, x_right = R·x_left + T.

Every problem raises FormatError naming the file and the line (or the field).
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from aida_kb.errors import FormatError
from aida_kb.io.jsonio import read_text_file
from aida_kb.io.scene import FloatArray, StereoCalib, read_calib
from aida_kb.limits import MAX_CALIB_BYTES

CalibForm = Literal["opencv", "middlebury", "projection"]

MIDDLEBURY_UNIT_M = 1e-3
"""Middlebury's calib.txt gives the baseline in millimetres."""

_FILESTORAGE_SUFFIXES = (".yaml", ".yml", ".xml", ".json")
_KEY = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*[:=]\s*(.*?)\s*$")


@dataclass(frozen=True)
class TextCalib:
    """A calibration read from a file: the rig (image size (0, 0) where the file has none),
    the unit of its translations in metres (None: not known), and hints such as ndisp."""

    calib: StereoCalib | None
    K1: FloatArray
    K2: FloatArray
    R: FloatArray
    T: FloatArray
    size: tuple[int, int] | None
    unit_m: float | None
    form: CalibForm
    max_disp: int | None = None

    def rig(self, size: tuple[int, int], unit_m: float | None) -> StereoCalib:
        """The rig with image size `size` and its translation in metres (times `unit_m`)."""
        if self.calib is not None and unit_m in (None, 1.0):
            return self.calib
        factor = 1.0 if unit_m is None else unit_m
        D1 = self.calib.D1 if self.calib is not None else np.zeros(5)
        D2 = self.calib.D2 if self.calib is not None else np.zeros(5)
        return StereoCalib(self.K1, D1, self.K2, D2, self.R, self.T * factor, size)


def _text(file: Path) -> list[str]:
    return read_text_file(file, MAX_CALIB_BYTES).splitlines()


def _entries(file: Path) -> dict[str, tuple[int, str]]:
    """key -> (line number, value) of a key=value / key: value text file (# comments)."""
    out: dict[str, tuple[int, str]] = {}
    for i, line in enumerate(_text(file), start=1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        m = _KEY.match(line)
        if m is None:
            raise FormatError(f"{file}:{i}: expected KEY=VALUE or KEY: VALUE")
        if m.group(1) in out:
            raise FormatError(f"{file}:{i}: {m.group(1)} given twice")
        out[m.group(1)] = (i, m.group(2))
    return out


def _matrix(file: Path, line: int, key: str, value: str, rows: int, cols: int) -> FloatArray:
    body = value.strip().removeprefix("[").removesuffix("]")
    tokens = body.replace(";", " ").replace(",", " ").split()
    try:
        nums = [float(t) for t in tokens]
    except ValueError:
        raise FormatError(f"{file}:{line}: {key}: expected {rows}x{cols} numbers") from None
    if len(nums) != rows * cols:
        raise FormatError(f"{file}:{line}: {key}: has {len(nums)} numbers, expected {rows * cols}")
    if not all(math.isfinite(v) for v in nums):
        raise FormatError(f"{file}:{line}: {key}: contains NaN or infinity")
    return np.array(nums, dtype=np.float64).reshape(rows, cols)


def _camera_matrix(file: Path, line: int, key: str, K: FloatArray) -> FloatArray:
    if K[0, 0] <= 0 or K[1, 1] <= 0 or K[1, 0] != 0 or np.any(K[2] != [0.0, 0.0, 1.0]):
        raise FormatError(
            f"{file}:{line}: {key}: not a camera matrix "
            "(need [fx s cx; 0 fy cy; 0 0 1] with fx, fy > 0)"
        )
    return K


def _number(file: Path, entries: dict[str, tuple[int, str]], key: str) -> float | None:
    if key not in entries:
        return None
    line, value = entries[key]
    try:
        v = float(value)
    except ValueError:
        raise FormatError(f"{file}:{line}: {key}: expected a number, got {value[:30]!r}") from None
    if not math.isfinite(v):
        raise FormatError(f"{file}:{line}: {key}: not a finite number")
    return v


def _size(file: Path, entries: dict[str, tuple[int, str]]) -> tuple[int, int] | None:
    w, h = _number(file, entries, "width"), _number(file, entries, "height")
    if w is None or h is None:
        return None
    if not (w == int(w) > 0 and h == int(h) > 0):
        raise FormatError(f"{file}:{entries['width'][0]}: width/height must be positive integers")
    return int(w), int(h)


def read_middlebury(path: str | os.PathLike[str]) -> TextCalib:
    """Middlebury's calib.txt: cam0, cam1, baseline (mm), width, height, ndisp (optional)."""
    file = Path(path)
    entries = _entries(file)
    for key in ("cam0", "cam1", "baseline"):
        if key not in entries:
            raise FormatError(
                f"{file}: {key}: missing (a Middlebury calib.txt has cam0, cam1, baseline)"
            )
    K1, K2 = (
        _camera_matrix(file, entries[k][0], k, _matrix(file, entries[k][0], k, entries[k][1], 3, 3))
        for k in ("cam0", "cam1")
    )
    baseline = _number(file, entries, "baseline")
    assert baseline is not None
    if baseline <= 0:
        raise FormatError(f"{file}:{entries['baseline'][0]}: baseline: must be > 0 (millimetres)")
    ndisp = _number(file, entries, "ndisp")
    return TextCalib(
        calib=None,
        K1=K1,
        K2=K2,
        R=np.eye(3),
        T=np.array([-baseline, 0.0, 0.0]),
        size=_size(file, entries),
        unit_m=MIDDLEBURY_UNIT_M,
        form="middlebury",
        max_disp=None if ndisp is None or ndisp <= 0 else int(ndisp),
    )


PROJECTION_PAIRS = (("P1", "P2"), ("P0", "P1"), ("P2", "P3"))
"""The labels of a projection-matrix pair, tried in this order (P0/P1: KITTI's grey pair,
P2/P3: its colour pair)."""


def decompose_projection(P: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(K (3, 3) with K[2, 2] = 1 and a positive diagonal, R (3, 3) rotation, t (3,)) of a
    3x4 projection matrix P = λ·K [R | t]; ValueError if its left 3x3 block is singular."""
    import cv2

    M = P[:, :3]
    det = float(np.linalg.det(M))
    if not math.isfinite(det) or abs(det) <= 1e-12 * float(np.abs(M).max()) ** 3:
        raise ValueError("its left 3x3 block is singular: not a camera's projection")
    Pn = P * np.sign(det)  # then R = K^-1 M / λ has det > 0
    K, R, C, *_ = cv2.decomposeProjectionMatrix(Pn)
    S = np.diag(np.sign(np.diag(K)))
    K, R = K @ S, S @ R
    K = K / K[2, 2]
    K[1, 0] = K[2, 0] = K[2, 1] = 0.0
    centre = (C[:3] / C[3]).ravel()
    t = -R @ centre
    return K, R, t


def read_projection_pair(path: str | os.PathLike[str]) -> TextCalib:
    """A text file with two labelled 3x4 projection matrices (see PROJECTION_PAIRS)."""
    file = Path(path)
    entries = _entries(file)
    pair = next((p for p in PROJECTION_PAIRS if p[0] in entries and p[1] in entries), None)
    if pair is None:
        raise FormatError(
            f"{file}: no projection-matrix pair (labels P1/P2, P0/P1 or P2/P3); found "
            f"{', '.join(sorted(entries)) or 'nothing'}"
        )
    cams = []
    for key in pair:
        line, value = entries[key]
        P = _matrix(file, line, key, value, 3, 4)
        try:
            cams.append(decompose_projection(P))
        except ValueError as exc:
            raise FormatError(f"{file}:{line}: {key}: {exc}") from None
    (K1, R1, t1), (K2, R2, t2) = cams
    R = R2 @ R1.T
    T = t2 - R @ t1
    if np.linalg.norm(T) <= 1e-12 * max(1.0, float(np.linalg.norm(t1))):
        raise FormatError(
            f"{file}: {pair[0]} and {pair[1]} have the same camera centre: no baseline"
        )
    return TextCalib(None, K1, K2, R, T, _size(file, entries), 1.0, "projection")


def read_any_calib(path: str | os.PathLike[str]) -> TextCalib:
    """A stereo calibration in any of the forms above, told apart by suffix and content."""
    file = Path(path)
    if not file.is_file():
        raise FormatError(f"{file}: no such file" if not file.exists() else f"{file}: not a file")
    if file.suffix.lower() in _FILESTORAGE_SUFFIXES:
        calib = read_calib(file)
        return TextCalib(
            calib, calib.K1, calib.K2, calib.R, calib.T, calib.image_size, 1.0, "opencv"
        )
    keys = _entries(file)
    if "cam0" in keys or "cam1" in keys:
        return read_middlebury(file)
    if any(p[0] in keys for p in PROJECTION_PAIRS):
        return read_projection_pair(file)
    raise FormatError(
        f"{file}: not a calibration aida-kb reads (an OpenCV FileStorage .yaml/.xml/.json, a "
        "Middlebury calib.txt with cam0/cam1/baseline, or a P1/P2 projection-matrix pair)"
    )
