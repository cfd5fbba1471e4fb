"""Reading and writing pydantic models as JSON files, with errors that name file and field."""

from __future__ import annotations

import contextvars
import json
import os
from pathlib import Path
from typing import Any, TypeVar

from pydantic import BaseModel, ConfigDict, ValidationError

from aida_kb.errors import FormatError
from aida_kb.io.atomic import write_text_atomic
from aida_kb.limits import MAX_JSON_BYTES, nesting_problem, read_limited

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


# How many FrozenModel validations are running in this context: only the outermost turns a
# ValidationError into a FormatError (pydantic calls a custom __init__ for nested models too).
_NESTING: contextvars.ContextVar[int] = contextvars.ContextVar("aida_kb_io_nesting", default=0)


class FrozenModel(BaseModel):
    """Base of the file-format models: immutable, no unknown fields.

    Built in code with a bad value it raises `FormatError` naming the model and the field
    (not pydantic's multi-line ValidationError), as reading a bad file does.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    def __init__(self, **data: Any) -> None:
        token = _NESTING.set(_NESTING.get() + 1)
        try:
            super().__init__(**data)
        except ValidationError as exc:
            if _NESTING.get() > 1:
                raise
            raise FormatError(describe_validation_error(type(self).__name__, exc)) from None
        finally:
            _NESTING.reset(token)


def validate_model(model: type[ModelT], data: object, source: str) -> ModelT:
    """`data` (parsed JSON/YAML) validated as `model`; FormatError naming `source` and field."""
    token = _NESTING.set(_NESTING.get() + 1)
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise FormatError(describe_validation_error(source, exc)) from None
    finally:
        _NESTING.reset(token)


def read_text_file(path: str | os.PathLike[str], limit: int = MAX_JSON_BYTES) -> str:
    """The UTF-8 text of a regular file of at most `limit` bytes; FormatError naming it when
    missing, unreadable, too large or not UTF-8."""
    file = Path(path)
    try:
        return read_limited(file, limit).decode("utf-8")
    except FileNotFoundError:
        raise FormatError(f"{file}: no such file") from None
    except OSError as exc:
        raise FormatError(f"{file}: cannot be read: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise FormatError(f"{file}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None


def read_json_model(path: str | os.PathLike[str], model: type[ModelT]) -> ModelT:
    """Load and validate a JSON file as `model`; raise FormatError naming the file and field."""
    file = Path(path)
    text = read_text_file(file)
    problem = nesting_problem(text)
    if problem is not None:
        raise FormatError(f"{file}:{problem}")
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise FormatError(f"{file}:{exc.lineno}:{exc.colno}: not valid JSON: {exc.msg}") from None
    except (ValueError, RecursionError) as exc:  # a backstop: nesting_problem checked first
        raise FormatError(f"{file}: not valid JSON: {exc}") from None
    return validate_model(model, data, str(file))


def write_json_model(
    path: str | os.PathLike[str], value: BaseModel, indent: int | None = 2
) -> None:
    """Write `value` as JSON atomically (temporary file, then rename)."""
    write_text_atomic(path, value.model_dump_json(indent=indent) + "\n")
