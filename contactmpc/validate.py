"""What a parameter accepts, declared once in its signature and checked before any work.

A constructor or job declares the values a parameter accepts in its annotation::

    @checked
    def __init__(self, horizon: Annotated[float, Gt(0)] = 2.5, nthread: Annotated[int, Ge(1)] | None = None):

The declaration is read in two places, so a nonsense value fails before anything runs, with one line
naming it:

- :func:`checked` (a decorator of the constructor or job function) checks every call's arguments:
  ``PredictiveSampling.horizon must be finite and > 0, got nan``;
- :func:`contactmpc.config.check_config` checks a composed config (``launch.py`` calls it before it
  builds anything) and names the value by its key: ``planner.horizon must be finite and > 0, got nan``.

The generated config schemas (:func:`contactmpc.config.schema`) see through ``Annotated`` to the plain
type. One rule needs no declaration: a float, alone or in a list, must be finite (NaN and inf are
never a setting). A relation between parameters (a range's low < high, ``num_elites <= num_samples``)
is checked by the constructor itself.
"""

from __future__ import annotations

import functools
import inspect
import math
import numbers
import types
import typing
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

__all__ = [
    "Check",
    "ConfigError",
    "Ge",
    "Gt",
    "Le",
    "OneOf",
    "check_values",
    "checked",
    "declared",
    "problem",
    "type_hints",
]


class ConfigError(ValueError):
    """A value its parameter does not accept; the message is one line that names the parameter."""


class Check:
    """A constraint on a value, placed in a parameter's annotation (``Annotated[float, Gt(0)]``)."""

    def accepts(self, value: Any) -> bool:
        raise NotImplementedError


@dataclass(frozen=True)
class Gt(Check):
    """A number ``> bound``."""

    bound: float

    def accepts(self, value: Any) -> bool:
        return value > self.bound

    def __str__(self) -> str:
        return f"> {self.bound:g}"


@dataclass(frozen=True)
class Ge(Check):
    """A number ``>= bound``."""

    bound: float

    def accepts(self, value: Any) -> bool:
        return value >= self.bound

    def __str__(self) -> str:
        return f">= {self.bound:g}"


@dataclass(frozen=True)
class Le(Check):
    """A number ``<= bound``."""

    bound: float

    def accepts(self, value: Any) -> bool:
        return value <= self.bound

    def __str__(self) -> str:
        return f"<= {self.bound:g}"


class OneOf(Check):
    """One of the given strings (``None`` stays allowed where the type is ``... | None``)."""

    def __init__(self, *options: str) -> None:
        self.options = options

    def accepts(self, value: Any) -> bool:
        return value in self.options

    def __eq__(self, other: object) -> bool:
        return isinstance(other, OneOf) and other.options == self.options

    def __hash__(self) -> int:
        return hash(self.options)

    def __str__(self) -> str:
        return "one of " + ", ".join(map(repr, self.options))


def declared(hint: Any) -> tuple[Check, ...]:
    """The checks in a type annotation: ``Annotated`` metadata, also inside ``X | None`` and
    ``list[...]``/``tuple[...]`` (a check inside a list applies to each element)."""
    if typing.get_origin(hint) is typing.Annotated:
        base, *meta = typing.get_args(hint)
        return tuple(m for m in meta if isinstance(m, Check)) + declared(base)
    return tuple(c for arg in typing.get_args(hint) if arg is not Ellipsis for c in declared(arg))


def problem(value: Any, checks: tuple[Check, ...] = ()) -> str | None:
    """What is wrong with ``value`` under ``checks`` and the finite-float rule, or ``None``.

    A sequence (list, tuple, OmegaConf's ``ListConfig``) or an array is checked element by element:
    the answer then starts with the index, ``"[3] must be finite, got nan"``.

    Returns:
        ``"must be finite and > 0, got nan"`` and the like; ``None`` when the value is accepted.
    """
    if value is None or isinstance(value, bool):
        return None
    if (isinstance(value, Sequence) and not isinstance(value, str | bytes)) or _is_array(value):
        for i, item in enumerate(value.tolist() if _is_array(value) else value):
            if (p := problem(item, checks)) is not None:
                return f"[{i}]{'' if p.startswith('[') else ' '}{p}"
        return None
    if isinstance(value, numbers.Real):
        bounds = [c for c in checks if isinstance(c, Gt | Ge | Le)]
        is_float = not isinstance(value, numbers.Integral)
        if (is_float and not math.isfinite(value)) or not all(c.accepts(value) for c in bounds):
            shown = float(value) if is_float else int(value)
            return f"must be {' and '.join(['finite'] * is_float + [str(c) for c in bounds])}, got {shown!r}"
        return None
    for c in checks:
        if isinstance(c, OneOf) and not c.accepts(value):
            return f"must be {c}, got {value!r}"
    return None


def _is_array(value: Any) -> bool:
    return hasattr(value, "tolist") and hasattr(value, "dtype") and getattr(value, "ndim", 0) > 0


def type_hints(function: Callable, extras: bool = False) -> dict[str, Any]:
    """``typing.get_type_hints`` of a function (``extras``: keep ``Annotated``); where one annotation
    cannot be resolved (a name imported only for type checking), the others still are and that one is
    ``Any``."""
    try:
        return typing.get_type_hints(function, include_extras=extras)
    except (NameError, TypeError):
        pass
    globalns = getattr(inspect.unwrap(function), "__globals__", None)
    hints = {}
    for name, annotation in getattr(function, "__annotations__", {}).items():
        holder = types.SimpleNamespace(__annotations__={name: annotation})
        try:
            hints.update(typing.get_type_hints(holder, globalns=globalns, include_extras=extras))
        except (NameError, TypeError):
            hints[name] = Any
    return hints


def check_values(where: str, values: Mapping[str, Any], checks: Mapping[str, tuple[Check, ...]]) -> None:
    """Check named values against their checks (and the finite-float rule).

    Args:
        where: prefix of each name in the message (``"planner."``, ``"MPPI."``).
        values: name -> value; mappings and other objects are left alone.
        checks: name -> the checks declared for it.

    Raises:
        ConfigError: ``"<where><name> <problem>"`` for the first value that is not accepted.
    """
    for name, value in values.items():
        if (p := problem(value, checks.get(name, ()))) is not None:
            raise ConfigError(f"{where}{name}{'' if p.startswith('[') else ' '}{p}")


@functools.cache
def _declared_parameters(function: Callable) -> dict[str, tuple[Check, ...]]:
    hints = type_hints(function, extras=True)
    return {name: declared(hints.get(name, Any)) for name in inspect.signature(function).parameters}


def checked(function: Callable) -> Callable:
    """Check a constructor's (``__init__``) or a function's arguments against their declarations
    (:func:`declared`) at every call, before its body runs.

    The signature, annotations and name stay the function's own (``functools.wraps``), so the config
    schema generated from it is unchanged. A message names the parameter after the class of the object
    being built (``MPPI.temperature``) or the function (``run_trial.failure_gap``).

    Raises:
        ConfigError: at call time, for the first argument that is not accepted.
    """
    signature = inspect.signature(function)
    method = next(iter(signature.parameters), None) == "self"
    variadic = {p.name for p in signature.parameters.values() if p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD)}

    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        arguments = signature.bind(*args, **kwargs).arguments
        owner = type(args[0]).__name__ if method else function.__name__
        named = {k: v for k, v in arguments.items() if k not in variadic and not (method and k == "self")}
        check_values(f"{owner}.", named, _declared_parameters(function))
        return function(*args, **kwargs)

    return wrapper
