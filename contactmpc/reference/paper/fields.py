"""What the readers of the authors' files share: opening a file, checking a JSON document's fields.

Every problem with a file raises :class:`~contactmpc.reference.data.ReferenceError` with a one-line
message naming the file and the field: the JSON key path (``data[3].controlPointData``) or the XML
element name, e.g. ``…/x_hand.smexp: field 'data[1].numControlPoints': expected an integer, got 5.0``.

The checks take JSON as :func:`json.loads` returns it and coerce nothing: ``5.0`` is no integer, ``"5"``
no number and ``true`` neither; numbers must be finite. Each takes the value and the field's name
(:func:`key_path`) and returns the value checked (:func:`as_floats`: an array).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from contactmpc.reference.data import ReferenceError

__all__ = [
    "PathLike",
    "as_float",
    "as_floats",
    "as_int",
    "as_list",
    "as_object",
    "check_file",
    "frozen",
    "get",
    "json_type",
    "key_path",
    "load_json",
]

PathLike = str | os.PathLike


def frozen(value: Any, dtype: type) -> np.ndarray:
    """A read-only copy of ``value`` as an array of ``dtype``."""
    arr = np.array(value, dtype=dtype, copy=True)
    arr.setflags(write=False)
    return arr


def check_file(path: Path) -> None:
    """Raise :class:`ReferenceError` unless ``path`` is an existing file."""
    if not path.exists():
        raise ReferenceError("no such file", path=path)
    if path.is_dir():
        raise ReferenceError("is a directory, not a file", path=path)


def load_json(path: Path) -> dict[str, Any]:
    """The JSON object in ``path``.

    Raises:
        ReferenceError: the file is missing, unreadable, not JSON or not an object at the top level.
    """
    check_file(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise ReferenceError(f"unreadable ({err})", path=path) from err
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as err:
        where = f"line {err.lineno} column {err.colno}"
        raise ReferenceError(f"not valid JSON ({err.msg} at {where}; truncated?)", path=path) from err
    if not isinstance(doc, dict):
        raise ReferenceError(f"expected a JSON object at the top level, got {json_type(doc)}", path=path)
    return doc


def json_type(value: Any) -> str:
    """What a JSON value is, for a message: ``an object``, ``an array``, ``a number``, ``null``, ..."""
    if isinstance(value, bool):
        return "a boolean"
    if value is None:
        return "null"
    names = {dict: "an object", list: "an array", str: "a string", int: "a number", float: "a number"}
    return names.get(type(value), type(value).__name__)


def key_path(where: str, key: str) -> str:
    """The name of field ``key`` of the object at ``where`` (``data[1]`` -> ``data[1].type``)."""
    return f"{where}.{key}" if where else key


def get(obj: Mapping[str, Any], key: str, where: str, path: Path) -> Any:
    """``obj[key]``, where ``obj`` is the object at ``where``; missing: :class:`ReferenceError`."""
    if key not in obj:
        raise ReferenceError("missing", field=key_path(where, key), path=path)
    return obj[key]


def as_object(value: Any, field: str, path: Path) -> Mapping[str, Any]:
    """``value``, checked to be a JSON object."""
    if not isinstance(value, dict):
        raise ReferenceError(f"expected a JSON object, got {json_type(value)}", field=field, path=path)
    return value


def as_list(value: Any, field: str, path: Path) -> list[Any]:
    """``value``, checked to be a JSON array."""
    if not isinstance(value, list):
        raise ReferenceError(f"expected an array, got {json_type(value)}", field=field, path=path)
    return value


def as_int(value: Any, field: str, path: Path, minimum: int | None = None) -> int:
    """``value``, checked to be an integer (not a float, not a boolean), ``>= minimum`` if given."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise ReferenceError(f"expected an integer, got {value!r}", field=field, path=path)
    if minimum is not None and value < minimum:
        raise ReferenceError(f"must be >= {minimum}, got {value}", field=field, path=path)
    return value


def as_float(value: Any, field: str, path: Path) -> float:
    """``value``, checked to be a finite number."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ReferenceError(f"expected a number, got {json_type(value)}", field=field, path=path)
    if not math.isfinite(value):
        raise ReferenceError(f"not finite ({value})", field=field, path=path)
    return float(value)


def as_floats(value: Any, field: str, path: Path) -> np.ndarray:
    """``value``, checked to be an array of finite numbers, as float64 ``(n,)``."""
    items = as_list(value, field, path)
    for i, item in enumerate(items):
        if isinstance(item, bool) or not isinstance(item, (int, float)):
            raise ReferenceError(f"entry {i} is {json_type(item)}, not a number", field=field, path=path)
    arr = np.array(items, dtype=np.float64)
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        raise ReferenceError(f"entry {bad[0]} is not finite ({arr[bad[0]]})", field=field, path=path)
    return arr
