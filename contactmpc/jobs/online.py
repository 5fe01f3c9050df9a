"""The online job (``conf/job/online.yaml``): the controller live, in wall-clock time, optionally watched.

The trial job's inputs, trial, plant and record (:mod:`contactmpc.jobs.common`), run by
:class:`~contactmpc.online.OnlineLoop` instead of the synchronous :meth:`~contactmpc.trial.Trial.run`:
the plant at ``slowdown`` x real time in this thread, the planner replanning continuously in another.
The record has the trial's fields plus the online timing (:meth:`~contactmpc.online.OnlineLoop.summary`).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from pathlib import Path
from typing import Annotated

from contactmpc.jobs.common import (
    TrialInputs,
    build_trial,
    new_record,
    record_failure,
    run_loop,
    write_failure,
)
from contactmpc.jobs.trial import summarize
from contactmpc.online import OnlineLoop
from contactmpc.records import RECORD_NAME, SERIES_NAME, RunningTrials, write_json, write_series
from contactmpc.scene import Scene
from contactmpc.trial import Trial
from contactmpc.validate import ConfigError, Ge, Gt, checked
from contactmpc.viewer import LiveViewer

logger = logging.getLogger(__name__)


def timing_of(trial: Trial, min_interval: float = 0.0, apply_after: float = 0.0) -> tuple[float, float]:
    """``(min_interval, apply_after)`` that run ``trial``'s simulated timing online: a plan started at
    most every replan interval of the trial (``max(planner.replan_period, planner.latency)``), each
    acting no sooner than its latency after its state.

    Raises:
        ConfigError: ``min_interval`` or ``apply_after`` is given too, or the trial charges each plan its
            own latency (``planner.latency_per_plan``: online a plan's latency is its compute).
    """
    if min_interval or apply_after:
        raise ConfigError(
            "job.simulated_timing sets job.min_interval and job.apply_after from the planner: give either it "
            "or them"
        )
    if trial.planner.latency_per_plan:
        raise ConfigError(
            "job.simulated_timing: the trial charges each plan its own latency (planner.latency_per_plan); "
            "online a plan's latency is its compute, so there is no fixed timing to run"
        )
    return float(trial.replan_interval), float(trial.latency)


@checked
def run_online(
    make_scene: Callable[[], Scene],
    output_dir: str | Path,
    seed: Annotated[int, Ge(0)],
    inputs: TrialInputs,
    slowdown: Annotated[float, Gt(0)] = 1.0,
    viewer: bool = False,
    fps: Annotated[float, Gt(0)] = 30.0,
    max_lag: Annotated[float, Gt(0)] = 0.1,
    min_interval: Annotated[float, Ge(0)] = 0.0,
    apply_after: Annotated[float, Ge(0)] = 0.0,
    latency_by_samples: bool = False,
    simulated_timing: bool = False,
    config: dict | None = None,
    labels: dict | None = None,
) -> Path:
    """Run the closed loop live and write its record (``trial.json`` + ``timeseries.npz``).

    As :func:`~contactmpc.jobs.trial.run_trial`, the record is written whatever happens (``status``
    ``error``, ``diverged`` or ``interrupted``; Ctrl-C or closing the viewer end the run as
    ``interrupted``, with the online timing and the time series up to there).

    Args:
        make_scene: builds the scene (inside the record's guard).
        output_dir: the run directory.
        seed: seeds the planner's and the perturbation's generators (the run is not reproducible: what
            the planner sees depends on the machine's speed).
        inputs: sampler, cost, planner and the trial's settings, as for ``job=trial`` (the planner's
            ``nthread`` rollout threads plan beside the plant's thread; ``inputs.progress`` is the
            loop's bar).
        slowdown: wall seconds per control second (1: real time, as MuJoCo MPC's speed slider).
        viewer: open MuJoCo's passive viewer on the plant, with the reference's ghost and an overlay;
            without a display it says so in one line and runs headless.
        fps: viewer refreshes per wall second.
        max_lag: wall seconds the plant may fall behind its schedule and catch up; beyond, the schedule
            slips (``plant_behind_seconds``).
        min_interval: control seconds between the states two plans start from, at least
            (:class:`~contactmpc.online.OnlineLoop`); 0: continuous replanning.
        apply_after: control seconds from the state a plan starts from to the step it acts at, at
            least: a plan ready sooner is held until then (a fixed latency, as a simulated trial's
            ``planner.latency``); 0: each plan acts as soon as it is ready.
        latency_by_samples: with ``planner.compensate_latency``, predict each plan's state as far ahead
            as the last plans of the samples it is expected to draw took
            (:class:`~contactmpc.online.OnlineLoop`); False: the last plans, whatever they drew.
        simulated_timing: (not the paper's) run the simulated trial's timing where the machine plans
            within it: ``min_interval`` the trial's replan interval (``max(planner.replan_period,
            planner.latency)``) and ``apply_after`` its ``planner.latency`` (:func:`timing_of`);
            False: the two as given (0 and 0: MuJoCo MPC's loop).
        config: the resolved config, stored in the record.
        labels: names of the config choices for the record.

    Returns:
        Path of ``trial.json``.
    """
    out = Path(output_dir)
    record = new_record(seed, labels)
    wall0 = time.perf_counter()
    loop = None
    running = RunningTrials()
    try:
        with running:
            trial = build_trial(make_scene, seed, inputs, progress=False)
            scene = trial.scene
            if simulated_timing:
                min_interval, apply_after = timing_of(trial, min_interval, apply_after)
            record["simulated_timing"] = bool(simulated_timing)
            loop = OnlineLoop(
                trial,
                slowdown,
                max_lag,
                viewer=LiveViewer.open if viewer else None,
                fps=fps,
                milestone_hold=inputs.milestone_hold,
                progress=inputs.progress,
                min_interval=min_interval,
                apply_after=apply_after,
                latency_by_samples=latency_by_samples,
            )
            loop0 = time.perf_counter()
            try:
                log = run_loop(loop.run, trial, record)
            finally:
                timing = loop.summary()
                record.update(timing)
        record["concurrent_trials"] = running.max or None
        series = log.arrays()
        rules = (inputs.failure_gap, inputs.failure_min_expected, inputs.milestone_hold)
        record.update(summarize(series, trial, loop.wall_seconds, *rules))
        record.update(timing)  # the realised timing wins over the trial's (wall_seconds, ...)
        record["setup_seconds"] = loop0 - wall0
        record["status"] = "ok"
        write_series(out / SERIES_NAME, {**series, **loop.plan_series()})
    except (Exception, KeyboardInterrupt) as err:
        record["concurrent_trials"] = running.max or None
        if loop is not None and loop.log.columns:
            write_series(out / SERIES_NAME, {**loop.log.arrays(), **loop.plan_series()})
        # the loop's own wall time where it ran (the real-time factor's), else the job's
        wall = record.get("wall_seconds", time.perf_counter() - wall0)
        write_failure(out, record, err, wall, config)
        raise
    record["config"] = config
    path = write_json(out / RECORD_NAME, record)
    logger.info(
        "%s seed %d online at slowdown %g: ttf %s, completed %s; %.1f s in %.1f s (real-time factor %.3f, "
        "target %.3f); replan interval %s ms, plan age %s ms (median), %d of %d steps on a plan older than "
        "%g ms; plant behind %.2f s",
        scene.task.name,
        seed,
        slowdown,
        "none" if record["ttf"] is None else f"{record['ttf']:.2f}",
        record["completed"],
        record["simulated_seconds"],
        record["wall_seconds"],
        record["real_time_factor"],
        record["real_time_factor_target"],
        _ms(record["replan_interval_median"]),
        _ms(record["plan_age_median"]),
        record["stale_steps"],
        loop.steps_run,
        1000 * record["stale_threshold"],
        record["plant_behind_seconds"],
    )
    return path


run_online.record_failure = record_failure


def _ms(seconds: float | None) -> str:
    return "-" if seconds is None else f"{1000 * seconds:.0f}"
