"""Reading and writing pydantic models as JSON files, with errors that name file and field."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import TypeVar

from pydantic import BaseModel, ValidationError

from aida_kb.errors import FormatError
from aida_kb.io.atomic import write_text_atomic

ModelT = TypeVar("ModelT", bound=BaseModel)


def _field_path(loc: tuple[int | str, ...]) -> str:
    path = ""
    for part in loc:
        path += f"[{part}]" if isinstance(part, int) else (f".{part}" if path else str(part))
    return path or "(top level)"


def describe_validation_error(source: str, exc: ValidationError, limit: int = 5) -> str:
    """One readable message for a pydantic validation error: file, field path, what is wrong."""
    lines = [f"{source}: {exc.error_count()} problem(s) in the file"]
    for err in exc.errors()[:limit]:
        lines.append(f"  {_field_path(tuple(err['loc']))}: {err['msg']}")
    if exc.error_count() > limit:
        lines.append(f"  ... and {exc.error_count() - limit} more")
    return "\n".join(lines)


def read_json_model(path: str | os.PathLike[str], model: type[ModelT]) -> ModelT:
    """Load and validate a JSON file as `model`; raise FormatError naming the file and field."""
    file = Path(path)
    try:
        text = file.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise FormatError(f"{file}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise FormatError(f"{file}: cannot be read: {exc}") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise FormatError(f"{file}:{exc.lineno}:{exc.colno}: not valid JSON: {exc.msg}") from None
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise FormatError(describe_validation_error(str(file), exc)) from None


def write_json_model(
    path: str | os.PathLike[str], value: BaseModel, indent: int | None = 2
) -> None:
    """Write `value` as JSON atomically (temporary file, then rename)."""
    write_text_atomic(path, value.model_dump_json(indent=indent) + "\n")
