"""The profile job (``conf/job/profile.yaml``): where a plan's time goes over a whole trial.

    python launch.py job=profile task=paper_apple preset=paper_32samples variant=full
    python launch.py job=profile task=paper_stapler preset=paper_32samples variant=wrist_clearance \
        job.every=3.0 job.visit=planner

The job visits a trial's states at a regular stride (``every`` seconds of control time, from the start to
the end): the plant tracking the reference's own splines (``visit=replay``, no planning: seconds) or the
closed loop of the configured planner (``visit=planner``: the trial itself, minutes). At each state it
times, on one thread, a whole planning iteration (the planner's :meth:`~Planner.plan`) and the bare
``mujoco.rollout`` of the same candidates, interleaved (plan, rollout, plan, ...; median of ``repeats``),
the cost's evaluation of the rollout's sensors, and rolls the same candidates out once more with a
single-threaded ``mujoco.mj_step`` loop whose per-part timers (``mjData.timer``) split the physics:

- ``collision``: ``mjTIMER_POS_COLLISION`` (broad and narrow phase);
- ``constraint``: the constraint solver (``mjTIMER_CONSTRAINT``) plus making and projecting the rows
  (``POS_MAKE``, ``POS_PROJECT``);
- ``sensors``: what ``mj_forward`` spends outside position, velocity, actuation and constraint (the
  sensors, the ``geomdist`` sensors of ``scene.link_distance_cutoff`` among them, and the smooth
  acceleration);
- ``kinematics``: ``POS_KINEMATICS`` + ``POS_INERTIA``; ``physics_rest``: the rest of ``mj_step``
  (velocity, actuation, integration, checks) and the rollout's copies of state and sensors.

The timers measure wall time in a Python loop, so they only give the parts' shares: each share of the
loop's ``mjTIMER_STEP`` is applied to the real rollout's CPU time (``rollout_us``), whose parts then add
up to it;
- ``cost``: the cost's evaluation (Python/numba); ``planner_rest``: the plan less the rollout and the cost
  (sampling, splines to controls, the update).

Every figure is per sample-step (microseconds of one thread for one planning-model step of one sample; a
plan's per the samples it draws, ``plan_samples``: ``acquire_samples`` where the planner draws them, more
than the candidates the rollout and the parts are timed on), grouped by phase of the reference's contact
timeline: ``before`` the first expected contact, ``contact`` (from the first to the last expected contact)
and ``after`` it. With ``alternatives`` (name -> planning-
model cuts, :func:`contactmpc.scene.planning_model`) each state also times the planning iteration with
each alternative planning model, interleaved with the scene's, so that old and new meet the same load.
The machine's load (``os.getloadavg``) is recorded before and after. Prints a markdown table and writes
``profile.json`` and ``profile.csv``.
"""

from __future__ import annotations

import csv
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any

import mujoco
import numpy as np

from contactmpc.control.cost import TrackingCost
from contactmpc.control.planners.base import Planner
from contactmpc.control.samplers import SplineSpace
from contactmpc.jobs.benchmark import STATE, full_state, interleaved, replay
from contactmpc.jobs.trial import summarize
from contactmpc.records import machine, write_json
from contactmpc.reference.source import get_reference
from contactmpc.scene import Scene, planning_model
from contactmpc.trial import Trial
from contactmpc.validate import Ge, Gt, OneOf, checked

T = mujoco.mjtTimer
PARTS = (
    "collision",
    "constraint",
    "sensors",
    "kinematics",
    "physics_rest",
    "cost",
    "planner_rest",
)


def phase_of(trial: Trial, t: float) -> str:
    """``before``, ``contact`` or ``after`` the reference's expected contacts, at control time ``t``."""
    active = np.flatnonzero(trial.track.contact_active.any(axis=1))
    if not active.size:
        return "before"
    i = trial.track.index(t)
    return "before" if i < active[0] else ("contact" if i <= active[-1] else "after")


def visit_states(trial: Trial, every: float, visit: str) -> tuple[list[tuple[float, np.ndarray]], dict]:
    """The plant's full states at control times 0, ``every``, 2 ``every``, ... below the trial's
    duration: [(time, state)], replaying the reference (``replay``) or in the planner's closed loop
    (``planner``, the trial itself, whose outcome comes second: ``completed``, ``ttf``, ... as a trial's
    record has them; ``{}`` for a replay)."""
    scene = trial.scene
    times = list(np.arange(0.0, trial.duration - 1e-9, every))
    if visit == "planner":
        wall = time.perf_counter()
        series = trial.run(snapshots=tuple(times)).arrays()
        summary = summarize(series, trial, time.perf_counter() - wall, 0.3, 6, 0.3)
        keep = ("ttf", "completed", "finished_cleanly", "plan_seconds_mean", "plan_seconds_p95", "num_plans")
        outcome = {k: summary[k] for k in keep}
        outcome["plan_us_per_sample_step"] = (
            1e6 * summary["plan_seconds_mean"] / (trial.planner.num_samples * trial.planner.steps)
        )
        return [(float(s[0]), s) for s in trial.snapshots.values()], outcome
    out, pending = [], list(times)
    for t, d in replay(scene, trial, scene.planner_model.opt.timestep):
        while pending and t >= pending[0] - 1e-9:
            pending.pop(0)
            out.append((t, full_state(scene.plant_model, d, t)))
        if not pending:
            break
    return out, {}


def physics_parts(model: mujoco.MjModel, state: np.ndarray, controls: np.ndarray) -> dict[str, float]:
    """Seconds per step of each part of ``mj_step`` (single-threaded loop, ``mjData.timer``) over the
    rollouts of ``controls`` (S, H, nu) from ``state``, with the mean ``ncon`` and ``nefc``."""
    d = mujoco.MjData(model)
    before = np.array([d.timer[i].duration for i in range(len(d.timer))])
    ncon = nefc = 0
    for u in controls:
        mujoco.mj_setState(model, d, state, STATE)
        for row in u:
            d.ctrl[:] = row
            mujoco.mj_step(model, d)
            ncon += d.ncon
            nefc += d.nefc
    spent = np.array([d.timer[i].duration for i in range(len(d.timer))]) - before
    n = controls.shape[0] * controls.shape[1]
    t = {name: spent[int(getattr(T, f"mjTIMER_{name}"))] / n for name in (
        "STEP", "FORWARD", "POSITION", "VELOCITY", "ACTUATION", "CONSTRAINT", "POS_KINEMATICS",
        "POS_INERTIA", "POS_COLLISION", "POS_MAKE", "POS_PROJECT")}  # fmt: skip
    parts = {
        "step": t["STEP"],
        "collision": t["POS_COLLISION"],
        "constraint": t["CONSTRAINT"] + t["POS_MAKE"] + t["POS_PROJECT"],
        "sensors": t["FORWARD"] - t["POSITION"] - t["VELOCITY"] - t["ACTUATION"] - t["CONSTRAINT"],
        "kinematics": t["POS_KINEMATICS"] + t["POS_INERTIA"],
    }
    parts["physics_rest"] = parts["step"] - sum(parts[k] for k in PARTS[:4])
    return parts | {"ncon": ncon / n, "nefc": nefc / n}


def profile_state(
    trial: Trial, t: float, state: np.ndarray, seed: int, repeats: int, alternatives: dict[str, Any]
) -> dict[str, float]:
    """One state's per sample-step costs (us), by part; ``alternatives``: name -> planning model whose
    whole planning iteration is timed interleaved with the scene's (``plan_<name>_us``)."""
    planner, problem = trial.planner, trial.problem
    theta0 = planner.theta.copy()
    _, _, thetas = planner.candidates(np.random.default_rng(seed), t)
    planner.theta[:] = theta0
    ctrl = np.ascontiguousarray(planner.controls(thetas, planner.basis(t)))
    S, H, _ = ctrl.shape
    window = problem.track.window(t, planner.steps)
    n = window.stop - window.start
    engine = planner.engine
    _, sd, _ = engine.run(state, ctrl)
    sd = sd.copy()

    drawn: list[int] = []  # the sample-steps of each timed plan (its own samples: acquire_samples, ...)

    def plan_with(model: mujoco.MjModel) -> Callable[[], None]:
        def plan() -> None:
            engine.model = model
            planner.theta[:] = theta0  # the same candidates every time
            info = planner.plan(t, state, np.random.default_rng(seed))
            drawn.append(info.samples * planner.steps)

        return plan

    scene_model = engine.model
    fns = {"plan": plan_with(scene_model), "rollout": lambda: engine.run(state, ctrl)}
    fns["cost"] = lambda: sum(v.sum(axis=-1) for v in problem.cost(sd[:, :n], window).values())
    for name, model in alternatives.items():
        fns[f"plan_{name}"] = plan_with(model)
    try:
        timed = interleaved(fns, repeats)
    finally:
        engine.model = scene_model
        planner.theta[:] = theta0
    per = 1e6 / (S * H)
    if len(set(drawn)) != 1:
        raise RuntimeError(f"t={t:.2f}: the timed plans drew different sample-steps ({sorted(set(drawn))})")
    per_plan = 1e6 / drawn[0]  # a plan per its own sample-steps, which may be more than the candidates'
    parts = physics_parts(scene_model, state, ctrl)
    rollout_us = per * timed["rollout"]["cpu"]
    share = rollout_us / parts["step"]  # the loop's timers split the real rollout's CPU time
    row = {
        "time": t,
        "phase": phase_of(trial, t),
        "ncon": parts["ncon"],
        "nefc": parts["nefc"],
        "plan_samples": drawn[0] // planner.steps,
        "plan_us": per_plan * timed["plan"]["cpu"],
        "plan_wall_us": per_plan * timed["plan"]["wall"],
        "rollout_us": rollout_us,
        "loop_step_us": 1e6 * parts["step"],
    }
    row |= {k: share * parts[k] for k in PARTS[:5]}
    row["cost"] = per * timed["cost"]["cpu"]
    row["planner_rest"] = row["plan_us"] - row["rollout_us"] - row["cost"]
    for name in alternatives:
        row[f"plan_{name}_us"] = per_plan * timed[f"plan_{name}"]["cpu"]
    return row


def summarise(rows: list[dict[str, float]], columns: list[str]) -> dict[str, dict[str, float]]:
    """Per phase and over the whole trial (``all``, every state alike): the mean of each column."""
    out = {}
    for phase in ("before", "contact", "after", "all"):
        sel = [r for r in rows if phase in ("all", r["phase"])]
        if sel:
            out[phase] = {"states": len(sel)} | {c: float(np.mean([r[c] for r in sel])) for c in columns}
    return out


def calibration(rows: list[dict[str, float]], samples: int = 128, steps: int = 250, threads: int = 7) -> dict:
    """The per sample-step cost of a plan over the visited states (one thread's CPU time, us: median,
    min, max, mean) and the latency it implies for ``samples`` x ``steps`` on ``threads`` threads
    (:class:`~contactmpc.control.latency.ComputeLatency`, ms; preset=paper: 128 x 250 on 7)."""
    us = np.array([r["plan_us"] for r in rows])
    stats = {
        "median": float(np.median(us)),
        "min": float(us.min()),
        "max": float(us.max()),
        "mean": float(us.mean()),
    }
    scale = samples * steps / threads / 1e3  # us per sample-step -> ms of latency
    return {"sample_step_us": stats, "latency_ms": {k: v * scale for k, v in stats.items()},
            "samples": samples, "steps": steps, "threads": threads}  # fmt: skip


def markdown(label: str, summary: dict[str, dict[str, float]], alternatives: list[str]) -> str:
    """The summary as markdown rows: label, phase, states, plan us, its parts, ncon, alternatives."""
    lines = []
    for phase, s in summary.items():
        alt = " | ".join(
            f"{s[f'plan_{a}_us']:.1f} ({s['plan_us'] / s[f'plan_{a}_us']:.2f}x)" for a in alternatives
        )
        lines.append(
            f"| {label} | {phase} | {s['states']} | {s['plan_us']:.1f} | {s['rollout_us']:.1f} | "
            + " | ".join(f"{s[p]:.1f}" for p in PARTS)
            + f" | {s['ncon']:.1f} | {s['nefc']:.0f}"
            + (f" | {alt}" if alternatives else "")
            + " |"
        )
    return "\n".join(lines)


def header(alternatives: list[str]) -> str:
    cols = [
        "run",
        "phase",
        "states",
        "plan us",
        "rollout us",
        *PARTS,
        "ncon",
        "nefc",
        *(f"plan {a} us" for a in alternatives),
    ]
    return "| " + " | ".join(cols) + " |\n|" + "---|" * len(cols)


@checked
def profile_plan(
    make_scene: Callable[[], Scene],
    output_dir: str | Path,
    seed: Annotated[int, Ge(0)],
    *,
    every: Annotated[float, Gt(0)] = 2.0,
    repeats: Annotated[int, Ge(1)] = 3,
    visit: Annotated[str, OneOf("replay", "planner")] = "replay",
    alternatives: dict[str, dict[str, Any]] | None = None,
    sampler: SplineSpace,
    cost: TrackingCost,
    planner: Planner,
    duration: Annotated[float, Gt(0)] | None = None,
    labels: dict | None = None,
    reference_cache: str | None = "outputs/cache/references",
    **_,
) -> Path:
    """Profile a planning iteration over a trial's states (see the module docstring).

    The job's settings, after ``seed``, are keyword-only (its config gives them by name): its own first,
    then the trial's it visits.

    Args:
        make_scene: builds the scene.
        output_dir: where ``profile.json`` and ``profile.csv`` go.
        seed: the trial's seed (the closed loop's and the sampling noise's).
        every: control seconds between visited states.
        repeats: interleaved timings per state (median).
        visit: ``replay`` (the reference's splines in the plant) or ``planner`` (the closed loop).
        alternatives: name -> planning-model cuts (keyword arguments of
            :func:`contactmpc.scene.planning_model`) timed beside the scene's planning model.
        sampler, cost, planner: as for a trial; the planner runs on one thread.
        duration: control time the visit covers; ``None``: the trial's.
        labels: the config choices (task, variant, preset), for the table.
        reference_cache: cache directory of synthesised references.

    Returns:
        Path of ``profile.json``.
    """
    load_before = os.getloadavg()
    start = time.perf_counter()
    scene = make_scene()
    alternatives = {k: dict(v) for k, v in (alternatives or {}).items()}
    models = {name: planning_model(scene, **cuts) for name, cuts in alternatives.items()}
    reference = get_reference(scene, reference_cache)
    planner.close()
    planner.nthread = 1
    trial = Trial(scene, reference, sampler, cost, planner, seed, duration=duration, progress=False)
    states, outcome = visit_states(trial, every, visit)
    rows = [profile_state(trial, t, s, seed, repeats, models) for t, s in states]
    planner.close()
    labels = {str(k): None if v is None else str(v) for k, v in dict(labels or {}).items()}
    label = " ".join(str(labels.get(k) or "-") for k in ("task", "variant", "preset"))
    columns = ["plan_us", "plan_wall_us", "rollout_us", "loop_step_us", *PARTS, "ncon", "nefc"]
    columns += [f"plan_{a}_us" for a in alternatives]
    summary = summarise(rows, columns)
    table = header(list(alternatives)) + "\n" + markdown(label, summary, list(alternatives))
    load_after = os.getloadavg()
    print(
        f"{label}: {planner.num_samples} samples x {planner.steps} steps, {len(rows)} states every {every} s "
        f"({visit}); load average before {load_before[0]:.2f}, after {load_after[0]:.2f}"
    )
    print(table)
    if outcome:
        print(f"the visited trial (seed {seed}): {outcome}")
    cal = calibration(rows)
    us, ms = cal["sample_step_us"], cal["latency_ms"]
    print(
        f"calibration: {us['median']:.1f} us per sample-step (median; {us['min']:.1f}-{us['max']:.1f}, "
        f"mean {us['mean']:.1f}, {len(rows)} states): preset=paper's latency 128 x 250 / 7 threads = "
        f"{ms['median']:.0f} ms ({ms['min']:.0f}-{ms['max']:.0f})"
    )
    out = Path(output_dir)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "profile.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["label", *rows[0].keys()] if rows else ["label"])
        w.writeheader()
        for r in rows:
            w.writerow({"label": label, **r})
    return write_json(
        out / "profile.json",
        {
            "task": scene.task.name,
            "seed": seed,
            "labels": labels,
            "num_samples": planner.num_samples,
            "horizon_steps": planner.steps,
            "visit": visit,
            "every": every,
            "repeats": repeats,
            "alternatives": alternatives,
            "load_before": list(load_before),
            "load_after": list(load_after),
            "seconds": time.perf_counter() - start,
            "machine": machine(),
            "rows": rows,
            "summary": summary,
            "calibration": cal,
            "trial": outcome,
            "table": table,
        },
    )
