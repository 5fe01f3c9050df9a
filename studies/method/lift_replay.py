"""The grasp and lift of the paper's free objects (apple, bottle, stapler) replayed open-loop in the plant
and in planning models of several steps: does the model the planner rolls out keep the object in the hand
where the plant does (the method study's "The planning model and the lift")?

From each kept trial of the method on :data:`TASKS` that has its time series, the scene is put in the
trial's recorded configuration :data:`BEFORE` s before its contact span starts (the hand not yet on the
object; velocities zeroed: the series keep none, so a replay is near its trial, not the trial), and the
trial's recorded hand targets are replayed open-loop to :data:`AFTER` s after the span starts (past the
reference's lift), in the plant model (its 1 ms) and in the planning model (the trial's own, with the
planner's options) at each step of :data:`PLANNER_STEPS`. A replay lifts the object where it ends at least
:data:`LIFT` above where it started. Writes ``figures/lift_replay.csv`` (one row per trial and model) and
``figures/lift_replay_<task>.png`` (the object's height in each model, per trial), which the report reads
(so a clone without the time series makes the same report):

    CONTACTMPC_PAPER_DATA=... python studies/method/lift_replay.py
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import mujoco
import numpy as np
from release_replay import recorded_target, scene_of, write_rows  # this folder's script

from contactmpc.labels import method_name

HERE = Path(__file__).resolve().parent
CSV = HERE / "figures" / "lift_replay.csv"
TASKS = ("paper_apple", "paper_bottle", "paper_stapler")
METHOD = "grasp_held_eased"
BEFORE = 0.3  # s before the contact span starts that a replay starts
# s after the span starts that a replay ends (past the references' lifts: the apple's 1.9-2.4 s after it)
AFTER = 3.5
PLANNER_STEPS = (0.01, 0.005, 0.002)  # s: the planning model's step (the method's 10 ms first)
LIFT = 0.05  # m above its start: the tasks' lifted milestone's height
EVERY = 0.01  # s between the samples of the object's height kept for the figure


def replay(scene, model: mujoco.MjModel, series, start: float, end: float) -> tuple[np.ndarray, np.ndarray]:
    """``(times, heights)``: the object's height (m) every :data:`EVERY` s while ``model`` runs the recorded
    hand targets open-loop from the recorded configuration at ``start`` to ``end``."""
    t = series["time"]
    i0 = int(np.searchsorted(t, start))
    d = mujoco.MjData(model)
    scene.reset(d, hand_qpos=series["hand_qpos"][i0], object_qpos=series["object_qpos"][i0])
    z = scene.index.object_qpos[2]
    steps = int(round((end - t[i0]) / model.opt.timestep))
    keep = max(int(round(EVERY / model.opt.timestep)), 1)
    times, heights = [], []
    for k in range(steps):
        now = t[i0] + k * model.opt.timestep
        d.ctrl[scene.index.actuators] = recorded_target(series, now)
        mujoco.mj_step(model, d)
        if k % keep == 0:
            times.append(now + model.opt.timestep)
            heights.append(float(d.qpos[z]))
    return np.array(times), np.array(heights)


def window(record: dict, series) -> tuple[float, float, float]:
    """``(start, end, z0)``: a replay's window of a trial (from :data:`BEFORE` s before its contact span
    starts to :data:`AFTER` s after) and the object's height at its start (m)."""
    span = record["contact_span_start"]
    start, end = span - BEFORE, span + AFTER
    return start, end, float(series["object_qpos"][int(np.searchsorted(series["time"], start)), 2])


def trials(folder: Path, method: str):
    """``(path, record, series)`` of each kept trial under ``folder`` on :data:`TASKS` of ``method`` whose
    time series is kept (``path``: its ``trial.json``)."""
    for path in sorted(folder.glob("*/trial.json")):
        record = json.loads(path.read_text())
        series_path = path.parent / "timeseries.npz"
        if record.get("task") in TASKS and series_path.is_file() and method_name(record) == method:
            yield path, record, np.load(series_path)


def figure(curves: dict, path: Path, task: str) -> None:
    """Per trial of ``task``, the object's height above its start in each replay."""
    import matplotlib.pyplot as plt

    seeds = sorted({seed for seed, _ in curves})
    cols = 5
    rows = -(-len(seeds) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.0 * cols, 2.4 * rows), squeeze=False, sharey=True)
    for ax, seed in zip(axes.flat, seeds, strict=False):
        lifted = False
        for (s, model), (times, rise, in_trial) in curves.items():
            if s == seed:
                ax.plot(times, 1e3 * rise, lw=1.0, label=model, ls="-" if model == "plant" else "--")
                lifted = in_trial
        ax.axhline(1e3 * LIFT, color="k", lw=0.6, ls=":")
        ax.set_title(f"seed {seed}" + (" (lifted in its trial)" if lifted else " (not lifted)"), fontsize=8)
        ax.set_ylim(-100, 250)
        ax.grid(alpha=0.3)
    for ax in axes.flat[len(seeds) :]:
        ax.axis("off")
    axes[0][0].set_ylabel(f"{task.removeprefix('paper_')} above its start (mm)")
    axes[0][0].legend(fontsize=6)
    fig.suptitle(
        f"the recorded hand targets replayed open-loop from {BEFORE:g} s before the grasp; "
        "time from the contact span's start (s)",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> int:
    paper_data = os.environ.get("CONTACTMPC_PAPER_DATA")
    if not paper_data:
        print("lift_replay: error: set CONTACTMPC_PAPER_DATA to the authors' mjpc/tasks", file=sys.stderr)
        return 2
    rows, curves = [], {task: {} for task in TASKS}
    for path, record, series in trials(HERE / "records", METHOD):
        start, end, z0 = window(record, series)
        span = record["contact_span_start"]
        runs = []
        for step in PLANNER_STEPS:
            scene = scene_of(record, paper_data, planner_timestep=step)
            if not runs:
                runs.append(("plant", scene.plant_model.opt.timestep, scene, scene.plant_model))
            runs.append((f"planning model, {1e3 * step:g} ms", step, scene, scene.planner_model))
        for name, step, scene, model in runs:
            times, heights = replay(scene, model, series, start, end)
            rise = heights - z0
            rows.append({"record": path.parent.name, "task": record["task"], "seed": record["seed"],
                         "model": name, "step": step,
                         "lifted_in_trial": bool(record.get("milestone_lifted")),
                         "rise": float(rise[-1]), "lifted": bool(rise[-1] >= LIFT),
                         "before": BEFORE, "after": AFTER})  # fmt: skip
            curves[record["task"]][(record["seed"], name)] = (
                times - span,
                rise,
                bool(record.get("milestone_lifted")),
            )
            print(
                f"{record['task']} seed {record['seed']} {name}: "
                f"the object ends {1e3 * rise[-1]:+.0f} mm from its start"
            )
    if not rows:
        print("lift_replay: error: no trial of the method with its time series", file=sys.stderr)
        return 1
    write_rows(rows, CSV)
    for task, kept in curves.items():
        if kept:
            figure(kept, CSV.parent / f"lift_replay_{task.removeprefix('paper_')}.png", task)
    print(f"wrote {CSV} and its figures")
    return 0


if __name__ == "__main__":
    sys.exit(main())
