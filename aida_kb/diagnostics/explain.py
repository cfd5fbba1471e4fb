"""Long explanations of the diagnostic codes, one Markdown file per code.

Each code ``KBnnn`` of the registry (`aida_kb.diagnostics.codes`) has a file
``aida_kb/diagnostics/explanations/KBnnn.md`` of this form::

    # KB003: unknown unit

    What the code means, why it is a problem and how to fix it.

    ## Bad

    ```kb
    ...a minimal file that gets the diagnostic...
    ```

    ## Fixed

    ```kb
    ...the same file, corrected...
    ```

``aida-kb explain CODE`` prints the file; ``docs/diagnostics.md`` is generated from the
registry and these files (``python -m aida_kb.diagnostics.docs``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from importlib import resources

from aida_kb.diagnostics import codes

__all__ = ["Explanation", "available", "explanation", "normalize_code"]

_FENCE = re.compile(r"^## (Bad|Fixed)\s*\n+```kb\n(.*?)^```", re.M | re.S)
_CODE = re.compile(r"(?i)^(?:kb)?(\d{1,3})$")


@dataclass(frozen=True, slots=True)
class Explanation:
    """One code's explanation: the title line, the whole Markdown text and its two examples."""

    code: str
    title: str
    text: str
    bad: str | None
    fixed: str | None


def normalize_code(text: str) -> str | None:
    """``"kb3"``, ``"3"``, ``"KB003"`` -> ``"KB003"``; None when `text` is not a code."""
    m = _CODE.match(text.strip())
    return f"KB{int(m.group(1)):03d}" if m else None


def _directory() -> resources.abc.Traversable:
    return resources.files("aida_kb.diagnostics").joinpath("explanations")


def available() -> list[str]:
    """The codes that have an explanation file, sorted."""
    directory = _directory()
    if not directory.is_dir():
        return []
    names = (entry.name for entry in directory.iterdir())
    return sorted(
        n.removesuffix(".md") for n in names if n.endswith(".md") and normalize_code(n[:-3])
    )


def parse_explanation(code: str, text: str) -> Explanation:
    """Split an explanation file into title, text and its ``Bad``/``Fixed`` examples."""
    first = text.split("\n", 1)[0]
    title = first.lstrip("#").strip()
    prefix = f"{code}:"
    if title.startswith(prefix):
        title = title[len(prefix) :].strip()
    examples = {kind: body for kind, body in _FENCE.findall(text)}
    return Explanation(code, title, text, examples.get("Bad"), examples.get("Fixed"))


def explanation(code: str) -> Explanation | None:
    """The explanation of `code` (any spelling `normalize_code` accepts), or None.

    Returns None for a code that is neither registered nor has a file.
    """
    normal = normalize_code(code)
    if normal is None:
        return None
    entry = _directory().joinpath(f"{normal}.md")
    if not entry.is_file():
        if codes.lookup(normal) is None:
            return None
        registered = codes.REGISTRY[normal]
        # A registered code without its file still gets its one-line summary.
        return Explanation(
            normal, registered.summary, f"# {normal}: {registered.summary}\n", None, None
        )
    return parse_explanation(normal, entry.read_text(encoding="utf-8"))
