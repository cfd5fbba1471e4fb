"""Hostile files are refused by the limits (`aida_kb.limits`) with one line naming the file.

Each case crashed or ran away before: deep JSON/YAML (RecursionError, "internal error"), a
50,000-deep calib.yaml (SIGSEGV inside OpenCV), a 5,000-digit number (int conversion limit),
a PNG header claiming more than 2**30 pixels, a FIFO (hangs), /dev/zero (reads forever).
"""

from __future__ import annotations

import os
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest

from aida_kb.errors import FormatError
from aida_kb.io.evidence import read_evidence
from aida_kb.io.model import read_model
from aida_kb.io.scene import (
    StereoCalib,
    ViewData,
    read_calib,
    read_depth,
    read_image,
    read_labels,
    read_scene,
    write_scene,
)
from aida_kb.limits import MAX_NESTING, image_header_size, read_limited


def _one_line(exc: pytest.ExceptionInfo[FormatError], file: Path) -> str:
    message = str(exc.value)
    assert "\n" not in message
    assert message.startswith(str(file))
    return message


@pytest.mark.parametrize("reader", [read_evidence, read_model])
def test_json_nested_5000_deep(tmp_path: Path, reader: object) -> None:
    file = tmp_path / "deep.json"
    file.write_text('{"format": ' + "[" * 5000 + "]" * 5000 + "}")
    with pytest.raises(FormatError) as exc:
        reader(file)  # type: ignore[operator]
    assert f"nested more than {MAX_NESTING} deep" in _one_line(exc, file)


@pytest.mark.parametrize("reader", [read_evidence, read_model])
def test_json_5000_digit_number(tmp_path: Path, reader: object) -> None:
    file = tmp_path / "big.json"
    file.write_text('{"version": ' + "9" * 5000 + "}")
    with pytest.raises(FormatError) as exc:
        reader(file)  # type: ignore[operator]
    assert "a number longer than" in _one_line(exc, file)


def _scene(tmp_path: Path) -> Path:
    K = np.array([[60.0, 0.0, 31.5], [0.0, 60.0, 23.5], [0.0, 0.0, 1.0]])
    calib = StereoCalib(K, np.zeros(5), K, np.zeros(5), np.eye(3), np.array([-0.3, 0, 0]), (64, 48))
    img = np.zeros((48, 64, 3), np.uint8)
    return write_scene(tmp_path / "scene", calib, [ViewData(img, img.copy())])


def test_scene_yaml_nested_500_deep(tmp_path: Path) -> None:
    scene = _scene(tmp_path)
    index = scene / "scene.yaml"
    index.write_text(index.read_text() + "extra: " + "[" * 500 + "]" * 500 + "\n")
    with pytest.raises(FormatError) as exc:
        read_scene(scene)
    assert "nested more than" in _one_line(exc, index)


def test_scene_yaml_aliases_are_refused(tmp_path: Path) -> None:
    scene = _scene(tmp_path)
    index = scene / "scene.yaml"
    laughs = "a: &a [x, x, x, x, x, x, x, x, x]\n"
    for i in range(8):
        laughs += f"{chr(98 + i)}: &{chr(98 + i)} [{', '.join(['*' + chr(97 + i)] * 9)}]\n"
    index.write_text(index.read_text() + laughs)
    with pytest.raises(FormatError) as exc:
        read_scene(scene)
    assert "aliases" in _one_line(exc, index)


def test_calib_nested_50000_deep_never_reaches_opencv(tmp_path: Path) -> None:
    scene = _scene(tmp_path)
    calib = scene / "calib.yaml"
    calib.write_text(calib.read_text() + "deep: " + "[" * 50000 + "]" * 50000 + "\n")
    with pytest.raises(FormatError) as exc:
        read_calib(calib)
    assert "nested more than" in _one_line(exc, calib)


def _png_header(width: int, height: int) -> bytes:
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    chunk = b"IHDR" + ihdr
    return (
        b"\x89PNG\r\n\x1a\n"
        + struct.pack(">I", len(ihdr))
        + chunk
        + struct.pack(">I", zlib.crc32(chunk))
    )


def test_png_header_over_the_pixel_limit_is_refused_unread(tmp_path: Path) -> None:
    file = tmp_path / "huge.png"
    file.write_bytes(_png_header(40000, 40000) + b"\0" * 64)
    assert image_header_size(file.read_bytes()) == (40000, 40000)
    for reader in (read_image, read_labels):
        with pytest.raises(FormatError) as exc:
            reader(file)
        assert "40000x40000 pixels, more than the limit" in _one_line(exc, file)


def test_npy_header_over_the_pixel_limit_is_refused_unread(tmp_path: Path) -> None:
    file = tmp_path / "depth.npy"
    header = {"descr": "<f4", "fortran_order": False, "shape": (40000, 40000)}
    with file.open("wb") as fh:
        np.lib.format.write_array_header_1_0(fh, header)
    with pytest.raises(FormatError) as exc:
        read_depth(file)
    assert "more than the limit" in _one_line(exc, file)


def test_fifo_and_device_are_refused_without_blocking(tmp_path: Path) -> None:
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    for path in (fifo, Path("/dev/zero")):
        with pytest.raises(OSError, match="not a regular file"):
            read_limited(path, 1024)
    with pytest.raises(FormatError) as exc:
        read_model(fifo)
    assert "not a regular file" in _one_line(exc, fifo)


def test_a_file_over_its_size_limit_is_refused_before_reading(tmp_path: Path) -> None:
    file = tmp_path / "big.bin"
    with file.open("wb") as fh:
        fh.truncate(10_000)  # sparse: size without content
    with pytest.raises(OSError, match="more than the limit"):
        read_limited(file, 1000)


def test_lint_refuses_a_fifo_and_dev_zero(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from aida_kb.cli.main import main

    fifo = tmp_path / "x.kb"
    os.mkfifo(fifo)
    for path in (str(fifo), "/dev/zero"):
        assert main(["lint", path]) == 2
        err = capsys.readouterr().err
        assert f"{path}: cannot read: not a regular file" in err


@pytest.mark.parametrize("what", ["image", "views folder", "calibration"])
def test_symlinks_out_of_the_scene_are_refused(tmp_path: Path, what: str) -> None:
    scene = _scene(tmp_path)
    outside = tmp_path / "outside"
    outside.mkdir()
    if what == "image":
        left = next(scene.rglob("left.png"))
        (outside / "left.png").write_bytes(left.read_bytes())
        left.unlink()
        left.symlink_to(outside / "left.png")
    elif what == "views folder":
        (scene / "views").rename(outside / "views")
        (scene / "views").symlink_to(outside / "views")
    else:
        (scene / "calib.yaml").rename(outside / "calib.yaml")
        (scene / "calib.yaml").symlink_to(outside / "calib.yaml")
    with pytest.raises(FormatError) as exc:
        read_scene(scene)
    assert "leads outside the scene directory" in _one_line(exc, scene / "scene.yaml")


def test_a_fifo_in_the_scene_is_refused(tmp_path: Path) -> None:
    scene = _scene(tmp_path)
    left = next(scene.rglob("left.png"))
    left.unlink()
    os.mkfifo(left)
    with pytest.raises(FormatError) as exc:
        read_scene(scene)
    assert "not a regular file" in _one_line(exc, scene / "scene.yaml")


def test_a_10000x6500_scene_is_refused_with_the_figure_before_any_image(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Matched at the working resolution, a 65-megapixel scene still needs more than the
    budget for its full images; a 48-megapixel one (8000x6000) fits."""
    from aida_kb.cli.main import main
    from aida_kb.io.scene import memory_problem, write_calib

    assert memory_problem(8000, 6000) is None
    scene = _scene(tmp_path)
    K = np.array([[6000.0, 0.0, 4999.5], [0.0, 6000.0, 3249.5], [0.0, 0.0, 1.0]])
    big = StereoCalib(
        K, np.zeros(5), K, np.zeros(5), np.eye(3), np.array([-0.3, 0, 0]), (10000, 6500)
    )
    write_calib(scene / "calib.yaml", big)
    with pytest.raises(FormatError) as exc:
        read_scene(scene)
    message = _one_line(exc, scene / "calib.yaml")
    assert "images of 10000x6500 pixels need about 4.2 GiB (matched at 1754x1140)" in message
    assert "more than the memory budget of 4.0 GiB" in message
    assert main(["evidence", str(scene), "-o", str(tmp_path / "ev.json"), "--quiet"]) == 2
    assert "memory budget" in capsys.readouterr().err


def test_a_corrupt_png_gives_one_line_not_libpng_s(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    import cv2

    from aida_kb.cli.main import main

    ok, encoded = cv2.imencode(".png", np.arange(48 * 64, dtype=np.uint8).reshape(48, 64))
    assert ok
    data = bytearray(encoded.tobytes())
    data[60] ^= 0xFF  # inside IDAT: a CRC error
    bad = tmp_path / "bad.png"
    bad.write_bytes(bytes(data))
    assert main(["disparity", str(bad), str(bad), "-o", str(tmp_path / "d.npy")]) == 2
    err = capfd.readouterr().err
    assert err.strip().splitlines() == [f"aida-kb: error: {bad}: not a readable image"]


def test_found_by_fuzzing_control_character_and_overlong_path(tmp_path: Path) -> None:
    scene = _scene(tmp_path)
    index = scene / "scene.yaml"
    text = index.read_text()
    index.write_text(text.replace("calib.yaml", "calib\x0f.yaml"))
    with pytest.raises(FormatError) as exc:
        read_scene(scene)
    assert "not valid YAML" in _one_line(exc, index)
    index.write_text(text.replace("calib.yaml", "calib" + "(" * 5000 + ".yaml"))
    with pytest.raises(FormatError) as exc:
        read_scene(scene)
    assert "field calib: not a usable path" in _one_line(exc, index)


def test_more_than_100_views_are_refused(tmp_path: Path) -> None:
    scene = _scene(tmp_path)
    index = scene / "scene.yaml"
    lines = index.read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("views:"))
    entry = lines[start + 1 :]
    views = [
        line.replace("'00'", f"'{n:03d}'") if "id:" in line else line
        for n in range(101)
        for line in entry
        if line.startswith(" ") or line.startswith("-")
    ]
    index.write_text("\n".join([*lines[: start + 1], *views]) + "\n")
    with pytest.raises(FormatError) as exc:
        read_scene(scene)
    assert "views" in _one_line(exc, index)
    assert "at most 100" in str(exc.value)
