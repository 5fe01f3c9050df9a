"""Config schemas generated from constructor signatures: complete, strict, and the only home of defaults.

Nothing here names a parameter of a constructor except the two end-to-end examples: the tests iterate
over ``launch.SCHEMAS`` (one per member YAML with a ``_target_``), the signatures and the YAML files,
so they keep up with constructors that change.
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import inspect
import typing
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest
from hydra.errors import ConfigCompositionException
from hydra.utils import instantiate
from omegaconf import OmegaConf

import launch
from contactmpc.config import JOB_RUNTIME_ARGS, MISSING, SCENE_RUNTIME_ARGS, Config, Inputs, locate, schema
from launch import SCHEMAS
from tests.conftest import CONF_DIR, compose_config, member_package

GENERATED = [(group, name, cls) for group, name, cls in SCHEMAS if group is not None]
META = ("_target_", "_partial_")


def signature_params(target) -> dict[str, inspect.Parameter]:
    """Named parameters of a function or a class's constructor; ``**kwargs`` is followed up the MRO.

    Written independently of :func:`contactmpc.config.parameters`, as the oracle it is checked against.
    """
    if not inspect.isclass(target):
        inits = [(target, 0)]
    else:
        inits = []
        for cls in target.__mro__[:-1]:  # object's __init__ takes nothing
            if "__init__" in vars(cls):
                inits.append((vars(cls)["__init__"], 1))
                kinds = [p.kind for p in inspect.signature(vars(cls)["__init__"]).parameters.values()]
                if inspect.Parameter.VAR_KEYWORD not in kinds:
                    break
    params: dict[str, inspect.Parameter] = {}
    for function, skip in inits:
        hints = typing.get_type_hints(function) if not skip else {}
        for p in list(inspect.signature(function).parameters.values())[skip:]:
            hint = hints.get(p.name)
            if inspect.isclass(hint) and issubclass(hint, Inputs):  # a job's inputs: its fields instead
                for q in signature_params(hint).values():
                    params.setdefault(q.name, q)
            elif p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
                params.setdefault(p.name, p)
    return params


def configurable(cls: type) -> dict[str, inspect.Parameter]:
    """The parameters of a schema's target that the config must hold (the runtime ones left out)."""
    target = locate(_field_default(cls, "_target_"))
    return {k: p for k, p in signature_params(target).items() if k not in cls.__excluded__}


def _field_default(cls: type, name: str) -> Any:
    f = next(f for f in dataclasses.fields(cls) if f.name == name)
    return f.default if f.default_factory is dataclasses.MISSING else f.default_factory()


def member_files(group: str, schema_name: str) -> list[Path]:
    """The YAML members of ``group`` whose defaults list names ``schema_name``."""
    files = []
    for path in sorted((CONF_DIR / group).glob("*.yaml")):
        defaults = OmegaConf.load(path).get("defaults") or []
        if schema_name in [d for d in defaults if isinstance(d, str)]:
            files.append(path)
    return files


USES = [(group, name, cls, path) for group, name, cls in GENERATED for path in member_files(group, name)]


def _id(item) -> str:
    return f"{item[0]}/{item[3].stem}" if len(item) == 4 else f"{item[0]}/{item[1]}"


def _scene_fields() -> list[tuple[str, type]]:
    """The root config's fields whose default is a generated schema (the scene)."""
    out = []
    for f in dataclasses.fields(Config):
        if f.default_factory is not dataclasses.MISSING:
            value = f.default_factory()
            if hasattr(type(value), "__excluded__"):
                out.append((f.name, type(value)))
    return out


# ------------------------------------------------------------------------ generation (unit tests)


class _Base:
    def __init__(self, a: int, b: float | None = None, c: tuple[float, float] = (1.0, 2.0)) -> None:
        pass


class _Child(_Base):
    def __init__(self, x: list[int] | np.ndarray = (3,), y: str = "s", rt: object = None, **kwargs) -> None:
        super().__init__(**kwargs)


class _Grandchild(_Child):  # no __init__ of its own
    pass


def _job(make_scene, s: tuple[int, ...] = (1, 2), flag: bool = True, obj: Any = None, **_) -> None:
    pass


def test_schema_follows_kwargs_up_the_mro_and_maps_types():
    cls = schema(_Grandchild, exclude=("rt",))
    fields = {f.name: f for f in dataclasses.fields(cls)}
    assert list(fields) == ["_target_", "x", "y", "a", "b", "c"]
    assert fields["_target_"].default == f"{__name__}._Grandchild"
    assert fields["x"].type is Any and fields["x"].default_factory() == [3]
    assert fields["y"].type is str and fields["y"].default == "s"
    assert fields["a"].type is int and fields["a"].default == MISSING == "???"
    assert fields["b"].type == float | None and fields["b"].default is None
    assert fields["c"].type == list[float] and fields["c"].default_factory() == [1.0, 2.0]
    assert fields["c"].default_factory() is not fields["c"].default_factory()  # a fresh list each time
    assert cls.__name__ == "GrandchildConf" and cls.__excluded__ == ("rt",)


def test_schema_of_a_function_is_partial():
    cls = schema(_job, exclude=("make_scene",), partial=True)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    assert list(fields) == ["_target_", "_partial_", "s", "flag", "obj"]
    assert fields["_partial_"].default is True
    assert fields["s"].type == list[int] and fields["s"].default_factory() == [1, 2]
    assert fields["flag"].type is bool and fields["obj"].type is Any


_ARRAY = np.zeros(2)


def test_schema_rejects_a_default_no_config_can_hold():
    def f(x=_ARRAY):
        pass

    with pytest.raises(TypeError, match=r"x=\.\.\."):
        schema(f)


def test_schema_keeps_the_target_path_it_is_given():
    cls = schema("contactmpc.tasks.AppleTask")
    assert _field_default(cls, "_target_") == "contactmpc.tasks.AppleTask"
    assert cls.__module__ == "contactmpc.config"


# ----------------------------------------------------------------- every parameter is configurable


@pytest.mark.parametrize(("group", "name", "cls"), GENERATED, ids=[f"{g}/{n}" for g, n, _ in GENERATED])
def test_schema_has_a_field_per_parameter(group, name, cls):
    fields = [f.name for f in dataclasses.fields(cls) if f.name not in META]
    assert fields == list(configurable(cls)), f"{name}: fields and constructor parameters differ"
    assert member_files(group, name), f"no conf/{group}/*.yaml uses {name}"


def test_only_runtime_arguments_are_left_out():
    """An exclusion hides a parameter from these tests: only the call sites' own arguments may be."""
    runtime = set(JOB_RUNTIME_ARGS) | set(SCENE_RUNTIME_ARGS)
    for name, cls in [(n, c) for _, n, c in GENERATED] + _scene_fields():
        assert set(cls.__excluded__) <= runtime, f"{name} leaves out {set(cls.__excluded__) - runtime}"


@pytest.mark.parametrize(("group", "name", "cls", "path"), USES, ids=[_id(u) for u in USES])
def test_every_parameter_is_a_key_of_the_composed_member(group, name, cls, path):
    cfg = compose_config([f"{group}={path.stem}"])
    node = OmegaConf.select(cfg, member_package(group, path.stem))
    missing = set(configurable(cls)) - set(node)
    assert not missing, f"{group}={path.stem}: {sorted(missing)} cannot be set from the command line"
    assert node._target_ == _field_default(cls, "_target_")


@pytest.mark.parametrize(("key", "cls"), _scene_fields())
def test_every_scene_parameter_is_a_key(key, cls):
    missing = set(configurable(cls)) - set(compose_config()[key])
    assert not missing, f"{key}: {sorted(missing)} cannot be set from the command line"


PARTIAL_USES = [u for u in USES if getattr(u[2], "_partial_", False)]


@pytest.mark.parametrize(("group", "name", "cls", "path"), PARTIAL_USES, ids=[_id(u) for u in PARTIAL_USES])
def test_partial_members_pass_every_key(group, name, cls, path):
    """A ``_partial_`` member (a job) instantiates to a partial holding every configured parameter."""
    job = instantiate(compose_config([f"{group}={path.stem}"])[group])
    assert isinstance(job, functools.partial)
    assert set(job.keywords) == set(configurable(cls))


def test_hand_override_reaches_the_hand():
    cfg = compose_config(["hand.armature_wrist=0.05"])
    assert instantiate(cfg.hand).armature_wrist == 0.05


def test_scene_override_reaches_the_scene():
    cfg = compose_config(["scene.hand_root=[0,0,0.1]"])
    assert instantiate(cfg.scene).keywords["hand_root"] == [0.0, 0.0, 0.1]
    scene = launch.build_scene(cfg)
    body = mujoco.mj_name2id(scene.plant_model, mujoco.mjtObj.mjOBJ_BODY, "hand_root")
    np.testing.assert_allclose(scene.plant_model.body_pos[body], [0.0, 0.0, 0.1])


# --------------------------------------------------------------------------------- still strict

STRICT = sorted({group for group, *_ in GENERATED} | {key for key, _ in _scene_fields()})


@pytest.mark.parametrize("node", STRICT)
def test_misspelt_key_fails_at_compose_time(node):
    with pytest.raises(ConfigCompositionException):
        compose_config([f"{node}.no_such_key=1"])


def test_misspelt_task_key_fails():
    with pytest.raises(ConfigCompositionException, match="radiuss"):
        compose_config(["task.radiuss=1"])


# ------------------------------------------------------------------------- defaults in one place


def _same(value: Any, default: Any) -> bool:
    """Config value == Python default (tuples as lists; a bool is not the number 1)."""
    if isinstance(default, tuple | list):
        return isinstance(value, list) and len(value) == len(default) and all(map(_same, value, default))
    if isinstance(value, bool) or isinstance(default, bool):
        return value is default
    return value == default


def _restated(values: dict, params: dict[str, inspect.Parameter]) -> list[str]:
    return [
        f"{k}: {v!r}"
        for k, v in values.items()
        if k in params and params[k].default is not inspect.Parameter.empty and _same(v, params[k].default)
    ]


@pytest.mark.parametrize(("group", "name", "cls", "path"), USES, ids=[_id(u) for u in USES])
def test_yaml_member_does_not_restate_a_default(group, name, cls, path):
    values = OmegaConf.to_container(OmegaConf.load(path), resolve=False)
    restated = _restated(values, configurable(cls))
    assert not restated, f"{path.relative_to(CONF_DIR)} restates constructor defaults: {restated}"


@pytest.mark.parametrize(("key", "cls"), _scene_fields())
def test_root_config_does_not_restate_a_default(key, cls):
    values = OmegaConf.to_container(OmegaConf.load(CONF_DIR / "config.yaml"), resolve=False).get(key) or {}
    restated = _restated(values, configurable(cls))
    assert not restated, f"config.yaml {key}: restates constructor defaults: {restated}"


# ----------------------------------------------------------------------- experiments win over the root

EXPERIMENTS = sorted((CONF_DIR / "experiment").glob("*.yaml"))


def _leaves(node: Any, prefix: str = "") -> list[tuple[str, Any]]:
    """``(dotted key, value)`` of every leaf of a YAML mapping (a list is one leaf); a key that itself
    holds a dot (a sweeper parameter such as ``perturbation.object_offset``) is bracketed."""
    if not isinstance(node, dict):
        return [(prefix, node)]
    return [
        leaf
        for k, v in node.items()
        for leaf in _leaves(v, f"{prefix[:-1]}[{k}]." if "." in str(k) else f"{prefix}{k}.")
    ]


def _same_setting(written: Any, composed: Any) -> bool:
    """A YAML value and its composed value (Hydra holds ``hydra.mode`` as an enum and sweeper
    parameters as strings)."""
    if isinstance(composed, enum.Enum):
        composed = composed.name
    return written == composed or (isinstance(composed, str) and str(written) == composed)


@pytest.mark.parametrize("path", EXPERIMENTS, ids=[p.stem for p in EXPERIMENTS])
def test_every_value_an_experiment_sets_is_in_the_composed_config(path):
    """An experiment file (package ``_global_``) wins over ``config.yaml``: each value it sets and each
    default it overrides is what the composed config holds (``duration`` was silently null)."""
    values = OmegaConf.to_container(OmegaConf.load(path), resolve=False)
    defaults = values.pop("defaults", [])
    cfg = compose_config([f"experiment={path.stem}"], return_hydra_config=True)
    composed = {key: OmegaConf.select(cfg, key[:-1]) for key, _ in _leaves(values)}
    wrong = {
        key[:-1]: (v, composed[key]) for key, v in _leaves(values) if not _same_setting(v, composed[key])
    }
    assert not wrong, f"{path.name}: set -> composed: {wrong}"
    choices = cfg.hydra.runtime.choices
    for entry in defaults:
        if isinstance(entry, str):  # _self_, or another experiment it builds on
            continue
        ((group, choice),) = entry.items()
        group = group.removeprefix("override ").strip().lstrip("/")
        assert choices[group] == choice, f"{path.name}: {group} is {choices[group]}, not {choice}"


def test_presets_and_variants_still_set_their_groups():
    paper = compose_config(["preset=paper", "variant=no_contact"])
    assert (paper.planner.num_samples, paper.planner.horizon, paper.planner.replan_period) == (128, 2.5, 0.01)
    assert paper.cost.lambda_c == 0.0 and paper.sampler._target_.endswith("PCASplineSpace")
    joint = compose_config(["variant=joint_space", "planner=replay"])
    assert joint.sampler._target_.endswith("JointSplineSpace") and joint.planner.num_samples == 32
    assert compose_config(["experiment=smoke", "duration=1.0"]).duration == 1.0  # the command line wins


GLOBAL_GROUPS = sorted(
    d.name
    for d in CONF_DIR.iterdir()
    if d.is_dir() and any(p.read_text().startswith("# @package _global_") for p in d.glob("*.yaml"))
)


@pytest.mark.parametrize("path", sorted(CONF_DIR.glob("*/*.yaml")), ids=lambda p: f"{p.parent.name}/{p.stem}")
def test_no_file_sets_a_global_group_by_a_plain_value(path):
    """``variant: full`` in a file's body sets the root slot named ``variant``, not the variant group
    (whose files are ``_global_``): it changes nothing, silently (experiment=release_reset ran the full
    method so). A global group is chosen in the defaults list (``- override /variant: full``)."""
    assert len(GLOBAL_GROUPS) >= 4 and "variant" in GLOBAL_GROUPS
    values = OmegaConf.load(path)
    if not isinstance(values, dict) and not OmegaConf.is_dict(values):
        return
    plain = [g for g in GLOBAL_GROUPS if g in values]
    assert not plain, f"{path.name} sets {plain} as values: choose them in its defaults list"
