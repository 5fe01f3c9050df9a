"""Shared fixtures: Hydra composition of the real ``conf/`` tree, scenes built as ``launch.py`` does.

``launch.py`` lives at the repository root (not in the package), so the root is put on ``sys.path``;
importing it registers the config schemas in Hydra's ConfigStore and defaults ``MUJOCO_GL`` to ``egl``.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]
CONF_DIR = REPO_ROOT / "conf"
TASKS = ("apple", "bottle", "stapler", "doorknob")

if str(REPO_ROOT) not in sys.path:
    sys.path.insert(0, str(REPO_ROOT))
os.environ.setdefault("MUJOCO_GL", "egl")  # before any MuJoCo GL context is made

from hydra import compose as hydra_compose  # noqa: E402
from hydra import initialize_config_dir  # noqa: E402
from omegaconf import DictConfig  # noqa: E402

import launch  # noqa: E402  (registers the ConfigStore schemas at import)


def compose_config(overrides: Sequence[str] = (), return_hydra_config: bool = False) -> DictConfig:
    """Compose ``conf/config.yaml`` with command-line style ``overrides`` (e.g. ``["task=stapler"]``).

    Hydra's global state is set up for the call only and restored afterwards, so this can be called
    any number of times and does not clash with other users of ``GlobalHydra``. With
    ``return_hydra_config`` the result keeps its ``hydra`` node (launcher, sweeper, runtime choices).
    """
    launch.register_configs()  # idempotent; guards against a ConfigStore cleared by another test
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        return hydra_compose(
            config_name="config", overrides=list(overrides), return_hydra_config=return_hydra_config
        )


def member_package(group: str, member: str) -> str:
    """Where a member of ``group`` lands in the composed config: its ``# @package`` header (e.g.
    ``planner.robust`` for ``conf/robust/ensemble.yaml``), else the group's name."""
    first = (CONF_DIR / group / f"{member}.yaml").read_text().splitlines()[:1]
    if first and first[0].startswith("# @package "):
        return first[0].removeprefix("# @package ").strip()
    return group


_SCENES: dict[tuple[str, ...], object] = {}


def build_scene(overrides: Sequence[str] = ()):
    """The scene of the composed config, built by ``launch.build_scene``; cached per overrides.

    Callers must treat the cached scene's models as read-only (make their own ``MjData``).
    """
    key = tuple(overrides)
    if key not in _SCENES:
        _SCENES[key] = launch.build_scene(compose_config(key))
    return _SCENES[key]


@pytest.fixture(scope="session")
def compose() -> Callable[[Sequence[str]], DictConfig]:
    """``compose(overrides)`` -> composed ``DictConfig`` of the real ``conf/`` tree."""
    return compose_config


@pytest.fixture(scope="session")
def scene_for() -> Callable[..., object]:
    """``scene_for(task, *overrides)`` -> the :class:`~contactmpc.scene.Scene` built as ``launch.py`` does."""

    def _scene_for(task: str, *overrides: str):
        return build_scene((f"task={task}", *overrides))

    return _scene_for


@pytest.fixture(scope="session")
def reference_files(tmp_path_factory) -> dict[str, str]:
    """A short static reference .npz per synthetic task, for its ``task.reference_path``."""
    from tests.helpers import static_reference

    root = tmp_path_factory.mktemp("refs")
    return {
        task: str(static_reference(build_scene((f"task={task}",)), duration=0.2, frames=6).save(root / task))
        for task in TASKS
    }


@pytest.fixture(scope="session")
def repo_root() -> Path:
    return REPO_ROOT
