"""The benchmark job (``conf/job/benchmark.yaml``): what a trial's time goes to, at states a trial visits.

    python launch.py job=benchmark task=apple                 # lite preset
    python launch.py job=benchmark task=paper_bottle preset=paper

The states are a trial's own, taken at two instants: *approach* (half-way to the first expected contact)
and *contact* (the middle of the span with expected contacts). With ``visit=planner`` (the default) the
closed loop of the configured planner runs from the reference's start to the contact instant, so the
contact state is one where the controller holds the object (seconds to a minute, lite); with
``visit=replay`` the plant tracks the reference's own splines (no planning: seconds), whose contact state
may have lost the object. At each state the job measures, per thread count:

- one physics step of the plant model and of the planning model from that state (wall and CPU time per
  step over runs of the same simulated time, timed interleaved, median), with the state's ``ncon`` and
  ``nefc``;
- a planning iteration (sampling, spline -> controls, rollout, cost, update; ``plan_samples``: the samples
  it draws at the state's time, :meth:`~contactmpc.control.planners.base.Planner.samples_at`) and the bare
  ``mujoco.rollout`` of the same controls, **interleaved** (plan, rollout, plan, rollout, ...) so that
  load on the machine hits both alike; the median wall time and the median CPU time (the process's,
  over all threads) of each, their ratio (the planner's overhead) and the speed-up from the first
  thread count to each other (wall time).

With ``planner_options`` (named sets of ``mjOption`` fields applied on top of the scene's, e.g.
``{pyramidal: {cone: pyramidal}}``) it also prices each set at each state against the scene's planning
model: CPU time per step of the candidates' rollout (timed interleaved with the scene's) and the
agreement cost, the largest distance between the object in the plant and in the planning model under
the same controls (the nominal candidate's, over the planner's horizon), so that a saving is never
reported without what it breaks.

It prints its tables and writes ``benchmark.json``.
"""

from __future__ import annotations

import copy
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Annotated, Any

import mujoco
import numpy as np

from contactmpc.control.cost import TrackingCost
from contactmpc.control.planners.base import Planner
from contactmpc.control.rollout import RolloutEngine
from contactmpc.control.samplers import SplineSpace
from contactmpc.records import write_json
from contactmpc.reference.source import get_reference
from contactmpc.scene import Scene, set_options
from contactmpc.trial import Trial
from contactmpc.validate import Ge, OneOf, checked

STATE = mujoco.mjtState.mjSTATE_FULLPHYSICS


def _clock() -> tuple[float, float]:
    return time.perf_counter(), time.process_time()


def interleaved(fns: dict[str, Callable[[], object]], repeats: int) -> dict[str, dict[str, float]]:
    """Median wall and CPU seconds of each function, timed in turn (a, b, a, b, ...) after one warm-up
    call each, so that whatever else runs on the machine affects them alike."""
    for fn in fns.values():
        fn()
    times: dict[str, list[tuple[float, float]]] = {name: [] for name in fns}
    for _ in range(repeats):
        for name, fn in fns.items():
            w0, c0 = _clock()
            fn()
            w1, c1 = _clock()
            times[name].append((w1 - w0, c1 - c0))
    return {
        name: {"wall": float(np.median([w for w, _ in v])), "cpu": float(np.median([c for _, c in v]))}
        for name, v in times.items()
    }


def step_costs(
    models: dict[str, tuple[mujoco.MjModel, int]], state: np.ndarray, repeats: int
) -> dict[str, dict[str, float]]:
    """Wall and CPU seconds per ``mj_step`` of each model from ``state`` (controls held), each run of
    its number of steps timed interleaved with the others' (median of ``repeats``), with the ``ncon``
    and ``nefc`` of the state in that model.

    Args:
        models: name -> (model, steps per timed run); give each the same simulated time.
        state: (nstate,) full-physics state.
        repeats: timed runs of each.
    """
    out: dict[str, dict[str, float]] = {}
    runs = {}
    for name, (model, steps) in models.items():
        d = mujoco.MjData(model)
        mujoco.mj_setState(model, d, state, STATE)
        mujoco.mj_forward(model, d)
        out[name] = {"ncon": int(d.ncon), "nefc": int(d.nefc)}

        def run(model=model, d=d, steps=steps) -> None:
            mujoco.mj_setState(model, d, state, STATE)
            for _ in range(steps):
                mujoco.mj_step(model, d)

        runs[name] = run
    for name, timed in interleaved(runs, repeats).items():
        steps = models[name][1]
        out[name].update(wall=timed["wall"] / steps, cpu=timed["cpu"] / steps)
    return out


def object_gap(
    scene: Scene,
    state: np.ndarray,
    controls: np.ndarray,
    model: mujoco.MjModel,
    truth: mujoco.MjModel | None = None,
) -> float:
    """Largest distance (m) between the object's position in ``truth`` (default: the plant) and in
    ``model`` (a planning model) when both run ``controls`` from ``state``, compared after every step of
    ``model``.

    Args:
        scene: the scene (its plant model and object index).
        state: (nstate,) full-physics state.
        controls: (H, nu) controls; row h is held during step h of ``model``.
        model: the planning model (its timestep a multiple of ``truth``'s).
        truth: what ``model`` is compared with; ``None``: the plant.
    """
    body = int(scene.index.object_bodies[0])
    truth = scene.plant_model if truth is None else truth
    ratio = int(round(model.opt.timestep / truth.opt.timestep))
    dt, dm = mujoco.MjData(truth), mujoco.MjData(model)
    for m, d in ((truth, dt), (model, dm)):
        mujoco.mj_setState(m, d, state, STATE)
    gap = 0.0
    for u in controls:
        dt.ctrl[:] = u
        dm.ctrl[:] = u
        for _ in range(ratio):
            mujoco.mj_step(truth, dt)
        mujoco.mj_step(model, dm)
        gap = max(gap, float(np.linalg.norm(dt.xpos[body] - dm.xpos[body])))
    return gap


def price_options(
    scene: Scene,
    state: np.ndarray,
    controls: np.ndarray,
    option_sets: dict[str, dict[str, Any]],
    engine: RolloutEngine,
    repeats: int,
) -> dict[str, dict[str, float]]:
    """What each set of planning-model options saves and what it costs in agreement, at one state.

    The saving is that of the planning iteration's rollout: the candidates' controls rolled out with
    each model (timed interleaved), per physics step; options change the trajectories and with them the
    contacts, so a step cost taken from one held pose would not say what a rollout pays.

    Args:
        scene: the scene; its planning model (``"scene"``) is the baseline.
        state: (nstate,) full-physics state.
        controls: (S, H, nu) the candidates' controls; row 0 (the nominal) also runs the agreement
            check (:func:`object_gap`).
        option_sets: name -> ``mjOption`` fields set on a copy of the scene's planning model.
        engine: the rollout engine (its thread count is the one timed).
        repeats: interleaved timings (median).

    Returns:
        name -> ``step_us``, ``step_cpu_us`` (per rollout step), ``saving`` (CPU, fraction of the
        baseline's) and ``object_gap_mm`` (plant vs that planning model), with ``"scene"`` first.
    """
    models = {"scene": scene.planner_model}
    for name, options in option_sets.items():
        models[name] = copy.copy(scene.planner_model)
        set_options(models[name].opt, dict(options), what=f"planner_options.{name}")
    S, H, _ = controls.shape
    timed = interleaved(
        {name: lambda m=m: engine.run(state, controls, models=[m] * S) for name, m in models.items()}, repeats
    )
    base = timed["scene"]["cpu"]
    return {
        name: {
            "step_us": 1e6 * timed[name]["wall"] / (S * H),
            "step_cpu_us": 1e6 * timed[name]["cpu"] / (S * H),
            "saving": 1.0 - timed[name]["cpu"] / base,
            "object_gap_mm": 1e3 * object_gap(scene, state, controls[0], m),
        }
        for name, m in models.items()
    }


def instants(trial: Trial) -> dict[str, float]:
    """Control times of the *approach* and *contact* states (see the module docstring)."""
    track = trial.track
    active = np.flatnonzero(track.contact_active.any(axis=1))
    first = active[0] * track.dt if active.size else 0.5 * trial.duration
    last = active[-1] * track.dt if active.size else trial.duration
    return {"approach": 0.5 * first, "contact": 0.5 * (first + last)}


def planner_states(trial: Trial) -> dict[str, tuple[float, np.ndarray]]:
    """The plant's full state at the instants of :func:`instants` in the closed loop of ``trial``'s
    planner, run from the start to the contact instant: name -> (control time, state)."""
    times = instants(trial)
    visit = Trial(
        trial.scene, trial.reference, trial.problem.space, trial.problem.cost, trial.planner, trial.seed,
        duration=times["contact"] + trial.planner.replan_period, progress=False,
    )  # fmt: skip
    visit.run(snapshots=tuple(times.values()))
    return {name: (float(visit.snapshots[t][0]), visit.snapshots[t]) for name, t in times.items()}


def replay(scene: Scene, trial: Trial, every: float) -> Iterator[tuple[float, mujoco.MjData]]:
    """The plant tracking ``trial``'s reference splines (no planning; targets set every physics step)
    from the trial's start: yields ``(control time, data)`` at t = 0 and then every ``every`` seconds,
    without end. The data is live: copy what you keep (:func:`full_state`).
    """
    m = scene.plant_model
    d = mujoco.MjData(m)
    hand0 = trial.planner.targets(np.array([0.0]))[0]
    scene.reset(d, hand_qpos=hand0, object_qpos=scene.task.start_object_qpos(trial.reference.object_qpos[0]))
    dt = m.opt.timestep
    per = max(1, int(round(every / dt)))
    step = 0
    while True:
        yield step * dt, d
        for u in trial.planner.targets((step + np.arange(per)) * dt):
            d.ctrl[scene.index.actuators] = u
            mujoco.mj_step(m, d)
        step += per


def full_state(model: mujoco.MjModel, data: mujoco.MjData, t: float) -> np.ndarray:
    """(nstate,) the full-physics state of ``data`` with its time set to the control time ``t``."""
    state = np.empty(mujoco.mj_stateSize(model, STATE))
    mujoco.mj_getState(model, data, state, STATE)
    state[0] = t
    return state


def replay_states(scene: Scene, trial: Trial) -> dict[str, tuple[float, np.ndarray]]:
    """The plant's full state at the instants of :func:`instants` (on the planning model's 10 ms grid)
    while it tracks the reference's own splines (no planning): name -> (control time, state)."""
    pending = sorted(instants(trial).items(), key=lambda kv: kv[1])
    out: dict[str, tuple[float, np.ndarray]] = {}
    for t, d in replay(scene, trial, scene.planner_model.opt.timestep):
        while pending and t >= pending[0][1] - 1e-9:
            out[pending.pop(0)[0]] = (t, full_state(scene.plant_model, d, t))
        if not pending:
            return out
    return out


@checked
def benchmark_planner(
    make_scene: Callable[[], Scene],
    output_dir: str | Path,
    seed: Annotated[int, Ge(0)],
    sampler: SplineSpace,
    cost: TrackingCost,
    planner: Planner,
    threads: list[Annotated[int, Ge(1)]] | None = None,
    repeats: Annotated[int, Ge(1)] = 10,
    physics_steps: Annotated[int, Ge(1)] = 500,
    visit: Annotated[str, OneOf("planner", "replay")] = "planner",
    planner_options: dict[str, dict[str, Any]] | None = None,
    reference_cache: str | None = "outputs/cache/references",
    **_,
) -> Path:
    """Time the planner against the bare rollout and the physics at states a trial visits.

    Args:
        make_scene: builds the scene.
        output_dir: where ``benchmark.json`` goes.
        seed: seed of the sampling noise (the same candidates in every repeat).
        sampler, cost, planner: as for a trial (the planner's ``nthread`` is overridden).
        threads: thread counts to measure (default ``[1, 2]``).
        repeats: timed repetitions of each measurement (the median is reported).
        physics_steps: plant steps per physics timing (the planning model runs as much simulated time).
        visit: how the states are reached: the configured planner's closed loop, or the reference's
            splines replayed.
        planner_options: named sets of ``mjOption`` fields to price against the scene's planning model
            (:func:`price_options`); none: skipped.
        reference_cache: cache directory of synthesised references.

    Returns:
        Path of ``benchmark.json``.
    """
    planner_options = {name: dict(opts) for name, opts in (planner_options or {}).items()}
    scene = make_scene()
    reference = get_reference(scene, reference_cache)
    threads = list(threads or [1, 2])
    planner.close()
    planner.nthread = max(threads)  # the visit: rollouts are independent, so any count visits the same states
    trial = Trial(scene, reference, sampler, cost, planner, seed, progress=False)
    states = planner_states(trial) if visit == "planner" else replay_states(scene, trial)
    rows = []
    options: dict[str, dict[str, dict[str, float]]] = {}
    for name, (t, state) in states.items():
        theta0 = planner.theta.copy()
        plant = model = None
        for nthread in threads:
            planner.close()
            planner.nthread = nthread
            planner.bind(trial.problem)
            planner.phase(t)  # the planning model a plan at t rolls out (planner.switch_timestep)
            if plant is None:
                planning = planner.problem.scene.planner_model
                ratio = int(round(planning.opt.timestep / scene.plant_model.opt.timestep))
                steps = {
                    "plant": (scene.plant_model, physics_steps),
                    "model": (planning, max(1, physics_steps // ratio)),  # the same simulated time
                }
                plant, model = step_costs(steps, state, repeats).values()
            planner.theta[:] = theta0
            _, _, thetas = planner.candidates(np.random.default_rng(seed), t)
            ctrl = planner.controls(thetas, planner.basis(t))
            if planner_options and name not in options:  # ctrl[0]: the nominal candidate's controls
                options[name] = price_options(scene, state, ctrl, planner_options, planner.engine, repeats)

            def plan_once(t=t, state=state, theta0=theta0) -> None:
                planner.theta[:] = theta0  # the same candidates every time
                planner.plan(t, state, np.random.default_rng(seed))

            timed = interleaved(
                {
                    "plan": plan_once,
                    "rollout": lambda state=state, ctrl=ctrl: planner.engine.run(state, ctrl),
                },
                repeats,
            )
            rows.append(
                {
                    "state": name,
                    "time": t,
                    "ncon": plant["ncon"],
                    "nefc": plant["nefc"],
                    "plant_step_us": 1e6 * plant["wall"],
                    "plant_step_cpu_us": 1e6 * plant["cpu"],
                    "planning_model_step_us": 1e6 * model["wall"],
                    "planning_model_step_cpu_us": 1e6 * model["cpu"],
                    "nthread": nthread,
                    "plan_samples": planner.samples_at(t),
                    "horizon_steps": planner.steps,
                    "planning_timestep": planner.dt,
                    "plan_seconds": timed["plan"]["wall"],
                    "plan_cpu_seconds": timed["plan"]["cpu"],
                    "rollout_seconds": timed["rollout"]["wall"],
                    "rollout_cpu_seconds": timed["rollout"]["cpu"],
                    "overhead": timed["plan"]["wall"] / timed["rollout"]["wall"],
                    "overhead_cpu": timed["plan"]["cpu"] / timed["rollout"]["cpu"],
                }
            )
    planner.close()
    for row in rows:
        base = next(r for r in rows if r["state"] == row["state"] and r["nthread"] == threads[0])
        row["speedup"] = base["plan_seconds"] / row["plan_seconds"]
    span = instants(trial)
    active = np.flatnonzero(trial.track.contact_active.any(axis=1)) * trial.track.dt
    result = {
        "task": scene.task.name,
        "num_samples": planner.num_samples,
        "horizon_steps": planner.steps,
        "replan_period": planner.replan_period,
        "planner": type(planner).__name__,
        "visit": visit,
        # what a trial of this task costs besides its planner: its length and its share in contact
        "duration": trial.duration,
        "contact_fraction": float((active[-1] - active[0]) / trial.duration) if active.size else 0.0,
        "instants": span,
        "plant_timestep": scene.plant_model.opt.timestep,
        "planning_timestep": scene.planner_model.opt.timestep,
        "rows": rows,
        "planner_options": {"scene": scene.planner_options, "sets": planner_options, "states": options},
    }
    print(
        f"{scene.task.name}: {planner.num_samples} samples x {planner.steps} steps ({type(planner).__name__})"
    )
    header = (
        f"{'state':>9} {'ncon':>5} {'nefc':>5} {'plant us':>9} {'plan-model us':>13} {'thr':>4} "
        f"{'plan s':>8} {'(cpu)':>8} {'rollout s':>10} {'(cpu)':>8} {'overhead':>9} {'(cpu)':>6} "
        f"{'speed-up':>9}"
    )
    print(header)
    for r in rows:
        print(
            f"{r['state']:>9} {r['ncon']:>5} {r['nefc']:>5} {r['plant_step_us']:>9.1f} "
            f"{r['planning_model_step_us']:>13.1f} {r['nthread']:>4} {r['plan_seconds']:>8.4f} "
            f"{r['plan_cpu_seconds']:>8.4f} {r['rollout_seconds']:>10.4f} {r['rollout_cpu_seconds']:>8.4f} "
            f"{r['overhead']:>9.3f} {r['overhead_cpu']:>6.3f} {r['speedup']:>9.2f}"
        )
    if options:
        print(f"planning-model options vs the scene's ({dict(scene.planner_options) or 'MuJoCo defaults'}):")
        print(f"{'state':>9} {'options':>14} {'step us':>8} {'(cpu)':>7} {'saving':>7} {'plant gap mm':>13}")
        for state_name, priced in options.items():
            for set_name, p in priced.items():
                print(
                    f"{state_name:>9} {set_name:>14} {p['step_us']:>8.1f} {p['step_cpu_us']:>7.1f} "
                    f"{100 * p['saving']:>6.1f}% {p['object_gap_mm']:>13.2f}"
                )
    return write_json(Path(output_dir) / "benchmark.json", result)
