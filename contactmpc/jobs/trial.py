"""The trial job (``conf/job/trial.yaml``): one closed-loop trial and its record."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from pathlib import Path
from typing import Annotated

import numpy as np

from contactmpc.jobs.common import (
    TrialInputs,
    build_trial,
    failure_status,
    new_record,
    record_failure,
    run_loop,
    write_failure,
)
from contactmpc.metrics import errors_by_window, time_to_failure, time_to_failure_cut_short
from contactmpc.records import RECORD_NAME, SERIES_NAME, RunningTrials, write_json, write_series
from contactmpc.scene import Scene
from contactmpc.trial import PlantDiverged, Trial
from contactmpc.validate import Ge, Gt, OneOf, checked

__all__ = ["TrialInputs", "failure_status", "record_failure", "run_trial", "summarize"]

logger = logging.getLogger(__name__)


@checked
def run_trial(
    make_scene: Callable[[], Scene],
    output_dir: str | Path,
    seed: Annotated[int, Ge(0)],
    inputs: TrialInputs,
    video: Annotated[str, OneOf("gif", "mp4")] | None = None,
    video_speed: Annotated[float, Gt(0)] = 1.0,
    start_time: Annotated[float, Ge(0)] | None = None,
    start_before_contact: Annotated[float, Ge(0)] | None = None,
    end_after_contact: Annotated[float, Gt(0)] | None = None,
    config: dict | None = None,
    labels: dict | None = None,
) -> Path:
    """Run one closed-loop trial and write its record (``trial.json`` + ``timeseries.npz``).

    The record is written whatever happens: a trial that raises gets ``status`` ``"error"`` (or
    ``"diverged"``, or ``"interrupted"`` for Ctrl-C) and the reason, and the exception is re-raised
    after the record is on disk. A trial whose arguments cannot be built at all gets its record from
    :func:`record_failure` (``launch.py`` calls it as ``run_trial.record_failure``). An argument its
    declaration does not accept (``Annotated``, see :mod:`contactmpc.validate`) raises before anything
    is done or written.

    Args:
        make_scene: builds the scene (inside the record's guard, so a scene that fails to compile
            still leaves a record).
        output_dir: the run directory.
        seed: the trial's seed.
        inputs: sampler, cost, planner and the trial's settings (shared with ``job=online``; its config
            holds their fields at the job's own level: ``job.failure_gap``, ...).
        video: ``"gif"`` or ``"mp4"`` to render the trial next to its record (``trial.<ext>``);
            ``None`` renders nothing.
        video_speed: playback speed of the video relative to control time.
        start_time: start the trial at this control time (s), the plant at the reference's state there
            (:class:`~contactmpc.trial.Trial`'s ``start_time``; the cheap screen): TTF, milestones and
            errors are measured on what it logs, from there on; the record says ``start_time``.
            ``None``: at 0, the whole trial.
        start_before_contact: start that many seconds (control time) before the reference's first
            expected contact instead (rounded to the plant's step); not with ``start_time``.
        end_after_contact: end the trial that many seconds (control time) after the reference's first
            expected contact instead of at ``duration``; not with ``duration``.
        config: the resolved config, stored in the record.
        labels: names of the config choices (task, hand, cost, sampler, planner, ...) for the record.

    Returns:
        Path of ``trial.json``.
    """
    out = Path(output_dir)
    record = new_record(seed, labels)
    planner = inputs.planner
    rules = (inputs.failure_gap, inputs.failure_min_expected, inputs.milestone_hold)
    wall0 = time.perf_counter()
    running = RunningTrials()
    try:
        with running:
            trial = build_trial(
                make_scene, seed, inputs, window=(start_time, start_before_contact, end_after_contact)
            )
            if trial.start_time:
                record["start_time"] = trial.start_time
            scene = trial.scene
            engine = getattr(planner, "engine", None)  # rollout threads (None: a planner without rollouts)
            record["threads"] = None if engine is None else engine.nthread
            loop0, cpu0 = time.perf_counter(), time.process_time()
            log = run_loop(trial.run, trial, record)
        record["concurrent_trials"] = running.max or None
        series = log.arrays()
        wall = time.perf_counter() - loop0  # the closed loop alone, for the real-time factor
        record.update(summarize(series, trial, wall, *rules))
        record["cpu_seconds"] = time.process_time() - cpu0  # the process's, all rollout threads
        record["setup_seconds"] = loop0 - wall0
        record["status"] = "ok"
        write_series(out / SERIES_NAME, series)
        if video:
            from contactmpc.render import render_trial_video

            record["video"] = str(
                render_trial_video(scene, series, trial.track, out / f"trial.{video}", speed=video_speed)
            )
    except (Exception, KeyboardInterrupt) as err:
        record["concurrent_trials"] = running.max or None
        if isinstance(err, PlantDiverged) and err.log is not None and err.log.columns:
            # what the trial did until its plant went unstable: a failure there if inside the span
            series = err.log.arrays()
            wall = time.perf_counter() - loop0
            record.update(summarize(series, trial, wall, *rules, err.time))
            record["cpu_seconds"] = time.process_time() - cpu0
            record["diverged_time"] = err.time
            write_series(out / SERIES_NAME, series)
        write_failure(out, record, err, time.perf_counter() - wall0, config)
        raise
    record["config"] = config
    path = write_json(out / RECORD_NAME, record)
    logger.info(
        "%s seed %d: ttf %s, completed %s %s, settled %s, object error %.1f mm / %.1f deg / %.3f rad or m "
        "(mean over the trial), %.1f s simulated in %.1f s (real-time factor %.3f)",
        scene.task.name,
        seed,
        "none (no contact expected during the trial)" if record["ttf"] is None else f"{record['ttf']:.2f}",
        record["completed"],
        {k[10:]: v for k, v in record.items() if k.startswith("milestone_")},
        record["settled"],
        1000 * record["object_position_error_mean"],
        np.degrees(record["object_rotation_error_mean"]),
        record["object_articulation_error_mean"],
        record["simulated_seconds"],
        record["wall_seconds"],
        record["real_time_factor"],
    )
    return path


run_trial.record_failure = record_failure


def summarize(
    series: dict,
    trial: Trial,
    wall: float,
    gap: float,
    min_expected: int,
    hold: float,
    diverged_time: float | None = None,
) -> dict:
    """Flat summary fields of a trial's log (``hold``: see ``milestone_hold``).

    ``completed`` is every milestone of :meth:`~contactmpc.tasks.base.Task.milestones`; ``settled`` is
    the final milestone (:meth:`~contactmpc.tasks.base.Task.settled`: the trial ends as the reference
    ends, the object at rest at its final pose and let go where the reference lets go), kept out of
    ``milestone_*`` and of ``completed``; ``finished_cleanly`` is both.

    A trial whose plant diverged (``diverged_time``: the control time of its last replan, its log ends
    there) is measured on what it logged: its TTF against the whole trial's contact span, failed at
    ``diverged_time`` if that is inside the span and the rule did not fire earlier
    (:func:`~contactmpc.metrics.time_to_failure_cut_short`); the milestones it reached until then; never
    ``settled`` (it did not end as the reference ends).
    """
    if diverged_time is None:
        ttf = time_to_failure(
            series["time"], series["contacts"], series["expected_contacts"], gap, min_expected
        )
    else:
        ttf = time_to_failure_cut_short(
            series["time"],
            series["contacts"],
            series["expected_contacts"],
            *trial.expected_log(),
            diverged_time,
            gap,
            min_expected,
        )
    plan = series["plan_seconds"]
    sim = (float(trial.duration) if diverged_time is None else float(diverged_time)) - trial.start_time
    final_err = trial.scene.task.layout.error(series["object_qpos"][-1], trial.track.object_qpos[-1])
    task = trial.scene.task
    expected = series["expected_object_qpos"]
    held = series["contacts"].any(axis=-1)
    milestones = task.milestones(series["object_qpos"], expected, held, series["time"], hold)
    completed = all(milestones.values())
    let_go = not bool(trial.track.contact_active[-1].any())  # the reference ends without contact
    settled = None
    if diverged_time is None:
        settled = task.settled(
            series["object_qpos"], trial.track.object_qpos[-1], held, series["time"], hold, let_go
        )
    switch = {}
    if trial.planner.switch_timestep is not None:  # when its planning model switched (and back)
        switch["switch_time"] = trial.planner.switched_at
        if trial.planner.switches_back:
            switch["switch_back_time"] = trial.planner.switched_back_at
    if trial.planner.pace_retry is not None:  # (pace_retry) when the grasp was tried again
        switch["retry_times"] = list(trial.planner.retried_at)
    if trial.planner.acquire_error is not None:  # (acquire_error) plans given the grasp's samples for it
        switch["error_plans"] = int(trial.planner.error_plans)
    per_plan = {}
    if trial.planner.latency_per_plan:  # each plan its own latency: which ones, and how many of each
        dt = trial.scene.plant_model.opt.timestep
        last = series["time"][-1] if len(series["time"]) else -np.inf  # the plans it ran (not a diverged
        ran = [lag for k, lag, _ in trial.schedule() if k * dt <= last + 0.5 * dt]  # trial's whole schedule)
        lags, counts = np.unique(ran, return_counts=True)
        per_plan["plan_latencies"] = {f"{lag * dt:.3f}": int(n) for lag, n in zip(lags, counts, strict=True)}
    names = ("object_position_error", "object_rotation_error", "object_articulation_error")
    windows = errors_by_window(series["time"], {k: series[k] for k in names}, ttf.span)
    return {
        "ttf": ttf.ttf,
        "ttf_note": ttf.note,
        "completed": completed,
        **{f"milestone_{k}": v for k, v in milestones.items()},
        "settled": settled is not None,
        "settled_time": settled,
        "reference_lets_go": let_go,
        "finished_cleanly": completed and settled is not None,
        "failed": ttf.failed,
        "failure_time": ttf.failure_time,
        "contact_span_start": None if ttf.span is None else ttf.span[0],
        "contact_span_end": None if ttf.span is None else ttf.span[1],
        "object_position_error_mean": float(np.mean(series["object_position_error"])),
        "object_rotation_error_mean": float(np.mean(series["object_rotation_error"])),
        "object_articulation_error_mean": float(np.mean(series["object_articulation_error"])),
        **windows,
        "final_object_position_error": float(final_err.position),
        "final_object_rotation_error": float(final_err.rotation),
        "final_object_articulation_error": float(final_err.articulation),
        "contact_fraction": float(np.mean(series["contacts"].any(axis=-1))),
        "first_contact_time": float(series["time"][held.argmax()]) if held.any() else None,
        "last_contact_time": float(series["time"][len(held) - 1 - held[::-1].argmax()])
        if held.any()
        else None,
        "plan_seconds_mean": float(np.mean(plan)),
        "plan_seconds_p95": float(np.percentile(plan, 95)),
        "simulated_seconds": sim,
        "wall_seconds": wall,
        "real_time_factor": sim / wall if wall > 0 else None,
        "num_control_points": trial.spline.num_control_points,
        "num_plans": int(len(plan)),
        "replan_interval": trial.replan_interval,
        "latency": trial.latency,
        "diverged_rollouts": int(np.sum(series["num_diverged"])),
        **switch,
        **per_plan,
    }
