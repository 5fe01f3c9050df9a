"""Config schemas, generated from the signatures of the constructors that Hydra instantiates.

A schema is a dataclass with ``_target_`` (and ``_partial_: true`` where the call site completes the
object) and one field per constructor parameter, typed and defaulted from the signature. It gives the
YAML files in ``conf/`` a schema, so a misspelt key or a wrong type fails when the config is composed,
with Hydra's own error; and every constructor parameter can be set from the command line. The
defaults live in one place, the constructor: the YAML files hold only what differs from them. So do
the values a parameter accepts (``Annotated[float, Gt(0)]``, :mod:`contactmpc.validate`), which
:func:`check_config` checks in a composed config before anything is built.

This module does not import Hydra or OmegaConf: ``launch.py`` stores the schemas in Hydra's
``ConfigStore`` (see :func:`launch.register_configs`).
"""

from __future__ import annotations

import collections.abc
import copy
import dataclasses
import functools
import importlib
import inspect
import types
import typing
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Annotated, Any

from contactmpc.validate import Ge, Gt, check_values, declared, type_hints

MISSING = "???"
"""OmegaConf's ``MISSING`` (a value that must be given), spelled out so this module needs no OmegaConf."""

SCALARS = (bool, int, float, str)
"""Field types kept as they are (also inside ``Optional`` and lists); any other type becomes ``Any``."""

SCENE_RUNTIME_ARGS = ("hand", "task")
"""Arguments of :class:`~contactmpc.scene.Scene` passed at the call site (``launch.build_scene``)."""

JOB_RUNTIME_ARGS = ("make_scene", "output_dir", "seed", "config", "labels")
"""Arguments of a job function passed at the call site (``launch.main``)."""

_SEQUENCES = (list, tuple, collections.abc.Sequence, collections.abc.MutableSequence)


def locate(path: str) -> Any:
    """The object named by a dotted path such as ``"contactmpc.tasks.AppleTask"``, as Hydra finds it.

    Raises:
        ImportError: no module of the path can be imported, or it lacks the named attribute.
    """
    parts = path.split(".")
    obj = importlib.import_module(parts[0])
    for i, part in enumerate(parts[1:], start=2):
        try:
            obj = getattr(obj, part)
        except AttributeError:
            try:
                obj = importlib.import_module(".".join(parts[:i]))
            except ModuleNotFoundError as err:
                raise ImportError(f"cannot locate {path!r}: {err}") from err
    return obj


class Inputs:
    """Base of a parameter object that a job's config holds at the job's own level.

    A job function's parameter typed as a dataclass subclass of this (the trial and online jobs'
    :class:`~contactmpc.jobs.common.TrialInputs`) stands for its fields: :func:`parameters` lists them
    in its place, so the job's schema, checks and option defaults are its fields, and ``launch.build_job``
    builds the object from the job config's keys of those names (:func:`inputs_parameter`).
    """


def inputs_parameter(target: Callable) -> tuple[str, type] | None:
    """``(name, class)`` of the parameter of function ``target`` whose type is an :class:`Inputs`
    dataclass, or ``None`` (a class, or a function without one)."""
    if inspect.isclass(target):
        return None
    hints = type_hints(target)
    for name in inspect.signature(target).parameters:
        if (cls := _inputs_class(hints.get(name, Any))) is not None:
            return name, cls
    return None


def split_inputs(target: Callable, node: Mapping[str, Any]) -> tuple[dict, tuple[str, dict] | None]:
    """Split a job's config ``node`` (plain containers) into the job's own keys and, if ``target`` takes
    an :class:`Inputs` object (:func:`inputs_parameter`), ``(parameter name, its node)``: the keys of its
    fields, with its ``_target_``, to instantiate."""
    found = inputs_parameter(target)
    if found is None:
        return dict(node), None
    name, cls = found
    fields = {f.name for f in dataclasses.fields(cls)}
    own = {k: v for k, v in node.items() if k not in fields}
    inputs = {"_target_": f"{cls.__module__}.{cls.__qualname__}"}
    inputs.update((k, v) for k, v in node.items() if k in fields)
    return own, (name, inputs)


def parameters(target: Callable, extras: bool = False) -> list[tuple[inspect.Parameter, Any]]:
    """The named parameters of a function, or of a class's constructor, each with its resolved type.

    A function's parameter typed as an :class:`Inputs` dataclass is replaced by that dataclass's fields.
    A constructor that takes ``**kwargs`` forwards them up the MRO (``MPPI(temperature, **kwargs)``
    -> ``Planner(num_samples, ...)``): the parameters of the next ``__init__`` follow, and so on, until
    one without ``**kwargs``. A name already seen is not repeated. ``self``, ``*args`` and ``**kwargs``
    are left out.

    Args:
        target: the function or class.
        extras: keep ``typing.Annotated`` in the types (the checks of :mod:`contactmpc.validate`);
            by default they are stripped to the plain type.

    Returns:
        ``(parameter, type)`` pairs in order: the class's own parameters first, then its bases'. The
        type is the resolved annotation (``typing.get_type_hints``), ``Any`` where there is none.
    """
    if inspect.isclass(target):
        functions = []
        for cls in target.__mro__:
            init = cls.__dict__.get("__init__")
            if init is None or cls is object:
                continue
            functions.append((init, True))
            if not _takes_kwargs(init):
                break
    else:
        functions = [(target, False)]
    found: dict[str, tuple[inspect.Parameter, Any]] = {}
    for function, is_method in functions:
        hints = type_hints(function, extras)
        params = list(inspect.signature(function).parameters.values())[1 if is_method else 0 :]
        for p in params:
            if p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD) or p.name in found:
                continue
            hint = hints.get(p.name, Any)
            if not is_method and (inputs := _inputs_class(hint)) is not None:  # its fields, in its place
                found.update((q.name, (q, h)) for q, h in parameters(inputs, extras) if q.name not in found)
                continue
            found[p.name] = (p, hint)
    return list(found.values())


def _inputs_class(hint: Any) -> type | None:
    plain = typing.get_args(hint)[0] if typing.get_origin(hint) is Annotated else hint
    ok = inspect.isclass(plain) and issubclass(plain, Inputs) and dataclasses.is_dataclass(plain)
    return plain if ok else None


def schema(target: str | Callable, *, exclude: Iterable[str] = (), partial: bool = False) -> type:
    """A dataclass schema for ``target``, generated from its signature (see :func:`parameters`).

    Fields: ``_target_`` (the dotted path), ``_partial_ = True`` if ``partial``, then one per parameter
    not in ``exclude``. Types: ``bool``/``int``/``float``/``str``, ``X | None`` of those, and lists,
    tuples or sequences of one of them (as a ``list``) are kept; anything else is ``Any``. Defaults: the
    signature's (a tuple as a list), :data:`MISSING` for a parameter without one.

    Args:
        target: the class or function, or its dotted path (kept as is in ``_target_``, so a re-export
            such as ``contactmpc.tasks.AppleTask`` stays the name in the config).
        exclude: parameters passed at the call site, which the config does not hold.
        partial: the config makes a ``functools.partial`` that the call site completes.

    Returns:
        The dataclass, named after the target (``AppleTask`` -> ``AppleTaskConf``, ``run_trial`` ->
        ``RunTrialConf``); its ``__excluded__`` attribute holds ``exclude``.

    Raises:
        TypeError: a default that a config cannot hold (an object, an array): exclude the parameter,
            or give it a plain default.
    """
    path = target if isinstance(target, str) else f"{target.__module__}.{target.__qualname__}"
    obj = locate(path) if isinstance(target, str) else target
    exclude = tuple(exclude)
    fields: list[tuple[str, Any, Any]] = [("_target_", str, field(default=path))]
    if partial:
        fields.append(("_partial_", bool, field(default=True)))
    for p, hint in parameters(obj):
        if p.name not in exclude:
            fields.append((p.name, _field_type(hint), _field_default(p.default, f"{path}({p.name}=...)")))
    name = "".join(w[:1].upper() + w[1:] for w in path.rpartition(".")[2].split("_")) + "Conf"
    cls = dataclasses.make_dataclass(name, fields)
    cls.__module__ = __name__
    cls.__doc__ = f"Schema of ``{path}``, generated from its signature by :func:`contactmpc.config.schema`."
    cls.__excluded__ = exclude
    return cls


def _takes_kwargs(function: Callable) -> bool:
    return any(p.kind is p.VAR_KEYWORD for p in inspect.signature(function).parameters.values())


def _field_type(hint: Any) -> Any:
    """The type of a config field for a parameter's type (see :func:`schema`)."""
    if hint in SCALARS:
        return hint
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        inner = [a for a in args if a is not type(None)]
        if len(inner) == 1 and len(args) == 2 and (t := _field_type(inner[0])) is not Any:
            return t | None
        return Any
    if origin in _SEQUENCES:
        items = {a for a in args if a is not Ellipsis}
        if len(items) == 1 and (item := items.pop()) in SCALARS:
            return list[item]
    return Any


def _field_default(value: Any, where: str) -> Any:
    """A dataclass field for a parameter's default (see :func:`schema`)."""
    if value is inspect.Parameter.empty:
        return field(default=MISSING)
    plain = _plain(value, where)
    if isinstance(plain, list | dict):
        return field(default_factory=functools.partial(copy.deepcopy, plain))
    return field(default=plain)


def _plain(value: Any, where: str) -> Any:
    """``value`` as config data: scalars and ``None`` as they are, tuples as lists, recursively."""
    if value is None or isinstance(value, SCALARS):
        return value
    if isinstance(value, list | tuple):
        return [_plain(v, where) for v in value]
    if isinstance(value, dict) and all(isinstance(k, str) for k in value):
        return {k: _plain(v, where) for k, v in value.items()}
    raise TypeError(f"{where}: the default {value!r} cannot be a config value")


# ----------------------------------------------------------------------------------------- root

SceneConf = schema("contactmpc.scene.Scene", exclude=SCENE_RUNTIME_ARGS, partial=True)


@dataclass
class Config:
    """The root config: one node per config group, the scene, and the run's own settings."""

    task: Any = None
    hand: Any = None
    cost: Any = None
    sampler: Any = None
    planner: Any = None
    job: Any = None
    preset: Any = None
    variant: Any = None
    fidelity: Any = None
    perturbation: Any = None
    experiment: Any = None
    scene: SceneConf = field(default_factory=SceneConf)
    seed: Annotated[int, Ge(0)] = 0
    resume: Any = True  # true | false | overwrite (launch.py checks the value)
    duration: Annotated[float, Gt(0)] | None = None
    paper_data: str | None = None
    output_dir: str = "${hydra:runtime.output_dir}"


def check_config(config: Mapping[str, Any]) -> None:
    """Check a composed, resolved config before anything is built (``launch.main`` calls it first).

    Each value is checked against what its parameter declares (:mod:`contactmpc.validate`): the root
    values against :class:`Config`'s annotations (OmegaConf never calls a dataclass's
    ``__post_init__``: it merges into the schema without constructing it), every node with a
    ``_target_`` against the signature of what it builds (:func:`parameters`), and every float,
    anywhere, must be finite. A node's own values are checked before its sub-nodes, so a root value
    (``duration``) is named before the job's copy of it (``job.duration``).

    Args:
        config: the config as plain containers (``OmegaConf.to_container(cfg, resolve=True)``).

    Raises:
        ConfigError: one line naming the first value that is not accepted, by its key:
            ``planner.horizon must be finite and > 0, got nan``.
    """
    _check_node(config, "", {name: declared(hint) for name, hint in type_hints(Config, extras=True).items()})


def _check_node(node: Mapping[str, Any], key: str, checks: Mapping[str, tuple]) -> None:
    check_values(key, {k: v for k, v in node.items() if not isinstance(v, Mapping)}, checks)
    for name, value in node.items():
        if isinstance(value, Mapping):
            target = value.get("_target_")
            found = {} if not isinstance(target, str) else _declared(target)
            _check_node(value, f"{key}{name}.", found)


@functools.cache
def _declared(target: str) -> dict[str, tuple]:
    """The checks declared by the parameters of ``target`` (a dotted path), by parameter name."""
    return {p.name: declared(hint) for p, hint in parameters(locate(target), extras=True)}


# ---------------------------------------------------------------------------------------- members

_PICKLE_PREFIX = "Conf__"


@functools.cache
def schema_for(target: str) -> type:
    """The schema of a config-group member that builds ``target`` (a dotted path).

    A class is instantiated whole; a function is a job, built as a ``functools.partial`` that the call
    site completes with :data:`JOB_RUNTIME_ARGS`. One class per target (cached), importable by name
    from this module, so pickled configs (the joblib, submitit and Ray launchers pickle them) load in a
    fresh process: its ``__qualname__`` spells the target, and the module's ``__getattr__`` rebuilds it.
    """
    job = not inspect.isclass(locate(target))
    cls = schema(target, exclude=JOB_RUNTIME_ARGS if job else (), partial=job)
    cls.__qualname__ = _PICKLE_PREFIX + target.replace(".", "__")
    return cls


def __getattr__(name: str) -> Any:
    """Schema classes by their pickled names (see :func:`schema_for`)."""
    if name.startswith(_PICKLE_PREFIX):
        return schema_for(name[len(_PICKLE_PREFIX) :].replace("__", "."))
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def member_schemas(members: Iterable[tuple[str, str, str]]) -> tuple[tuple[str, str, type], ...]:
    """The schemas of config-group members, from what each member builds.

    Args:
        members: ``(group, member, target)`` per member file ``conf/<group>/<member>.yaml`` that has a
            ``_target_``.

    Returns:
        ``(group, "/<group>_<member>_schema", schema)`` triples (:func:`schema_for`): the entry a
        member's defaults list names. The leading ``/`` says the schema is stored at the root of the
        ConfigStore, not in its group, so it is no choice of the group (``--help`` does not list it).
    """
    return tuple(
        (group, f"/{group}_{member}_schema", schema_for(target)) for group, member, target in members
    )
