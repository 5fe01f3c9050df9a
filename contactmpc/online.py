"""The closed loop in wall-clock time (``job=online``): the plant in one thread, the planner in another.

MuJoCo MPC's loop (``mjpc/agent.cc``) run for real, where :class:`~contactmpc.trial.Trial` simulates it:
the plant steps in the calling thread, paced so that one control second takes ``slowdown`` wall seconds
(1: real time, MJPC's speed slider), while a planning thread replans continuously, each iteration from
the latest plant state it has not planned from yet (states are published on the planner's grid, every
``scene.planner_timestep`` of control time).

**The swap.** The planner plans on its own control points (``planner.theta``, warm-started from its last
plan), which the plant never reads. A finished plan is published as a new, immutable :class:`Published`
(a read-only copy of the control points, its :class:`~contactmpc.control.planners.base.PlanInfo` and the
control time of the state it came from), swapped in by one reference assignment under a lock. The plant
reads that reference once per physics step and evaluates its targets from the published copy only
(``planner.targets(times, theta)``), from the first step after the plan is ready: it never sees a plan
half-written, and it keeps the previous plan for as long as the next one takes.

Everything else is the trial's: the :class:`~contactmpc.trial.Trial` (problem, planner binding, timing
checks) is built as for ``job=trial``, and its :class:`~contactmpc.plant.Plant`
(:meth:`~contactmpc.trial.Trial.start_plant`: the draw, stepping, the divergence check and the log's row,
one row every ``replan_interval`` of control time, so the TTF and milestones are computed as for a
trial) is used as it is. A configured ``planner.latency`` or
``latency_model`` is not applied (the real delay is); with ``planner.compensate_latency`` each plan
starts from its state predicted :meth:`OnlineLoop.expected_latency` ahead (the last plans' median
compute time). The trial's ``replan_interval`` sets only the log's
rows and the age beyond which a plan counts as stale. Unlike a trial, an online run is not reproducible:
which states the planner sees, and when its plans land, depend on how fast the machine is.
"""

from __future__ import annotations

import sys
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Annotated

import mujoco
import numpy as np
from tqdm.auto import tqdm

from contactmpc.control.planners.base import PlanInfo
from contactmpc.trial import Trial, TrialLog
from contactmpc.validate import Ge, Gt, checked

MIN_SLEEP = 1e-3
"""Wall seconds: the plant sleeps only when it is at least this far ahead of its schedule."""

SWITCH_INTERVAL = 5e-4
"""Python's thread switch interval during a run (s; default 5 ms): the plant thread gets the interpreter
back within this long when the planning thread holds it."""


class ViewerClosed(KeyboardInterrupt):
    """The viewer window was closed: the run ends like a Ctrl-C (status ``interrupted``)."""


@dataclass(frozen=True)
class Published:
    """One plan, as the plant sees it.

    Attributes:
        version: 0, 1, ... in the order the plans were published.
        theta: (M, d) its control points (a read-only copy).
        info: what its planning iteration did (cost terms, seconds, ...).
        state_time: control time of the plant state it was planned from (s).
        start_wall: ``time.perf_counter()`` when its iteration started.
        ready_wall: ``time.perf_counter()`` when it was published.
        clock: a paced reference's clock as this plan set it (``planner.pace_lag``; ``None`` without), so
            the plant reads the plan's targets at the reference times it was planned for.
    """

    version: int
    theta: np.ndarray
    info: PlanInfo
    state_time: float
    start_wall: float
    ready_wall: float
    clock: tuple | None = None


def _median_p95(values) -> tuple[float | None, float | None]:
    values = np.asarray(values, float)
    if values.size == 0:
        return None, None
    return float(np.median(values)), float(np.percentile(values, 95))


class OnlineLoop:
    """A trial's closed loop in wall-clock time.

    Args:
        trial: the trial to run live (built as for ``job=trial``; its :meth:`~Trial.run` is not used).
        slowdown: wall seconds per control second (1: real time; 10: ten times slower than real time).
        max_lag: wall seconds the plant may fall behind its schedule and catch up by stepping without
            sleeping; further behind, the schedule slips (it restarts from now) and the slip counts in
            ``plant_behind_seconds``.
        viewer: ``viewer(scene, track, model, data) -> LiveViewer | None``, called once the plant exists
            (:meth:`contactmpc.viewer.LiveViewer.open`); ``None``: headless.
        fps: how often the viewer is synchronised with the plant (per wall second).
        milestone_hold: the milestone rule's hold (s), for the viewer's overlay.
        progress: show a progress bar.
        min_interval: control seconds from the state one plan starts from to the state the next starts
            from, at least (not the paper's): the planner paces itself to no more than one plan per
            ``min_interval`` (the simulated loop's rate at a latency of that much), waiting for the
            plant; 0: continuous replanning (MuJoCo MPC's loop).
        apply_after: control seconds from the state a plan starts from to the step it takes effect, at
            least (not the paper's): a plan that is ready sooner is held until then, so each plan acts
            at a fixed latency, as in a simulated trial with ``planner.latency`` of that much (the
            first plan, from the initial state, acts at once); a plan that takes longer acts when it is
            ready. With ``planner.compensate_latency`` the planner predicts its state the larger of this
            and :meth:`expected_latency` ahead. 0: each plan acts as soon as it is ready (MuJoCo MPC's
            loop).
        latency_by_samples: (not the paper's) with ``planner.compensate_latency``, each plan predicts its
            state as far ahead as the last plans that drew the samples it is expected to draw took
            (:meth:`expected_latency` at its state's time), not the last plans whatever they drew: a plan
            of the grasp's ``acquire_samples``, several times dearer, no longer predicts only as far as
            the cheap plans before it took. False: the last plans' median, whatever they drew.
    """

    @checked
    def __init__(
        self,
        trial: Trial,
        slowdown: Annotated[float, Gt(0)] = 1.0,
        max_lag: Annotated[float, Gt(0)] = 0.1,
        viewer: Callable | None = None,
        fps: Annotated[float, Gt(0)] = 30.0,
        milestone_hold: Annotated[float, Ge(0)] = 0.3,
        progress: bool = False,
        min_interval: Annotated[float, Ge(0)] = 0.0,
        apply_after: Annotated[float, Ge(0)] = 0.0,
        latency_by_samples: bool = False,
    ) -> None:
        self.min_interval = float(min_interval)
        self.latency_by_samples = bool(latency_by_samples)
        self.apply_after = float(apply_after)
        self.trial = trial
        self.slowdown = float(slowdown)
        self.max_lag = float(max_lag)
        self.open_viewer = viewer
        self.fps = float(fps)
        self.milestone_hold = float(milestone_hold)
        self.progress = progress
        self.plans: list[Published] = []  # every published plan, in order
        self.swaps: list[tuple[int, int]] = []  # (version, plant step from which it was applied)
        self.log = TrialLog()
        self.viewer = None
        self._milestone_cache: tuple[int, str] = (-1, "")
        self.steps_run = 0
        self.planner_threads: int | None = None
        self.wall_seconds = 0.0  # the plant loop's, from its first step
        self.first_plan_wait = 0.0
        self.plant_wait_seconds = 0.0
        self.plant_behind_seconds = 0.0
        self.plant_lag_max = 0.0
        self.plant_lag_max_at: float | None = None  # control time
        self.step_version = np.zeros(0, np.int32)
        self.step_age = np.zeros(0)
        self._lock = threading.Lock()
        self._new_state = threading.Condition()
        self._stop = threading.Event()
        self._plan: Published | None = None
        self._state: tuple[int, float, np.ndarray] | None = None  # (sequence number, control time, state)
        self._error: BaseException | None = None

    # ------------------------------------------------------------------------------- the planner
    def _plan_loop(self, rng: np.random.Generator) -> None:
        """The planning thread: plan from each newer published state, publish each result."""
        planner = self.trial.planner
        last, due = -1, -np.inf  # the last state planned from; the control time the next may start at

        def waiting() -> bool:
            return self._state is None or self._state[0] == last or self._state[1] < due - 1e-9

        try:
            while True:
                with self._new_state:
                    while not self._stop.is_set() and waiting():
                        self._new_state.wait(0.1)
                    if self._stop.is_set():
                        return
                    last, t, state = self._state
                due = t + self.min_interval
                start = time.perf_counter()
                ahead = max(self.apply_after, self.expected_latency(t=t if self.latency_by_samples else None))
                # the prediction's path runs as far again, for the next plan's check of it, which starts
                # when this one is done: later than predicted where this plan takes longer than the last ones
                info = planner.plan(t, state, rng, ahead=ahead, reach=ahead)
                theta = planner.theta.copy()
                theta.flags.writeable = False
                clock = None if planner.pace_lag is None else planner.clock
                with self._lock:
                    plan = Published(len(self.plans), theta, info, t, start, time.perf_counter(), clock)
                    self.plans.append(plan)
                    self._plan = plan  # the swap: one reference, read by the plant once per step
        except BaseException as err:  # noqa: BLE001  (handed to the plant thread, which raises it)
            self._error = err
            self._stop.set()

    def expected_latency(self, recent: int = 5, t: float | None = None) -> float:
        """The control time the next plan is expected to take (s): the median compute time of the last
        ``recent`` plans, in control seconds (wall / ``slowdown``); 0 before the first. With
        ``planner.compensate_latency`` the planner plans from its state predicted this far ahead.

        ``t`` (``latency_by_samples``): the control time of the next plan's state; the median is then of
        the last ``recent`` plans that drew the samples it is expected to draw (:meth:`expected_samples`),
        or, where none has yet, the last plans' scaled by the samples (a plan's rollouts cost in
        proportion to them)."""
        if not self.plans:
            return 0.0
        last = self.plans[-recent:]
        scale = 1.0
        if t is not None:
            samples = self.expected_samples(t)
            same = [p for p in self.plans if p.info.samples == samples][-recent:]
            if same:
                last = same
            else:
                scale = samples / float(np.median([max(p.info.samples, 1) for p in last]))
        return scale * float(np.median([p.ready_wall - p.start_wall for p in last])) / self.slowdown

    def expected_samples(self, t: float) -> int:
        """The samples the plan from the state at control time ``t`` is expected to draw: the planner's at
        the reference's time there (``acquire_samples`` in the acquire window), or, with
        ``planner.acquire_error``, the last plan's where it drew more (the object is still off the
        reference, most likely). Needs a published plan."""
        planner = self.trial.planner
        samples = int(planner.samples_at(planner.reference_time(t)))
        if planner.acquire_error is not None:
            samples = max(samples, int(self.plans[-1].info.samples))
        return samples

    def _acting(self, t: float, current: Published | None) -> Published | None:
        """The plan the plant steps with at control time ``t``: the newest published one, or with
        ``apply_after`` the newest whose state is at least that much older than ``t`` (``current``, the
        plan in use, where none newer is)."""
        published = self._plan

        def due(p: Published) -> bool:
            return p.state_time + self.apply_after <= t + 1e-9

        if not self.apply_after or published is current or due(published):
            return published
        with self._lock:
            plans = self.plans[current.version + 1 :]
        ready = [p for p in plans if due(p)]
        return ready[-1] if ready else current

    def _publish_state(self, seq: int, t: float, state: np.ndarray) -> None:
        with self._new_state:
            self._state = (seq, t, state)
            self._new_state.notify()

    # --------------------------------------------------------------------------------- the plant
    def run(self) -> TrialLog:
        """Run the loop for the trial's ``duration`` of control time (or until Ctrl-C or the viewer is
        closed, which raise :class:`KeyboardInterrupt` / :class:`ViewerClosed`).

        Returns:
            The log, one row every ``trial.replan_interval`` of control time, with three more columns:
            ``plan_version``, ``plan_age`` (control time since the state of the plan in use, s) and
            ``wall_time`` (s since the plant's first step).

        Raises:
            PlantDiverged: if the plant becomes unstable; whatever the planning thread raised.
        """
        trial = self.trial
        scene, planner = trial.scene, trial.planner
        plant = trial.start_plant()
        draw, m, d = plant.draw, plant.model, plant.data
        dt = plant.timestep
        n_steps = int(round(trial.duration / dt))
        per_log = int(round(trial.replan_interval / dt))
        per_state = max(1, int(round(scene.planner_timestep / dt)))
        # draw.delay: the planner is given the state of one replan interval earlier (as in a trial)
        observed: deque = deque(maxlen=(per_log // per_state + 1) if draw.delay else 1)
        self.step_version = np.full(n_steps, -1, np.int32)
        self.step_age = np.full(n_steps, np.nan)
        self.planner_threads = None if planner.engine is None else planner.engine.nthread
        if self.open_viewer is not None:
            self.viewer = self.open_viewer(scene, trial.track, m, d)
        bar = tqdm(total=n_steps, desc=f"{scene.task.name} (online)", unit="step", disable=not self.progress)
        thread = threading.Thread(
            target=self._plan_loop, args=(np.random.default_rng(trial.seed),), name="planner", daemon=True
        )
        switch = sys.getswitchinterval()
        sys.setswitchinterval(SWITCH_INTERVAL)
        thread.start()
        try:
            plan, targets, first = None, np.zeros((0, 0)), 0  # targets of `plan` for steps first, first+1...
            wall0 = time.perf_counter()
            origin, origin_step = wall0, 0  # the schedule: step k is due at origin + (k - origin_step) * pace
            pace = dt * self.slowdown
            next_sync = wall0
            for k in range(n_steps):
                t = k * dt
                if k % per_state == 0:  # the state on the planner's grid, as the planner is given it
                    state = plant.state(t)  # rollouts run on the control clock
                    observed.append(plant.observe(state))
                    self._publish_state(k, t, observed[0])
                if k == 0:  # the plant starts with the first plan, from the initial state
                    self._first_plan()
                    self.first_plan_wait = time.perf_counter() - wall0
                    wall0 = origin = next_sync = time.perf_counter()
                if self._error is not None:
                    raise self._error
                published = self._acting(t, plan) if k else self._plan  # the first plan acts at once
                if published is not plan or k - first >= len(targets):
                    if published is not plan:
                        self.swaps.append((published.version, k))
                    plan, first = published, k
                    targets = planner.targets((k + np.arange(per_state)) * dt, plan.theta, plan.clock)
                target = targets[k - first]
                age = t - plan.state_time
                self.step_version[k], self.step_age[k] = plan.version, age
                if k % per_log == 0:
                    if k:
                        plant.check(t - per_log * dt, t)
                    at = None if plan.clock is None else planner.reference_time(t, plan.clock)
                    plant.log(self.log, t, target, plan.info, at)
                    self.log.append(
                        plan_version=plan.version, plan_age=age, wall_time=time.perf_counter() - wall0
                    )
                    bar.update(min(per_log, n_steps - k))
                now = time.perf_counter()
                lag = now - (origin + (k - origin_step) * pace)
                if lag < -MIN_SLEEP:
                    time.sleep(-lag)
                    self.plant_wait_seconds += -lag
                elif lag > self.max_lag:  # too far behind to catch up: the schedule slips
                    self.plant_behind_seconds += lag
                    origin, origin_step = now, k
                if lag > self.plant_lag_max:
                    self.plant_lag_max, self.plant_lag_max_at = lag, t
                plant.step(target, t, t + dt)
                self.steps_run = k + 1
                if self.viewer is not None and now >= next_sync:
                    next_sync = now + 1.0 / self.fps
                    self._sync_viewer(d, t + dt)
            plant.check((n_steps - per_log) * dt, n_steps * dt)
        finally:
            self.wall_seconds = time.perf_counter() - wall0
            self._stop.set()
            with self._new_state:
                self._new_state.notify_all()
            thread.join()
            sys.setswitchinterval(switch)
            bar.close()
            if self.viewer is not None:
                self.viewer.close()
        if self._error is not None:
            raise self._error
        return self.log

    def _first_plan(self) -> None:
        """Wait for the first plan (from the initial state); the plant's clock starts then."""
        while self._plan is None:
            if self._error is not None:
                raise self._error
            time.sleep(1e-3)

    # -------------------------------------------------------------------------------- the viewer
    def _sync_viewer(self, d: mujoco.MjData, t: float) -> None:
        viewer = self.viewer
        if not viewer.is_running():
            raise ViewerClosed(f"viewer closed at t={t:.3f}s")
        viewer.sync(d, t, self.overlay(t))

    def overlay(self, t: float) -> list[tuple[str, str]]:
        """The viewer's text: (label, value) lines for control time ``t``."""
        plan = self._plan
        lines = [("time", f"{t:.2f} s (x{1 / self.slowdown:.2g} real time)")]
        recent = self.plans[-6:]
        if len(recent) > 1:
            per_plan = (recent[-1].ready_wall - recent[0].ready_wall) / (len(recent) - 1)
            lines.append(
                ("replan", f"{1 / per_plan:.1f} Hz ({per_plan / self.slowdown * 1000:.0f} ms control)")
            )
        if plan is not None:
            lines.append(("plan age", f"{(t - plan.state_time) * 1000:.0f} ms (plan {plan.version})"))
            for name, value in plan.info.terms.items():
                lines.append((f"cost {name}", f"{value:.4g}"))
        lines.append(("milestones", self._milestones_reached()))
        return lines

    def _milestones_reached(self) -> str:
        cols = self.log.columns
        if not cols.get("time"):
            return "-"
        key = len(cols["time"])
        if self._milestone_cache[0] != key:
            task = self.trial.scene.task
            held = np.stack(cols["contacts"]).any(axis=-1)
            reached = task.milestones(
                np.stack(cols["object_qpos"]),
                np.stack(cols["expected_object_qpos"]),
                held,
                np.stack(cols["time"]),
                self.milestone_hold,
            )
            self._milestone_cache = (key, ", ".join(k for k, v in reached.items() if v) or "none yet")
        return self._milestone_cache[1]

    # ------------------------------------------------------------------------------- the record
    def summary(self) -> dict:
        """What only an online run knows, as flat record fields (control seconds unless ``_wall``).

        * ``replan_interval_median`` / ``_p95``: control time between consecutive plans taking effect
          (the record's ``replan_interval`` and ``latency`` stay the trial's configured ones);
          ``replan_interval_step_median``: the median over plant steps of the interval each lies in (a
          long interval weighs by its length: plans in contact are slower, and fewer);
          ``replan_interval_wall_median``: wall time between consecutive plans being published.
        * ``plan_latency_median`` / ``_p95``: from the state a plan was planned from to its taking effect.
        * ``plan_age_median`` / ``_p95``: over plant steps, the age of the plan in use (control time
          since its state).
        * ``stale_steps`` (``stale_fraction``): plant steps run on a plan older than ``stale_threshold``,
          the trial's ``replan_interval`` (the synchronous loop's plans never are).
        * ``plan_seconds_grasp_median``: the median wall time of the plans planned from a state 1 s before
          to 2 s after the reference's first expected contact (the grasp: where ``effort=acquire`` draws its
          samples); ``plan_seconds_after_grasp_median``: of those planned from then on (``None`` without a
          first expected contact, or without such plans). ``plan_seconds_by_samples``: the median wall
          time of the plans that drew each number of samples (``{"128": ..., "32": ...}`` with
          ``effort=acquire``: the grasp's plans and the later ones, whatever state they planned from).
        * ``plant_wait_seconds``: wall time the plant slept to keep its pace (its headroom);
          ``plant_behind_seconds``: wall time the schedule slipped because the plant fell more than
          ``max_lag`` behind (0: it kept up, ``kept_up``); ``plant_lag_max``: the most it was behind
          (wall s), at control time ``plant_lag_max_at``; ``first_plan_wait``: wall time the plant
          waited for the first plan before starting.
        """
        trial = self.trial
        dt = trial.scene.plant_model.opt.timestep
        ran = slice(0, self.steps_run)
        age = self.step_age[ran]
        version = self.step_version[ran]
        applied = np.array([k for _, k in self.swaps], float) * dt  # when each applied plan took effect
        latency = [a - self.plans[v].state_time for a, (v, _) in zip(applied, self.swaps, strict=True)]
        ready = [p.ready_wall for p in self.plans]
        gaps = np.diff(applied)
        interval = _median_p95(gaps)
        per_step = np.repeat(gaps, np.round(gaps / dt).astype(int))  # each step weighs its interval
        lat = _median_p95(latency)
        ages = _median_p95(age[version >= 0])
        seconds = [p.info.seconds for p in self.plans]
        grasp, after = self._grasp_plans()
        sim = self.steps_run * dt
        stale = int(np.sum(age > trial.replan_interval + 1e-9))
        return {
            "mode": "online",
            "slowdown": self.slowdown,
            "min_interval": self.min_interval,
            "apply_after": self.apply_after,
            "latency_by_samples": self.latency_by_samples,
            "real_time_factor_target": 1.0 / self.slowdown,
            "simulated_seconds": sim,
            "wall_seconds": self.wall_seconds,
            "real_time_factor": sim / self.wall_seconds if self.wall_seconds > 0 else None,
            "kept_up": self.plant_behind_seconds == 0.0,
            "num_plans": len(self.plans),
            "plans_applied": len(self.swaps),
            "replan_interval_median": interval[0],
            "replan_interval_p95": interval[1],
            "replan_interval_step_median": _median_p95(per_step)[0],
            "replan_interval_wall_median": _median_p95(np.diff(ready))[0],
            "plan_latency_median": lat[0],
            "plan_latency_p95": lat[1],
            "plan_age_median": ages[0],
            "plan_age_p95": ages[1],
            "stale_threshold": trial.replan_interval,
            "stale_steps": stale,
            "stale_fraction": stale / self.steps_run if self.steps_run else None,
            "plan_seconds_mean": float(np.mean(seconds)) if seconds else None,
            "plan_seconds_p95": _median_p95(seconds)[1],
            "plan_seconds_grasp_median": _median_p95(grasp)[0],
            "plan_seconds_after_grasp_median": _median_p95(after)[0],
            "plan_seconds_by_samples": self._plans_by_samples(),
            "diverged_rollouts": int(sum(p.info.num_diverged for p in self.plans)),
            "planner_threads": self.planner_threads,
            "first_plan_wait": self.first_plan_wait,
            "plant_wait_seconds": self.plant_wait_seconds,
            "plant_behind_seconds": self.plant_behind_seconds,
            "plant_lag_max": self.plant_lag_max,
            "plant_lag_max_at": self.plant_lag_max_at,
            "viewer": self.viewer is not None,
            "drags": [] if self.viewer is None else list(self.viewer.drags),
        }

    def _grasp_plans(self, before: float = 1.0, until: float = 2.0) -> tuple[list[float], list[float]]:
        """The wall times of the plans planned from ``before`` s before to ``until`` s after the reference's
        first expected contact, and of those planned from then on (both empty without one)."""
        first = getattr(self.trial.planner.problem, "first_contact", None)
        if first is None:
            return [], []
        times = [(p.state_time, p.info.seconds) for p in self.plans]
        grasp = [s for t, s in times if first - before <= t < first + until]
        return grasp, [s for t, s in times if t >= first + until]

    def _plans_by_samples(self) -> dict[str, float]:
        """The median wall time of the plans that drew each number of samples (the most first)."""
        counts = sorted({p.info.samples for p in self.plans}, reverse=True)
        return {
            str(n): float(np.median([p.info.seconds for p in self.plans if p.info.samples == n]))
            for n in counts
        }

    def plan_series(self) -> dict[str, np.ndarray]:
        """Per-plan arrays for ``timeseries.npz``: ``plans_state_time`` (the control time each plan was
        planned from), ``plans_seconds`` (its wall time), ``plans_applied_time`` (the control time it took
        effect, NaN if it never did: the next plan came within the same physics step)."""
        dt = self.trial.scene.plant_model.opt.timestep
        applied = np.full(len(self.plans), np.nan)
        for version, k in self.swaps:
            applied[version] = k * dt
        return {
            "plans_state_time": np.array([p.state_time for p in self.plans]),
            "plans_seconds": np.array([p.info.seconds for p in self.plans]),
            "plans_applied_time": applied,
        }
