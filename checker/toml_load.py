"""A TOML file read and validated by pydantic, with the one mapping of the reader's and the
validator's errors to a one-line `PathcheckError` that names the file and what was expected.
A leaf module: it imports only `checker.errors`, pydantic and tomllib."""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

from checker.errors import PathcheckError

Model = TypeVar("Model", bound=BaseModel)


def read_toml(path: Path, *, what: str, code: str) -> dict[str, Any]:
    """The top table of the TOML file `path`. A missing or unreadable file, or text that is not
    TOML (the message names its line), raises PathcheckError naming `path`; `what` names the
    kind of file in the message (e.g. "machine file")."""
    try:
        with path.open("rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise PathcheckError(f"{what} not found", path=path, code=code) from None
    except OSError as err:
        raise PathcheckError(f"cannot read {what}: {err.strerror}", path=path, code=code) from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise PathcheckError(f"{what} is not valid TOML: {err}", path=path, code=code) from None


def validated(model: type[Model], data: Any, *, subject: str, code: str,
              path: Path | None = None) -> Model:
    """`data` validated as `model`. The first error raises PathcheckError (naming `path` when
    given): "{subject} field 'a.b': what was expected, found X" (a table's value is not shown),
    or "{subject}: ..." for an error of the whole table."""
    try:
        return model.model_validate(data)
    except ValidationError as err:
        raise PathcheckError(subject + _first_error(err), path=path, code=code) from None


def _first_error(err: ValidationError) -> str:
    first = err.errors()[0]
    msg = first["msg"].removeprefix("Value error, ")
    if not first["loc"]:
        return f": {msg}"
    field = ".".join(str(p) for p in first["loc"])
    found = first.get("input")
    shown = "" if isinstance(found, dict) else f", found {found!r}"
    return f" field '{field}': {msg}{shown}"
