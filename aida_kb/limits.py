"""Limits as policy: the largest inputs aida-kb reads, checked before any large allocation.

Every reader goes through here (`docs/formats.md`, "Outputs, limits and safety", lists the
figures): a file must be a regular file (no FIFO that blocks, no ``/dev/zero`` that never
ends) of at most its kind's size; JSON and YAML may nest at most `MAX_NESTING` deep and write
no number longer than `MAX_NUMBER_CHARS` characters (Python's parsers recurse, and a
5,000-digit integer exceeds ``int``'s conversion limit); an image may have at most
`MAX_IMAGE_PIXELS` pixels, read from its header before it is decoded.

Standard library only: the ``.kb`` front end (`lint`, `validate`) reads through here too.
"""

from __future__ import annotations

import errno
import os
import re
import stat

__all__ = [
    "MAX_CALIB_BYTES",
    "MAX_IMAGE_BYTES",
    "MAX_IMAGE_PIXELS",
    "MAX_IMAGE_SIDE",
    "MAX_JSON_BYTES",
    "MAX_KB_BYTES",
    "MAX_NESTING",
    "MAX_NUMBER_CHARS",
    "MAX_VIEWS",
    "MAX_YAML_BYTES",
    "image_header_size",
    "image_size_problem",
    "memory_budget",
    "memory_problem",
    "nesting_problem",
    "read_limited",
    "read_text_limited",
]

#: A ``.kb`` file: kb/buildings.kb is 20 kB; a 10,000-concept knowledge base about 2 MB.
MAX_KB_BYTES = 16 * 2**20
#: evidence, model, interpretation and truth JSON: 20 views of evidence stay below 20 MB.
MAX_JSON_BYTES = 256 * 2**20
#: scene.yaml: a list of views and file names (20 views take 2 kB).
MAX_YAML_BYTES = 2**20
#: calib.yaml: eight small matrices (OpenCV writes 2 kB).
MAX_CALIB_BYTES = 2**20
#: JSON/YAML containers inside one another; the formats nest at most 8 deep, Python's parsers
#: recurse per level (the interpreter's limit is 1000 frames).
MAX_NESTING = 64
#: Characters of one number in JSON/YAML (a float64 needs 24; more is not a measurement).
MAX_NUMBER_CHARS = 64
#: Image side and pixel count, read from the file's header before decoding. 2**26 pixels is
#: 8192x8192: 192 MB decoded in colour; the memory budget of a run (`aida_kb.vision`) is
#: checked separately from the scene's image size.
MAX_IMAGE_SIDE = 2**15
MAX_IMAGE_PIXELS = 2**26


def read_text_limited(path: str | os.PathLike[str], limit: int) -> str:
    """`read_limited` decoded as UTF-8 with universal newlines (as ``open(path).read()``).

    Raises OSError (see `read_limited`) or UnicodeDecodeError.
    """
    text = read_limited(path, limit).decode("utf-8")
    return text.replace("\r\n", "\n").replace("\r", "\n") if "\r" in text else text


def _sizes(n: int) -> str:
    return f"{n / 2**20:.0f} MiB" if n >= 2**20 else f"{n} bytes"


def read_limited(path: str | os.PathLike[str], limit: int) -> bytes:
    """The bytes of `path`, which must be a regular file of at most `limit` bytes.

    Raises `OSError` whose ``strerror`` says why (readers already turn an OSError into their
    one-line message): a FIFO, device or directory is refused without blocking or reading
    (``lint /dev/zero`` would read forever, a FIFO without a writer would wait forever).
    """
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            kind = "a directory" if stat.S_ISDIR(info.st_mode) else "a device, FIFO or socket"
            raise OSError(errno.EINVAL, f"not a regular file ({kind})")
        if info.st_size > limit:
            raise OSError(
                errno.EFBIG,
                f"{_sizes(info.st_size)}, more than the limit of {_sizes(limit)} for this kind "
                "of file",
            )
        with os.fdopen(fd, "rb", closefd=False) as fh:
            data = fh.read(limit + 1)  # a file that grows while read still stops here
    finally:
        os.close(fd)
    if len(data) > limit:
        raise OSError(errno.EFBIG, f"more than the limit of {_sizes(limit)} for this kind of file")
    return data


# Every byte but the number characters -> a space, number characters -> "9"; brackets kept.
_NUMBER_BYTES = b"0123456789.eE+-_"
_AS_NUMBERS = bytes(ord("9") if b in _NUMBER_BYTES else ord(" ") for b in range(256))
_AS_BRACKETS = bytes(ord("[") if b in b"[{" else ord("]") if b in b"]}" else 0 for b in range(256))
_DEEP_INDENT = re.compile(rb"^[ \t-]{" + str(2 * MAX_NESTING).encode() + rb",}", re.M)
_XML_TAG = re.compile(rb"<(/?)[A-Za-z_][^<>]*?(/?)>")


def _line_col(data: bytes, pos: int) -> str:
    line = data.count(b"\n", 0, pos) + 1
    column = pos - (data.rfind(b"\n", 0, pos) + 1) + 1
    return f"{line}:{column}"


def _too_deep(data: bytes) -> bool:
    """True when brackets (``[ ]`` and ``{ }``) nest more than `MAX_NESTING` deep.

    Each round deletes every innermost pair; a nesting of depth d is gone after d rounds, so
    MAX_NESTING rounds of C-speed replaces decide (unmatched brackets never count as depth).
    """
    brackets = data.translate(_AS_BRACKETS).replace(b"\0", b"")
    for _ in range(MAX_NESTING):
        if b"[]" not in brackets:
            return False
        brackets = brackets.replace(b"[]", b"")
    return b"[]" in brackets


def nesting_problem(text: str, *, indentation: bool = False, xml: bool = False) -> str | None:
    """Why `text` (JSON, YAML or OpenCV FileStorage) is refused before parsing, or None.

    Checks the nesting of brackets against `MAX_NESTING` and the length of every run of number
    characters against `MAX_NUMBER_CHARS` (inside strings too: conservative, and linear at
    C speed); with `indentation` also block-style nesting (a line indented more than
    ``2 * MAX_NESTING`` columns), with `xml` the depth of XML elements. The answer is
    ``"LINE:COL: why"``, ready to follow the file name.
    """
    data = text.encode("utf-8", "surrogatepass")
    run = data.translate(_AS_NUMBERS).find(b"9" * (MAX_NUMBER_CHARS + 1))
    if run >= 0:
        return f"{_line_col(data, run)}: a number longer than {MAX_NUMBER_CHARS} characters"
    if _too_deep(data):
        return f"1:1: nested more than {MAX_NESTING} deep"
    if indentation:
        deep = _DEEP_INDENT.search(data)
        if deep is not None:
            return f"{_line_col(data, deep.start())}: nested more than {MAX_NESTING} deep"
    if xml:
        depth = 0
        for m in _XML_TAG.finditer(data):
            if m.group(2):
                continue
            depth += -1 if m.group(1) else 1
            if depth > MAX_NESTING:
                return f"{_line_col(data, m.start())}: nested more than {MAX_NESTING} deep"
    return None


#: Views of one scene: each costs a whole evidence run (a building needs 2 to 20).
MAX_VIEWS = 100

#: An image file (PNG of 2**26 pixels in 16-bit colour stays below this).
MAX_IMAGE_BYTES = 512 * 2**20

_JPEG_SOF = frozenset(
    {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}
)


def _jpeg_size(data: bytes) -> tuple[int, int] | None:
    pos = 2
    while pos + 9 <= len(data):
        if data[pos] != 0xFF:
            return None
        marker = data[pos + 1]
        if marker == 0xFF:  # fill byte
            pos += 1
            continue
        if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:  # no length field
            pos += 2
            continue
        length = int.from_bytes(data[pos + 2 : pos + 4], "big")
        if marker in _JPEG_SOF:
            height = int.from_bytes(data[pos + 5 : pos + 7], "big")
            width = int.from_bytes(data[pos + 7 : pos + 9], "big")
            return width, height
        pos += 2 + length
    return None


def _pnm_size(data: bytes) -> tuple[int, int] | None:
    fields = re.match(
        rb"P[1-6](?:\s+|#[^\n]*\n)+([0-9]{1,10})(?:\s+|#[^\n]*\n)+([0-9]{1,10})", data
    )
    return (int(fields.group(1)), int(fields.group(2))) if fields else None


def image_header_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) from the header of a PNG, JPEG, BMP or PNM file; None for another
    format (or a header too short to say). Nothing is decoded."""
    if data.startswith(b"\x89PNG\r\n\x1a\n") and len(data) >= 24 and data[12:16] == b"IHDR":
        return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
    if data.startswith(b"\xff\xd8"):
        return _jpeg_size(data)
    if data.startswith(b"BM") and len(data) >= 26:
        width = int.from_bytes(data[18:22], "little", signed=True)
        height = int.from_bytes(data[22:26], "little", signed=True)
        return abs(width), abs(height)
    if data[:1] == b"P" and data[1:2] in b"123456":
        return _pnm_size(data[:1024])
    return None


def image_size_problem(width: int, height: int) -> str | None:
    """Why an image of `width` x `height` pixels is refused before decoding, or None."""
    if width <= 0 or height <= 0:
        return f"the header gives an empty image ({width}x{height})"
    if max(width, height) > MAX_IMAGE_SIDE or width * height > MAX_IMAGE_PIXELS:
        return (
            f"{width}x{height} pixels, more than the limit of {MAX_IMAGE_PIXELS:,} pixels "
            f"({MAX_IMAGE_SIDE} a side)"
        )
    return None


#: Peak memory of a run per pixel of the scene's images: `aida-kb evidence` measured 215 MB at
#: 640x480 and 1.64 GB at 2560x1920 (about 290 bytes a pixel: pyramids, cost volumes, depth).
BYTES_PER_PIXEL = 300
#: The memory a run may plan for, unless AIDA_KB_MEMORY_GB says otherwise: 4 GiB (a scene of
#: about 14 megapixels, e.g. 4368x3276).
MEMORY_BUDGET_BYTES = 4 * 2**30
MEMORY_BUDGET_ENV = "AIDA_KB_MEMORY_GB"


def memory_budget() -> int:
    """The memory budget of a run in bytes: ``$AIDA_KB_MEMORY_GB`` GiB, else the default."""
    value = os.environ.get(MEMORY_BUDGET_ENV, "")
    try:
        gib = float(value)
    except ValueError:
        return MEMORY_BUDGET_BYTES
    return int(gib * 2**30) if gib > 0 and gib == gib and gib < 2**20 else MEMORY_BUDGET_BYTES


def memory_problem(width: int, height: int) -> str | None:
    """Why a scene of `width` x `height` images is over the memory budget of a run, or None."""
    need = BYTES_PER_PIXEL * width * height
    budget = memory_budget()
    if need <= budget:
        return None
    return (
        f"images of {width}x{height} pixels need about {need / 2**30:.1f} GiB "
        f"({BYTES_PER_PIXEL} bytes a pixel), more than the memory budget of "
        f"{budget / 2**30:.1f} GiB (set {MEMORY_BUDGET_ENV} to change it)"
    )
