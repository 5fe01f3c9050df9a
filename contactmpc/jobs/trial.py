"""The trial job (``conf/job/trial.yaml``): one closed-loop trial and its record."""

from __future__ import annotations

import logging
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Annotated

import numpy as np

from contactmpc.control.cost import TrackingCost
from contactmpc.control.planners.base import Planner
from contactmpc.control.samplers import SplineSpace
from contactmpc.metrics import errors_by_window, time_to_failure, time_to_failure_cut_short
from contactmpc.perturbations import Perturbation
from contactmpc.records import (
    RECORD_NAME,
    SERIES_NAME,
    git_revision,
    machine,
    one_line,
    versions,
    write_json,
    write_series,
)
from contactmpc.reference.source import get_reference
from contactmpc.scene import Scene
from contactmpc.trial import PlantDiverged, Trial, check_planner_timing
from contactmpc.validate import ConfigError, Ge, Gt, OneOf, checked

logger = logging.getLogger(__name__)


@checked
def run_trial(
    make_scene: Callable[[], Scene],
    output_dir: str | Path,
    seed: Annotated[int, Ge(0)],
    sampler: SplineSpace,
    cost: TrackingCost,
    planner: Planner,
    num_control_points: int | None = None,
    duration: Annotated[float, Gt(0)] | None = None,
    progress: bool = True,
    failure_gap: Annotated[float, Ge(0)] = 0.3,
    failure_min_expected: Annotated[int, Ge(0)] = 6,
    milestone_hold: Annotated[float, Ge(0)] = 0.3,
    reference_cache: str | None = "outputs/cache/references",
    video: Annotated[str, OneOf("gif", "mp4")] | None = None,
    video_speed: Annotated[float, Gt(0)] = 1.0,
    perturbation: Perturbation | None = None,
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
        sampler: sampler space (PCA or joint splines).
        cost: running cost.
        planner: planner.
        num_control_points: M; ``None`` = the reference's suggestion.
        duration: control time to simulate; ``None`` = the slowed reference.
        progress: show a progress bar.
        failure_gap: TTF rule: seconds without any contact (paper 0.3).
        failure_min_expected: TTF rule: needs more than this many expected contacts (paper 6).
        milestone_hold: a milestone counts when its condition holds, with the hand touching the
            object, for at least this many seconds in a row; the final one (``settled``) when it
            holds over the trial's last this many seconds or more.
        reference_cache: directory caching synthesised references (``None`` disables).
        video: ``"gif"`` or ``"mp4"`` to render the trial next to its record (``trial.<ext>``);
            ``None`` renders nothing.
        video_speed: playback speed of the video relative to control time.
        perturbation: plant-only changes drawn from the seed (:mod:`contactmpc.perturbations`); the
            drawn values go into the record (``perturbation``). ``None``: none.
        start_time: start the trial at this control time (s), the plant at the reference's state there
            (:class:`~contactmpc.trial.Trial`'s ``start_time``; the cheap screen): TTF, milestones and
            errors are measured on what it logs, from there on; the record says ``start_time``.
            ``None``: at 0, the whole trial.
        start_before_contact: start that many seconds (control time) before the reference's first
            expected contact instead (rounded to the plant's step); not with ``start_time``.
        end_after_contact: end the trial that many seconds (control time) after the reference's first
            expected contact instead of at ``duration``; not with ``duration``.
        config: the resolved config, stored in the record.
        labels: names of the config choices (task, hand, cost, sampler, planner) for the record.

    Returns:
        Path of ``trial.json``.
    """
    out = Path(output_dir)
    record = _new_record(seed, labels)
    wall0 = time.perf_counter()
    try:
        scene = make_scene()
        check_planner_timing(scene, planner)  # before a reference is synthesised
        reference = get_reference(scene, reference_cache)
        start, duration = screen_window(
            scene, reference, start_time, start_before_contact, end_after_contact, duration
        )
        trial = Trial(
            scene,
            reference,
            sampler,
            cost,
            planner,
            seed,
            num_control_points,
            duration,
            progress,
            perturbation,
            start,
        )
        if start:
            record["start_time"] = start
        engine = getattr(planner, "engine", None)  # rollout threads (None: a planner without rollouts)
        record["threads"] = None if engine is None else engine.nthread
        loop0, cpu0 = time.perf_counter(), time.process_time()
        try:
            log = trial.run()
        finally:
            planner.close()
            if trial.draw is not None:
                record["perturbation"] = trial.draw.record()
        series = log.arrays()
        wall = time.perf_counter() - loop0  # the closed loop alone, for the real-time factor
        record.update(summarize(series, trial, wall, failure_gap, failure_min_expected, milestone_hold))
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
        if isinstance(err, PlantDiverged) and err.log is not None and err.log.columns:
            # what the trial did until its plant went unstable: a failure there if inside the span
            series = err.log.arrays()
            wall = time.perf_counter() - loop0
            record.update(
                summarize(series, trial, wall, failure_gap, failure_min_expected, milestone_hold, err.time)
            )
            record["cpu_seconds"] = time.process_time() - cpu0
            record["diverged_time"] = err.time
            write_series(out / SERIES_NAME, series)
        _write_failure(out, record, err, time.perf_counter() - wall0, config)
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


def screen_window(
    scene: Scene,
    reference,
    start_time: float | None,
    start_before_contact: float | None,
    end_after_contact: float | None,
    duration: float | None,
) -> tuple[float, float | None]:
    """The control times a trial starts and ends at, ``(start, duration)``, from :func:`run_trial`'s
    options: ``start_before_contact`` and ``end_after_contact`` are counted from the reference's first
    expected contact (its first frame with one, slowed), rounded to the plant's step.

    Raises:
        ConfigError: both ways of giving the start (or the end) are set, or the reference expects no
            contact to count from.
    """
    if start_time is not None and start_before_contact is not None:
        raise ConfigError("job.start_time and job.start_before_contact are both set: choose one")
    if duration is not None and end_after_contact is not None:
        raise ConfigError("duration and job.end_after_contact are both set: choose one")
    start = 0.0 if start_time is None else float(start_time)
    if start_before_contact is None and end_after_contact is None:
        return start, duration
    touching = np.flatnonzero(np.asarray(reference.contact_active).any(axis=-1))
    if not touching.size:
        raise ConfigError("job.start_before_contact / end_after_contact: the reference expects no contact")
    first = float(reference.time[touching[0]] - reference.time[0]) * scene.task.time_scale
    dt = scene.plant_model.opt.timestep
    if start_before_contact is not None:
        start = max(0.0, round((first - start_before_contact) / dt) * dt)
    if end_after_contact is not None:
        duration = round((first + end_after_contact) / dt) * dt
    return start, duration


def record_failure(
    output_dir: str | Path,
    seed: int,
    error: BaseException,
    config: dict | None = None,
    labels: dict | None = None,
) -> Path:
    """Write the record of a trial that could not start: its sampler, cost or planner failed to build.

    The record has the fields of a trial that failed while running (status ``error``, or
    ``interrupted`` for a ``KeyboardInterrupt``; the one-line reason, the traceback, labels, seed,
    versions and the config), so a sweep's analysis counts it like any other failed trial.

    Returns:
        Path of ``trial.json``.
    """
    return _write_failure(Path(output_dir), _new_record(seed, labels), error, None, config)


run_trial.record_failure = record_failure


def failure_status(error: BaseException) -> str:
    """The record ``status`` of a trial (or any job) that raised ``error``."""
    if isinstance(error, KeyboardInterrupt):
        return "interrupted"
    return "diverged" if isinstance(error, PlantDiverged) else "error"


def _new_record(seed: int, labels: dict | None) -> dict:
    record: dict = {"schema": 1, **(labels or {}), "seed": int(seed), "status": "running"}
    record["versions"] = versions()
    record["git_revision"] = git_revision()
    record.update(machine())
    return record


def _write_failure(
    out: Path, record: dict, err: BaseException, wall_seconds: float | None, config: dict | None
) -> Path:
    record["status"] = failure_status(err)
    record["error"] = one_line(err)
    record["traceback"] = "".join(traceback.format_exception(err, limit=8))
    record["wall_seconds"] = wall_seconds
    record["config"] = config
    return write_json(out / RECORD_NAME, record)


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
    }
