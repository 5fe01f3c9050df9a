"""Nonsense values fail before any work, with one line naming the key (``contactmpc.validate``).

A value a parameter does not accept (NaN or inf anywhere, a negative weight, ``duration <= 0``, ...) is
refused twice: by :func:`contactmpc.config.check_config` on the composed config, which ``launch.py``
calls before it builds anything, naming the key; and by the constructor or job itself (``@checked``),
naming the parameter, before its body runs.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import re
import subprocess
import sys
from typing import Annotated

import pytest
from hydra.errors import InstantiationException
from hydra.utils import instantiate
from omegaconf import OmegaConf

import launch
from contactmpc.config import check_config
from contactmpc.validate import ConfigError, Ge, Gt, Le, OneOf, checked, declared, problem
from tests.conftest import CONF_DIR, REPO_ROOT, compose_config, member_package

# (overrides, key the message names)
NONSENSE = [
    (["planner.horizon=nan"], "planner.horizon"),
    (["planner.replan_period=inf"], "planner.replan_period"),
    (["planner.num_samples=0"], "planner.num_samples"),
    (["planner.nthread=0"], "planner.nthread"),
    (["planner=mppi", "planner.temperature=nan"], "planner.temperature"),
    (["planner=cem", "planner.max_std_ratio=-inf"], "planner.max_std_ratio"),
    (["sampler.sigma2=nan"], "sampler.sigma2"),
    (["sampler.sigma2=-0.2"], "sampler.sigma2"),
    (["variant=joint_space", "sampler.root_sigma2=inf"], "sampler.root_sigma2"),
    (["cost.lambda_o=inf"], "cost.lambda_o"),
    (["cost.lambda_c=-1"], "cost.lambda_c"),
    (["cost.lambda_v=-0.01"], "cost.lambda_v"),
    (["cost.rotation_weight=nan"], "cost.rotation_weight"),
    (["hand.kp_finger=nan"], "hand.kp_finger"),
    (["hand.damping_slide=-1"], "hand.damping_slide"),
    (["scene.impratio=inf"], "scene.impratio"),
    (["scene.hand_root=[0,nan,0]"], "scene.hand_root[1]"),
    (["task.time_scale=nan"], "task.time_scale"),
    (["task.time_scale=inf"], "task.time_scale"),
    (["job.failure_gap=-0.1"], "job.failure_gap"),
    (["job.failure_min_expected=-1"], "job.failure_min_expected"),
    (["job.video=avi"], "job.video"),
    (["job.video_speed=0"], "job.video_speed"),
    (["duration=0"], "duration"),
    (["duration=-1"], "duration"),
    (["duration=nan"], "duration"),
    (["seed=-1"], "seed"),
]


def _resolved(overrides, output_dir, cfg=None) -> dict:
    """The composed config as ``launch.main`` passes it to ``check_config``."""
    cfg = compose_config(overrides) if cfg is None else cfg.copy()
    cfg.output_dir = str(output_dir)  # Hydra's runtime resolver is not there outside a run
    return OmegaConf.to_container(cfg, resolve=True)


def _no_work():
    raise AssertionError("the scene was built: work started before the arguments were checked")


@pytest.mark.parametrize(("overrides", "key"), NONSENSE, ids=[" ".join(o) for o, _ in NONSENSE])
def test_nonsense_value_fails_before_any_work(overrides, key, tmp_path):
    cfg = compose_config(overrides)
    with pytest.raises(ConfigError) as err:
        check_config(_resolved(overrides, tmp_path, cfg))
    message = str(err.value)
    assert message.startswith(f"{key} must "), message
    assert "\n" not in message

    # The object (or job) refuses it too, naming the parameter, before its body runs.
    node, _, param = key.partition(".")
    if not param:  # a root value (seed, duration): the trial job gets it
        node, param = "job", key
    param = param.split("[")[0]
    if node == "task":
        return  # contactmpc/tasks/ keeps its own checks; the config check above is what stops it
    with pytest.raises((ConfigError, InstantiationException), match=rf"\.{param}(\[\d+\])? must be"):
        if node == "job":
            job = launch.build_job(cfg.job)
            job(make_scene=_no_work, output_dir=tmp_path, seed=cfg.seed, config={}, labels={})
        elif node == "scene":
            instantiate(cfg.scene)(hand=instantiate(cfg.hand), task=instantiate(cfg.task))
        else:
            instantiate(cfg[node])
    assert not any(tmp_path.iterdir()), "something was written"


def _members() -> list[str]:
    return [
        f"{p.parent.name}={p.stem}" for p in sorted(CONF_DIR.glob("*/*.yaml")) if p.parent.name != "hydra"
    ]


@pytest.mark.parametrize("member", _members())
def test_shipped_configs_pass(member, tmp_path):
    check_config(_resolved([member], tmp_path))


_BY_NAME = {name: cls for _, name, cls in launch.SCHEMAS}
MEMBER_SCHEMAS = [
    (group, member, _BY_NAME[f"/{group}_{member}_schema"]) for group, member, _ in launch.conf_members()
]


@pytest.mark.parametrize(
    ("group", "member", "schema"), MEMBER_SCHEMAS, ids=[f"{g}/{m}" for g, m, _ in MEMBER_SCHEMAS]
)
def test_every_float_must_be_finite(group, member, schema, tmp_path):
    """NaN in any float of any member is refused, whether or not its parameter declares anything."""
    config = _resolved([f"{group}={member}"], tmp_path)
    package = member_package(group, member)
    floats = [f.name for f in dataclasses.fields(schema) if f.type is float or f.type == float | None]
    for name in floats:
        bad = copy.deepcopy(config)
        node = bad
        for part in package.split("."):
            node = node[part]
        node[name] = float("nan")
        with pytest.raises(ConfigError, match=rf"^{re.escape(package)}\.{name} must be finite"):
            check_config(bad)


def _launch(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "launch.py", *args], cwd=REPO_ROOT, capture_output=True, text=True, timeout=120
    )


@pytest.mark.parametrize(
    ("override", "line"),
    [
        ("planner.horizon=nan", "planner.horizon must be finite and > 0, got nan"),
        ("task.time_scale=inf", "task.time_scale must be finite and > 0, got inf"),
    ],
)
def test_launch_refuses_nonsense_in_one_line_before_any_work(override, line, tmp_path):
    """One line naming the key; the trial's record says the same (status error) and nothing ran."""
    run = tmp_path / "run"
    r = _launch(override, f"hydra.run.dir={run}", "job.reference_cache=null")
    assert r.returncode == 1
    errors = [x for x in r.stderr.splitlines() if x.startswith("contactmpc: error:")]
    assert errors == [f"contactmpc: error: ConfigError: {line}"], r.stderr
    record = json.loads((run / "trial.json").read_text())
    assert record["status"] == "error" and record["error"] == f"ConfigError: {line}"
    assert "ttf" not in record and not (run / "timeseries.npz").exists()


# ----------------------------------------------------------------------------- the mechanism itself


def test_declared_reads_through_optional_and_lists():
    assert declared(Annotated[float, Gt(0)] | None) == (Gt(0),)
    assert declared(list[Annotated[int, Ge(1)]] | None) == (Ge(1),)
    assert declared(Annotated[float, Ge(0), Le(1)]) == (Ge(0), Le(1))
    assert declared(float) == () and declared(tuple[int, ...]) == ()


def test_problem_messages():
    assert problem(float("nan")) == "must be finite, got nan"
    assert problem(-1.0, (Ge(0),)) == "must be finite and >= 0, got -1.0"
    assert problem(0, (Ge(1),)) == "must be >= 1, got 0"
    assert problem([1.0, float("inf")]) == "[1] must be finite, got inf"
    assert problem("avi", (OneOf("gif", "mp4"),)) == "must be one of 'gif', 'mp4', got 'avi'"
    for fine in (None, True, 0.5, 3, [1.0, 2.0]):
        assert problem(fine, (Gt(0),)) is None
    assert problem("gif", (OneOf("gif", "mp4"),)) is None


class _Thing:
    @checked
    def __init__(self, rate: Annotated[float, Gt(0)] = 1.0, name: str = "x", **kwargs) -> None:
        self.rate = rate


class _Child(_Thing):
    pass


def test_checked_names_the_class_built_and_leaves_the_signature_alone():
    with pytest.raises(ConfigError, match=r"^_Child\.rate must be finite and > 0, got -2\.0$"):
        _Child(rate=-2.0)
    assert _Child(0.5, extra=float("nan")).rate == 0.5  # **kwargs belong to the next constructor
    from contactmpc.config import parameters

    assert [p.name for p, _ in parameters(_Thing)] == ["rate", "name"]
    assert dict(parameters(_Thing))  # types resolve
    assert [hint for _, hint in parameters(_Thing)] == [float, str]  # the schema sees plain types
