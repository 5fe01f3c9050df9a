"""The online job (``conf/job/online.yaml``): the controller live, in wall-clock time, optionally watched.

The trial job's problem, planner, plant and record (:mod:`contactmpc.jobs.trial`), run by
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

from contactmpc.control.cost import TrackingCost
from contactmpc.control.planners.base import Planner
from contactmpc.control.samplers import SplineSpace
from contactmpc.jobs.trial import _new_record, _write_failure, record_failure, summarize
from contactmpc.online import OnlineLoop
from contactmpc.perturbations import Perturbation
from contactmpc.records import RECORD_NAME, SERIES_NAME, write_json, write_series
from contactmpc.reference.source import get_reference
from contactmpc.scene import Scene
from contactmpc.trial import Trial, check_planner_timing
from contactmpc.validate import Ge, Gt, checked
from contactmpc.viewer import LiveViewer

logger = logging.getLogger(__name__)


@checked
def run_online(
    make_scene: Callable[[], Scene],
    output_dir: str | Path,
    seed: Annotated[int, Ge(0)],
    sampler: SplineSpace,
    cost: TrackingCost,
    planner: Planner,
    slowdown: Annotated[float, Gt(0)] = 1.0,
    viewer: bool = False,
    fps: Annotated[float, Gt(0)] = 30.0,
    max_lag: Annotated[float, Gt(0)] = 0.1,
    num_control_points: int | None = None,
    duration: Annotated[float, Gt(0)] | None = None,
    progress: bool = True,
    failure_gap: Annotated[float, Ge(0)] = 0.3,
    failure_min_expected: Annotated[int, Ge(0)] = 6,
    milestone_hold: Annotated[float, Ge(0)] = 0.3,
    reference_cache: str | None = "outputs/cache/references",
    perturbation: Perturbation | None = None,
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
        sampler: sampler space.
        cost: running cost.
        planner: planner (its ``nthread`` rollout threads plan beside the plant's thread).
        slowdown: wall seconds per control second (1: real time, as MuJoCo MPC's speed slider).
        viewer: open MuJoCo's passive viewer on the plant, with the reference's ghost and an overlay;
            without a display it says so in one line and runs headless.
        fps: viewer refreshes per wall second.
        max_lag: wall seconds the plant may fall behind its schedule and catch up; beyond, the schedule
            slips (``plant_behind_seconds``).
        num_control_points: M; ``None`` = the reference's suggestion.
        duration: control time to run; ``None`` = the slowed reference.
        progress: show a progress bar.
        failure_gap: TTF rule: seconds without any contact (paper 0.3).
        failure_min_expected: TTF rule: needs more than this many expected contacts (paper 6).
        milestone_hold: a milestone counts when its condition holds, with the hand touching the
            object, for at least this many seconds in a row.
        reference_cache: directory caching synthesised references (``None`` disables).
        perturbation: plant-only changes drawn from the seed (:mod:`contactmpc.perturbations`).
        config: the resolved config, stored in the record.
        labels: names of the config choices for the record.

    Returns:
        Path of ``trial.json``.
    """
    out = Path(output_dir)
    record = _new_record(seed, labels)
    wall0 = time.perf_counter()
    loop = None
    try:
        scene = make_scene()
        check_planner_timing(scene, planner)  # before a reference is synthesised
        reference = get_reference(scene, reference_cache)
        trial = Trial(
            scene, reference, sampler, cost, planner, seed, num_control_points, duration, False, perturbation
        )
        loop = OnlineLoop(
            trial,
            slowdown,
            max_lag,
            viewer=LiveViewer.open if viewer else None,
            fps=fps,
            milestone_hold=milestone_hold,
            progress=progress,
        )
        loop0 = time.perf_counter()
        try:
            log = loop.run()
        finally:
            planner.close()
            if trial.draw is not None:
                record["perturbation"] = trial.draw.record()
            timing = loop.summary()
            record.update(timing)
        series = log.arrays()
        record.update(
            summarize(series, trial, loop.wall_seconds, failure_gap, failure_min_expected, milestone_hold)
        )
        record.update(timing)  # the realised timing wins over the configured (replan_interval, ...)
        record["setup_seconds"] = loop0 - wall0
        record["status"] = "ok"
        write_series(out / SERIES_NAME, {**series, **loop.plan_series()})
    except (Exception, KeyboardInterrupt) as err:
        if loop is not None and loop.log.columns:
            write_series(out / SERIES_NAME, {**loop.log.arrays(), **loop.plan_series()})
        # the loop's own wall time where it ran (the real-time factor's), else the job's
        wall = record.get("wall_seconds", time.perf_counter() - wall0)
        _write_failure(out, record, err, wall, config)
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
