"""Role paths as values: ``roof.front``, ``oriels[1].left``, the root ``""``.

A `RolePath` is a sequence of `Step` s (a role name and, for a role with several fillers, the
filler's index). Paths are *interned*: one object per distinct path, so a path is parsed once,
compared and hashed by identity cost, and joined, split and made relative by its steps, never
by re-reading a dotted string. The dotted spelling (DOMAIN.md) is what `str` gives: text in
messages and JSON is made from the path at the edge, and text read from the user or a file
becomes a path by `RolePath.parse`, once.

Kept free of pydantic and numpy: the compiler's light path imports it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

__all__ = ["ROOT", "RolePath", "Step"]

_NAME_START = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz_")
_NAME_REST = _NAME_START | frozenset("0123456789")


@dataclass(frozen=True, slots=True, order=True)
class Step:
    """One step of a role path: a role name and the filler's index (None: not indexed)."""

    role: str
    index: int | None = None

    def __str__(self) -> str:
        return self.role if self.index is None else f"{self.role}[{self.index}]"

    @staticmethod
    def parse(text: str) -> Step:
        """``front`` or ``oriels[1]``; ValueError for anything else."""
        role, bracket, rest = text.partition("[")
        if not role or role[0] not in _NAME_START or any(c not in _NAME_REST for c in role):
            raise ValueError(f"not a role name: {text!r}")
        if not bracket:
            return Step(role)
        digits = rest[:-1]
        if not rest.endswith("]") or not digits.isdigit() or not digits.isascii():
            raise ValueError(f"not a role with an index: {text!r}")
        return Step(role, int(digits))


class RolePath:
    """An interned role path (see the module doc). ``RolePath(steps)`` gives the one object of
    those steps; `ROOT` (no steps) is the path of the instance itself."""

    __slots__ = ("_text", "steps")
    _interned: ClassVar[dict[tuple[Step, ...], RolePath]] = {}
    _parsed: ClassVar[dict[str, RolePath]] = {}
    steps: tuple[Step, ...]
    _text: str

    def __new__(cls, steps: tuple[Step, ...] = ()) -> RolePath:
        found = cls._interned.get(steps)
        if found is None:
            found = super().__new__(cls)
            object.__setattr__(found, "steps", steps)
            object.__setattr__(found, "_text", ".".join(str(s) for s in steps))
            cls._interned[steps] = found
        return found

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError("a RolePath is immutable")

    def __reduce__(self) -> tuple[type[RolePath], tuple[tuple[Step, ...]]]:
        return (RolePath, (self.steps,))  # unpickled paths are interned again

    @classmethod
    def parse(cls, text: str) -> RolePath:
        """The path of a dotted spelling; ``""`` and ``"self"`` are `ROOT`.

        Raises
        ------
        ValueError
            If ``text`` is no role path (an empty step, a bad name or index).
        """
        found = cls._parsed.get(text)
        if found is None:
            if text in ("", "self"):
                found = cls(())
            else:
                found = cls(tuple(Step.parse(s) for s in text.split(".")))
            cls._parsed[text] = found
        return found

    # ---- the value ---------------------------------------------------------------------
    def __str__(self) -> str:
        return self._text

    def __repr__(self) -> str:
        return f"RolePath({self._text!r})"

    def __bool__(self) -> bool:
        return bool(self.steps)

    def __len__(self) -> int:
        return len(self.steps)

    def __lt__(self, other: RolePath) -> bool:
        """Paths sort as their dotted spellings do."""
        return self._text < other._text

    # ---- structure ---------------------------------------------------------------------
    @property
    def last(self) -> Step:
        """The last step (IndexError at the root)."""
        return self.steps[-1]

    @property
    def parent(self) -> RolePath:
        """The path without its last step (the root's parent is the root)."""
        return RolePath(self.steps[:-1])

    def child(self, role: str, index: int | None = None) -> RolePath:
        """This path one step further: ``body`` -> ``body.oriels[1]``."""
        return RolePath((*self.steps, Step(role, index)))

    def join(self, rel: RolePath) -> RolePath:
        """``rel`` (relative to this path) made absolute; the root `rel` is this path."""
        return RolePath(self.steps + rel.steps) if rel.steps else self

    @property
    def plain(self) -> RolePath:
        """The path without filler indices: ``wings[1].roof`` -> ``wings.roof`` (how the
        knowledge base names what every filler has)."""
        return RolePath(tuple(Step(s.role) for s in self.steps))

    def fills(self, role: RolePath) -> bool:
        """True if this path lies under a filler of ``role``, a role with several fillers:
        ``body.wings[1].front`` fills ``body.wings``."""
        n = len(role.steps)
        if n == 0 or len(self.steps) < n or self.steps[: n - 1] != role.steps[:-1]:
            return False
        step = self.steps[n - 1]
        return step.role == role.last.role and step.index is not None

    def indexed(self, index: int | None) -> RolePath:
        """The path with its last step's index set (or removed with None)."""
        return RolePath((*self.steps[:-1], Step(self.last.role, index)))

    def is_under(self, root: RolePath) -> bool:
        """True if ``root`` is this path or one of its ancestors."""
        n = len(root.steps)
        return self.steps[:n] == root.steps

    def relative_to(self, root: RolePath) -> RolePath:
        """This path relative to ``root`` (`ROOT` for ``root`` itself).

        Raises
        ------
        ValueError
            If the path is not under ``root``.
        """
        if not self.is_under(root):
            raise ValueError(f"{self} is not a part of {root or 'the root'}")
        return RolePath(self.steps[len(root.steps) :])


#: The path of the instance itself (``self`` in the knowledge base).
ROOT = RolePath(())
