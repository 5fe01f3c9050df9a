"""ContactMPC entry point: compose the config, build the scene, run the selected job.

    python launch.py                         # one default trial; prints where its record is
    python launch.py task=doorknob seed=3    # override any config group or value
    python launch.py --cfg job               # print the composed config
    python launch.py job=render_scene task=stapler
    python launch.py -m task=apple,bottle seed=0,1,2   # a multirun sweep

Errors that come from bad input (config, reference files, scenes) are printed as one line naming the
problem, and the process exits with status 1. Ctrl-C leaves the trial's record (status
``interrupted``), prints one line and exits with status 130; so does a SIGTERM (``timeout``, ``kill``, a
cluster's scheduler at its time limit), in the process that runs the trial and in a sweep's own. A
multirun ends with one summary line (:class:`sweep_summary.SweepSummary`, a Hydra callback beside this
file) and a non-zero exit status unless every job finished.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import os
import signal
import sys
import threading
from pathlib import Path
from typing import Any

from contactmpc.gl import default_gl

default_gl()  # before MuJoCo is first imported: egl where libEGL loads, else disable

import hydra  # noqa: E402
from hydra.core.config_store import ConfigStore  # noqa: E402
from hydra.core.hydra_config import HydraConfig  # noqa: E402
from hydra.types import RunMode  # noqa: E402
from hydra.utils import get_method, instantiate  # noqa: E402
from omegaconf import DictConfig, OmegaConf  # noqa: E402

from contactmpc.config import Config, check_config, member_schemas, schema_for, split_inputs  # noqa: E402
from contactmpc.jobs.common import failure_status  # noqa: E402
from contactmpc.records import RECORD_NAME, one_line  # noqa: E402
from contactmpc.runs import RESUME, job_lock, resume_decision  # noqa: E402
from sweep_summary import SWEEP_STATE_ENV  # noqa: E402  (also registers the safe_dirname resolver)

CONF_DIR = Path(__file__).resolve().parent / "conf"

LABELS = (
    "task",
    "hand",
    "cost",
    "sampler",
    "planner",
    "variant",
    "fidelity",
    "wrist",
    "shaping",
    "release",
    "compensation",
    "effort",
    "place",
    "pacing",
    "carry",
    "grip",
    "retarget",
    "rollout",
    "reuse",
    "preset",
    "experiment",
    "perturbation",
    "operating_point",
    "challenge",
    "loop",
)

DEFAULT_VARIANT = ("full", {"planner": "predictive_sampling", "cost": "contact", "sampler": "pca_spline"})
"""The variant label of a record whose ``variant`` is left unset (``null``), and the choices that make it
so: the root defaults compose the paper's full method (``conf/variant/full.yaml`` selects the same). With
other choices the label stays null and the analysis names the variant from them
(``analysis.aggregate.variant_name``)."""

log = logging.getLogger("contactmpc")


def labels_of(choices: dict) -> dict:
    """The record's labels (:data:`LABELS`) from Hydra's config choices; an unset variant named as
    :data:`DEFAULT_VARIANT` says."""
    labels = {g: choices.get(g) for g in LABELS}
    name, makes = DEFAULT_VARIANT
    if labels["variant"] is None and all(choices.get(g) == v for g, v in makes.items()):
        labels["variant"] = name
    return labels


def conf_members(conf_dir: Path = CONF_DIR) -> list[tuple[str, str, str]]:
    """``(group, member, target)`` of every member file ``conf/<group>/<member>.yaml`` whose top level
    has a ``_target_``: the objects the config builds."""
    members = []
    for path in sorted(conf_dir.glob("*/*.yaml")):
        node = OmegaConf.load(path)
        if isinstance(node, DictConfig) and "_target_" in node:
            members.append((path.parent.name, path.stem, node._target_))
    return members


# (group, name, schema) triples stored in Hydra's ConfigStore: the root schema, and one schema per
# member, generated from the signature of what it builds (contactmpc.config.schema). A member's YAML
# names its target and lists its schema, "/<group>_<member>_schema", in its defaults, so a typo in a key
# fails at compose time and every constructor parameter is settable; adding a member needs no other
# registration. The member schemas live at the root of the ConfigStore, not in their group: they are
# no choices of the group (`--help` and tab completion do not list them).
SCHEMAS = (
    (None, "config_schema", Config),
    *member_schemas(conf_members()),
    # a node inside the members of a global group: sampler.release (conf/release/reset.yaml lists it)
    (None, "/release_schedule_schema", schema_for("contactmpc.control.release.ReleaseSchedule")),
)


def register_configs() -> None:
    """Store :data:`SCHEMAS` in Hydra's ConfigStore (idempotent); a name ``/x`` is stored at the root."""
    cs = ConfigStore.instance()
    for group, name, node in SCHEMAS:
        if name.startswith("/"):
            cs.store(name=name[1:], node=node)
        else:
            cs.store(group=group, name=name, node=node)


register_configs()


def build_scene(cfg: DictConfig):
    """Instantiate hand, task and scene from the composed config."""
    demo = cfg.task.get("demonstration")
    if (
        demo is not None
        and "wrist_fit" in demo
        and not str(demo.get("_target_")).endswith(".PaperDemonstration")
    ):
        task = cfg.task.get("name") or str(cfg.task.get("_target_", "?")).rsplit(".", 1)[-1]
        raise ValueError(
            f"retarget=wrist: task {task!r} has no retargeted demonstration to correct "
            f"(its demonstration is {demo.get('_target_')}); use it with a paper task (task=paper_*)"
        )
    hand = instantiate(cfg.hand)
    task = instantiate(cfg.task)
    return instantiate(cfg.scene)(hand=hand, task=task)


def build_job(node: DictConfig) -> functools.partial:
    """The job of a composed config's ``job`` node: its function as a ``functools.partial`` that the call
    site completes with ``make_scene``, ``output_dir``, ``seed``, ``config`` and ``labels``.

    A job that takes a parameter object (:class:`contactmpc.config.Inputs`: the trial and online jobs'
    :class:`~contactmpc.jobs.common.TrialInputs`) gets it built here, from the node's keys of its fields
    (which the YAML holds at the job's level: ``job.failure_gap``, ``job.planner``, ...).
    """
    own, inputs = split_inputs(get_method(node._target_), OmegaConf.to_container(node, resolve=True))
    if inputs is None:
        return instantiate(node)
    name, fields = inputs
    return functools.partial(instantiate(own), **{name: instantiate(fields)})


# --------------------------------------------------------------------------------------------- jobs


def _sweep_state() -> Path | None:
    state = os.environ.get(SWEEP_STATE_ENV)
    return Path(state) if state else None


def _resolved(cfg: DictConfig) -> dict:
    try:
        return OmegaConf.to_container(cfg, resolve=True)
    except Exception:  # an interpolation that fails is the job's error to report; keep what there is
        return OmegaConf.to_container(cfg, resolve=False)


def run_job(cfg: DictConfig, labels: dict) -> dict:
    """Run the job of the composed config in its output directory, under the directory's lock.

    Returns:
        The outcome: ``{"status": ...}``, one of ``ok``, ``diverged``, ``error``, ``interrupted`` (the
        job ran), ``skipped`` (a finished record of the same trial), ``refused`` (a finished record of a
        different trial), ``busy`` (another process holds the directory's lock) or ``not_started``
        (the sweep was interrupted before this job began); ``record`` where the job wrote one.
    """
    output_dir = Path(cfg.output_dir)
    state = _sweep_state()
    if state is not None and (state / "STOP").exists():
        return {"status": "not_started"}
    if cfg.resume not in RESUME or not isinstance(cfg.resume, bool | str):
        print(f"contactmpc: error: resume={cfg.resume}: expected true, false or overwrite", file=sys.stderr)
        return {"status": "error"}
    config = _resolved(cfg)
    with job_lock(output_dir) as locked:
        if not locked:
            print(f"[contactmpc] skipped (in progress in another process): {output_dir}")
            return {"status": "busy"}
        action, line = resume_decision(output_dir, config, cfg.resume)
        if action != "run":
            print(line, file=sys.stderr if action == "refuse" else sys.stdout)
            return {"status": "skipped" if action == "skip" else "refused"}
        return _run(cfg, output_dir, config, labels)


class Terminated(KeyboardInterrupt):
    """A SIGTERM, raised where it arrives: a job ends as on Ctrl-C (status ``interrupted``, its record
    written), with the signal named."""


def _terminated(signum: int, frame: Any) -> None:
    raise Terminated(f"terminated by {signal.Signals(signum).name}")


@contextlib.contextmanager
def sigterm_interrupts():
    """While it is open, a SIGTERM raises :class:`Terminated` (in the main thread of a process, where
    Python runs signal handlers; elsewhere nothing changes)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = signal.signal(signal.SIGTERM, _terminated)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, before)


def _run(cfg: DictConfig, output_dir: Path, config: dict, labels: dict) -> dict:
    with sigterm_interrupts():
        return _run_job(cfg, output_dir, config, labels)


def _run_job(cfg: DictConfig, output_dir: Path, config: dict, labels: dict) -> dict:
    job = None
    try:
        # Nonsense values fail first, before any work (contactmpc.validate); then the job's objects
        # (sampler, cost, planner) are built here, inside the guard: a job that cannot be built, or
        # whose config is refused, still leaves the record its function would have written (its
        # `record_failure`).
        check_config(config)
        job = build_job(cfg.job)
        result = job(
            make_scene=functools.partial(build_scene, cfg),
            output_dir=output_dir,
            seed=cfg.seed,
            config=config,
            labels=labels,
        )
    except (Exception, KeyboardInterrupt) as err:
        if job is None and (record_failure := _record_failure(cfg.job._target_)) is not None:
            record_failure(output_dir, cfg.seed, err, config=config, labels=labels)
        record = output_dir / RECORD_NAME
        outcome: dict[str, Any] = {"status": failure_status(err)}
        if record.exists():
            outcome["record"] = str(record)
        if isinstance(err, KeyboardInterrupt):
            state = _sweep_state()
            if state is not None:  # no new job of this sweep starts
                (state / "STOP").touch()
            why = f" ({err})" if str(err) else ""
            where = f"; record: {record}" if record.exists() else ""
            print(f"contactmpc: interrupted{why}{where}", file=sys.stderr)
        else:
            # One line that names the problem; the trial's record (if it got that far) says the same.
            print(f"contactmpc: error: {one_line(err)}", file=sys.stderr)
        return outcome
    print(f"[contactmpc] {cfg.job._target_.rsplit('.', 1)[-1]}: wrote {result}")
    return {"status": "ok", "record": str(result)}


def _record_failure(target: str) -> Any:
    """The ``record_failure(output_dir, seed, error, config, labels)`` of a job function that writes a
    record (:func:`contactmpc.jobs.trial.record_failure`), or ``None``."""
    try:
        return getattr(get_method(target), "record_failure", None)
    except Exception:  # the target itself cannot be found: that is the error to report
        return None


@hydra.main(version_base="1.3", config_path="conf", config_name="config")
def main(cfg: DictConfig) -> dict:
    hc = HydraConfig.get()
    outcome = run_job(cfg, labels_of(hc.runtime.choices))
    if hc.mode != RunMode.MULTIRUN and outcome["status"] not in ("ok", "skipped"):
        sys.exit(130 if outcome["status"] == "interrupted" else 1)
    return outcome  # a multirun goes on with its other jobs; SweepSummary counts the outcomes


if __name__ == "__main__":
    try:
        with sigterm_interrupts():
            main()
    except KeyboardInterrupt as err:  # outside a job (a job's Ctrl-C is handled in run_job)
        print(f"contactmpc: interrupted{f' ({err})' if str(err) else ''}", file=sys.stderr)
        sys.exit(130)
