"""What the trial and online jobs share: their inputs (:class:`TrialInputs`), building the trial from them
(:func:`build_trial`), running its closed loop (:func:`run_loop`) and the record's life
(:func:`new_record`, :func:`write_failure`, :func:`record_failure`, :func:`failure_status`)."""

from __future__ import annotations

import traceback
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

import numpy as np

from contactmpc.config import Inputs
from contactmpc.control.cost import TrackingCost
from contactmpc.control.planners.base import Planner
from contactmpc.control.samplers import SplineSpace
from contactmpc.metrics import contact_span
from contactmpc.perturbations import Perturbation
from contactmpc.records import (
    RECORD_NAME,
    SCHEMA_VERSION,
    git_revision,
    host,
    machine,
    one_line,
    versions,
    write_json,
)
from contactmpc.reference.source import get_reference
from contactmpc.scene import Scene
from contactmpc.trial import PlantDiverged, Trial, TrialLog, check_planner_timing
from contactmpc.validate import ConfigError, Ge, Gt, checked


@dataclass(frozen=True)
class TrialInputs(Inputs):
    """The inputs of a closed-loop trial, the same for ``job=trial`` and ``job=online``.

    A job's config holds these fields at its own level (``job.failure_gap``, ``job.sampler``, ...):
    ``launch.build_job`` builds this object from them (:class:`contactmpc.config.Inputs`).

    Attributes:
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
        perturbation: plant-only changes drawn from the seed (:mod:`contactmpc.perturbations`); the
            drawn values go into the record (``perturbation``). ``None``: none.
    """

    sampler: SplineSpace
    cost: TrackingCost
    planner: Planner
    num_control_points: int | None = None
    duration: Annotated[float, Gt(0)] | None = None
    progress: bool = True
    failure_gap: Annotated[float, Ge(0)] = 0.3
    failure_min_expected: Annotated[int, Ge(0)] = 6
    milestone_hold: Annotated[float, Ge(0)] = 0.3
    reference_cache: str | None = "outputs/cache/references"
    perturbation: Perturbation | None = None


TrialInputs.__init__ = checked(TrialInputs.__init__)


def build_trial(
    make_scene: Callable[[], Scene],
    seed: int,
    inputs: TrialInputs,
    progress: bool | None = None,
    window: tuple[float | None, float | None, float | None] = (None, None, None),
) -> Trial:
    """Build the scene, check the planner's timing on it (before a reference is synthesised), get the
    reference and build the :class:`~contactmpc.trial.Trial` of ``inputs``.

    Args:
        progress: the trial's own progress bar; ``None``: ``inputs.progress``.
        window: ``(start_time, start_before_contact, end_after_contact)``: where the trial starts and
            ends (:func:`screen_window`); all ``None``: the whole trial.
    """
    scene = make_scene()
    check_planner_timing(scene, inputs.planner)
    reference = get_reference(scene, inputs.reference_cache)
    start, duration = screen_window(scene, reference, *window, inputs.duration)
    return Trial(
        scene,
        reference,
        inputs.sampler,
        inputs.cost,
        inputs.planner,
        seed,
        inputs.num_control_points,
        duration,
        inputs.progress if progress is None else progress,
        inputs.perturbation,
        start,
    )


def screen_window(
    scene: Scene,
    reference,
    start_time: float | None,
    start_before_contact: float | None,
    end_after_contact: float | None,
    duration: float | None,
) -> tuple[float, float | None]:
    """The control times a trial starts and ends at, ``(start, duration)``: ``start_before_contact``
    and ``end_after_contact`` are counted from the reference's first expected contact (its first frame
    with one, slowed), rounded to the plant's step.

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
    span = contact_span(np.asarray(reference.time) - reference.time[0], reference.contact_active)
    if span is None:
        raise ConfigError("job.start_before_contact / end_after_contact: the reference expects no contact")
    first = span[0] * scene.task.time_scale
    dt = scene.plant_model.opt.timestep
    if start_before_contact is not None:
        start = max(0.0, round((first - start_before_contact) / dt) * dt)
    if end_after_contact is not None:
        duration = round((first + end_after_contact) / dt) * dt
    return start, duration


def run_loop(run: Callable[[], TrialLog], trial: Trial, record: dict) -> TrialLog:
    """Run ``trial``'s closed loop, ``run`` (:meth:`~contactmpc.trial.Trial.run` or
    :meth:`~contactmpc.online.OnlineLoop.run`), and return its log; whatever happens, close the trial's
    planner and put the perturbation it drew in ``record`` (``perturbation``)."""
    try:
        return run()
    finally:
        trial.planner.close()
        if trial.draw is not None:
            record["perturbation"] = trial.draw.record()


def new_record(seed: int, labels: dict | None) -> dict:
    """A job's record as it starts (status ``running``): schema, labels, seed, versions, the git
    revision and the machine (:func:`~contactmpc.records.machine`, :func:`~contactmpc.records.host`)."""
    record: dict = {"schema": SCHEMA_VERSION, **(labels or {}), "seed": int(seed), "status": "running"}
    record["versions"] = versions()
    record["git_revision"] = git_revision()
    record.update(machine())
    record["host"] = host()
    return record


def failure_status(error: BaseException) -> str:
    """The record ``status`` of a trial (or any job) that raised ``error``."""
    if isinstance(error, KeyboardInterrupt):
        return "interrupted"
    return "diverged" if isinstance(error, PlantDiverged) else "error"


def write_failure(
    out: Path, record: dict, err: BaseException, wall_seconds: float | None, config: dict | None
) -> Path:
    """Write ``record`` as the record of a job that raised ``err``: its status
    (:func:`failure_status`), the one-line reason, the traceback, ``wall_seconds`` and the config."""
    record["status"] = failure_status(err)
    record["error"] = one_line(err)
    record["traceback"] = "".join(traceback.format_exception(err, limit=8))
    record["wall_seconds"] = wall_seconds
    record["config"] = config
    return write_json(out / RECORD_NAME, record)


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
    return write_failure(Path(output_dir), new_record(seed, labels), error, None, config)
