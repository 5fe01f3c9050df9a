"""MUJOCO_GL chosen before MuJoCo is imported (contactmpc.gl): egl where libEGL loads, else disable, with
which trials run and rendering says in one line what it needs."""

from __future__ import annotations

import ctypes.util
import json
import os
import subprocess
import sys

import pytest

from contactmpc import gl
from tests.conftest import REPO_ROOT


def test_default_gl_keeps_a_set_value_and_picks_egl_only_where_libegl_loads(monkeypatch):
    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    assert gl.default_gl() == "osmesa"
    monkeypatch.delenv("MUJOCO_GL")
    monkeypatch.setattr(ctypes.util, "find_library", lambda name: None)
    assert gl.default_gl() == "disable" and os.environ["MUJOCO_GL"] == "disable"
    monkeypatch.setenv("MUJOCO_GL", "")
    monkeypatch.setattr(ctypes.util, "find_library", lambda name: "libEGL.so.1" if name == "EGL" else None)
    assert gl.default_gl() == "egl"


def test_require_gl_names_what_is_missing(monkeypatch):
    monkeypatch.setenv("MUJOCO_GL", "disable")
    with pytest.raises(gl.NoGLError, match=r"^rendering needs OpenGL, but MUJOCO_GL=disable .*libegl1"):
        gl.require_gl()
    monkeypatch.setenv("MUJOCO_GL", "egl")
    gl.require_gl()


def _launch(tmp_path, *args):
    env = {**os.environ, "MUJOCO_GL": "disable"}
    return subprocess.run(
        [sys.executable, str(REPO_ROOT / "launch.py"), *args, f"hydra.run.dir={tmp_path}",
         "hydra/job_logging=disabled", "hydra/hydra_logging=disabled"],
        cwd=REPO_ROOT, env=env, capture_output=True, text=True, timeout=300,
    )  # fmt: skip


def test_without_opengl_a_trial_runs_and_rendering_fails_in_one_line(tmp_path):
    trial = _launch(
        tmp_path / "trial", "task=bottle", "duration=0.2", "planner.num_samples=4", "planner.nthread=1"
    )
    assert trial.returncode == 0, trial.stderr
    assert json.loads((tmp_path / "trial" / "trial.json").read_text())["status"] == "ok"
    render = _launch(tmp_path / "render", "job=render_scene", "task=bottle")
    assert render.returncode == 1
    errors = [line for line in render.stderr.splitlines() if line.startswith("contactmpc: error:")]
    assert len(errors) == 1 and "rendering needs OpenGL, but MUJOCO_GL=disable" in errors[0], render.stderr
    assert "Traceback" not in render.stderr
