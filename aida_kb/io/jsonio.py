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
    return path


def describe_validation_error(source: str, exc: ValidationError) -> str:
    """One line for a pydantic validation error: file, field path of the first problem, what.

    Further problems are counted, not listed (fixing the first often fixes the rest).
    """
    errors = exc.errors()
    first = errors[0]
    msg = str(first["msg"]).removeprefix("Value error, ").replace("\n", " ")
    where = f" field {_field_path(tuple(first['loc']))}:" if first["loc"] else ""
    line = f"{source}:{where} {msg}"
    if len(errors) > 1:
        line += f" (and {len(errors) - 1} more problem(s))"
    return line


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
