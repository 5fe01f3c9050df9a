"""Budget before you launch: predict an experiment's CPU-hours and wall time from benchmarks.

Composes the experiment's jobs (the cartesian product of its ``hydra.sweeper.params``, as Hydra's basic
sweeper does), and prices each from the ``benchmark.json`` of its task (``job=benchmark``, any preset:
costs are scaled to the job's planner): per planning iteration, the bare rollout's CPU time per sample
and step times the job's samples and horizon steps times the planner's overhead; per physics step, the
plant's; each weighted by the share of the trial in contact (contact state) and out of it (approach
state). A trial of ``T`` seconds costs ``T / max(replan_period, latency)`` planning iterations (the
latency fixed, or priced by the planner's ``latency_model``) and ``T / plant_dt``
plant steps (a planner without rollouts, ``replay``, only the latter). Robust planning multiplies the
rollouts by its ``num_models``.

The wall time is the makespan of the jobs on ``N`` single-threaded slots (longest job first), for the
local launcher's ``n_jobs`` and for each ``--cores`` given.

Command line::

    python -m analysis.budget experiment=fig3_paper_lite --benchmarks DIR [--cores 64 256] [--measured SWEEP]

``DIR`` holds ``benchmark.json`` files (searched recursively), one per task; ``--measured`` compares the
prediction with the records of a finished sweep (their ``wall_seconds`` and the sweep's span).
"""

from __future__ import annotations

import argparse
import heapq
import itertools
import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from hydra.utils import instantiate

REPO = Path(__file__).resolve().parent.parent


@dataclass(frozen=True)
class TaskCost:
    """What one task's trial costs per unit, from its benchmark.

    Attributes:
        duration: a trial's control time (s) at the benchmark's settings (the task's own length).
        contact_fraction: share of the trial inside the contact span.
        sample_step_cpu: (approach, contact) CPU seconds per rollout sample per planning step.
        overhead: (approach, contact) planning iteration / bare rollout, CPU time.
        plant_step_cpu: (approach, contact) CPU seconds per plant step.
    """

    duration: float
    contact_fraction: float
    sample_step_cpu: tuple[float, float]
    overhead: tuple[float, float]
    plant_step_cpu: tuple[float, float]

    @classmethod
    def from_benchmark(cls, result: dict) -> TaskCost:
        rows = {
            r["state"]: r for r in result["rows"] if r["nthread"] == min(x["nthread"] for x in result["rows"])
        }
        per = result["num_samples"] * result["horizon_steps"]
        states = ("approach", "contact")
        return cls(
            duration=float(result["duration"]),
            contact_fraction=float(result["contact_fraction"]),
            sample_step_cpu=tuple(rows[s]["rollout_cpu_seconds"] / per for s in states),
            overhead=tuple(rows[s]["overhead_cpu"] for s in states),
            plant_step_cpu=tuple(1e-6 * rows[s]["plant_step_cpu_us"] for s in states),
        )

    def weighted(self, pair: tuple[float, float]) -> float:
        return (1 - self.contact_fraction) * pair[0] + self.contact_fraction * pair[1]


def newest_benchmarks(directory: str | Path) -> dict[str, dict]:
    """Task name -> the newest ``benchmark.json`` under ``directory`` (searched recursively) that has
    the trial's length and contact share (older benchmarks lack them)."""
    out: dict[str, tuple[float, dict]] = {}
    for path in Path(directory).rglob("benchmark.json"):
        result = json.loads(path.read_text())
        if "duration" not in result:
            continue
        mtime = path.stat().st_mtime
        if result["task"] not in out or out[result["task"]][0] < mtime:
            out[result["task"]] = (mtime, result)
    return {task: result for task, (_, result) in out.items()}


def load_benchmarks(directory: str | Path) -> dict[str, TaskCost]:
    """Task name -> cost, from every ``benchmark.json`` under ``directory`` (the newest per task)."""
    return {task: TaskCost.from_benchmark(r) for task, r in newest_benchmarks(directory).items()}


def job_seconds(cost: TaskCost, cfg) -> float:
    """Predicted CPU seconds of one trial of the composed config ``cfg`` on this task."""
    planner = cfg.planner
    duration = float(cfg.duration) if cfg.get("duration") is not None else cost.duration
    plant_dt = float(cfg.scene.get("plant_timestep", 0.001))
    planner_dt = float(cfg.scene.get("planner_timestep", 0.01))
    plant = duration / plant_dt * cost.weighted(cost.plant_step_cpu)
    if planner._target_.endswith("Replay"):
        return plant
    steps = max(1, round(float(planner.horizon) / planner_dt))
    models = int(planner.robust.num_models) if planner.get("robust") else 1
    per_plan = int(planner.num_samples) * steps * models * cost.weighted(cost.sample_step_cpu)
    per_plan *= cost.weighted(cost.overhead)
    latency = float(planner.get("latency") or 0.0)
    if planner.get("latency_model"):
        model = instantiate(planner.latency_model)
        latency = model.seconds(int(planner.num_samples) * models, steps, plant_dt)
    return plant + duration / max(float(planner.replan_period), latency) * per_plan


def makespan(seconds: list[float], slots: int) -> float:
    """Wall time of jobs on ``slots`` parallel single-threaded workers, longest first."""
    heap = [0.0] * max(1, slots)
    for s in sorted(seconds, reverse=True):
        heapq.heapreplace(heap, heap[0] + s)
    return max(heap)


def compose(overrides: list[str], hydra: bool = False):
    """The config ``launch.py`` would compose from ``overrides`` (with its ``hydra`` node if asked)."""
    if str(REPO) not in sys.path:
        sys.path.insert(0, str(REPO))
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir

    import launch

    launch.register_configs()
    with initialize_config_dir(config_dir=str(REPO / "conf"), version_base="1.3"):
        return hydra_compose(config_name="config", overrides=list(overrides), return_hydra_config=hydra)


def sweep_jobs(overrides: list[str]) -> tuple[list[list[str]], int]:
    """The experiment's jobs (override lists) and its launcher's ``n_jobs`` (1 if none)."""
    cfg = compose(overrides, hydra=True)
    params = cfg.hydra.sweeper.get("params") or {}
    axes = []
    for key, value in params.items():
        text = str(value)
        if text.startswith("range(") and text.endswith(")"):
            values = [str(v) for v in range(*[int(x) for x in text[6:-1].split(",")])]
        else:
            values = [v.strip() for v in text.split(",")]
        axes.append([f"{key}={v}" for v in values])
    jobs = [list(overrides) + list(combo) for combo in itertools.product(*axes)]
    n_jobs = int(cfg.hydra.launcher.get("n_jobs") or 1)
    return jobs, n_jobs


def predict(overrides: list[str], costs: dict[str, TaskCost]) -> tuple[list[tuple[list[str], float]], int]:
    """Per job (overrides, predicted CPU seconds), and the launcher's ``n_jobs``."""
    from hydra.utils import get_class

    jobs, n_jobs = sweep_jobs(overrides)
    out = []
    for job in jobs:
        cfg = compose(job)
        task = get_class(cfg.task._target_).name
        if task not in costs:
            raise ValueError(f"no benchmark of task {task!r}: run python launch.py job=benchmark task=...")
        out.append((job, job_seconds(costs[task], cfg)))
    return out, n_jobs


def measured(sweep: str | Path) -> dict[str, float]:
    """A finished sweep's total trial wall seconds and its span (first record's start to last's end)."""
    records = [json.loads(p.read_text()) for p in Path(sweep).rglob("trial.json")]
    ends = [p.stat().st_mtime for p in Path(sweep).rglob("trial.json")]
    walls = [r.get("wall_seconds", 0.0) + r.get("setup_seconds", 0.0) for r in records]
    starts = [e - w for e, w in zip(ends, walls, strict=True)]
    return {
        "jobs": len(records),
        "cpu_seconds": float(sum(walls)),
        "span_seconds": float(max(ends) - min(starts)),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m analysis.budget", description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "overrides", nargs="+", help="the experiment's overrides, e.g. experiment=ablation_lite"
    )
    parser.add_argument("--benchmarks", required=True, help="directory of benchmark.json files, one per task")
    parser.add_argument("--cores", type=int, nargs="*", default=[], help="cluster core counts to price")
    parser.add_argument("--measured", help="a finished sweep of the experiment to compare with")
    args = parser.parse_args(argv)
    try:
        costs = load_benchmarks(args.benchmarks)
        jobs, n_jobs = predict(args.overrides, costs)
    except (ValueError, OSError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    seconds = [s for _, s in jobs]
    total = float(np.sum(seconds))
    print(f"{' '.join(args.overrides)}: {len(jobs)} jobs, {total / 3600:.2f} CPU-hours predicted")
    local = makespan(seconds, n_jobs) / 60
    print(f"  local ({n_jobs} job{'s' if n_jobs > 1 else ''} at a time): {local:.1f} min")
    for cores in args.cores:
        print(f"  {cores} cores: {makespan(seconds, cores) / 60:.1f} min")
    if args.measured:
        m = measured(args.measured)
        print(
            f"  measured ({m['jobs']} records): {m['cpu_seconds'] / 3600:.2f} CPU-hours of trials, "
            f"sweep span {m['span_seconds'] / 60:.1f} min"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
