"""analysis.budget: an experiment's jobs priced from benchmarks, and the makespan of a schedule."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from analysis.budget import TaskCost, job_seconds, load_benchmarks, main, makespan, predict, sweep_jobs


def _benchmark(task: str, duration: float) -> dict:
    rows = [
        {
            "state": s,
            "nthread": n,
            "rollout_cpu_seconds": 0.32 * f,
            "overhead_cpu": 1.05,
            "plant_step_cpu_us": 30.0 * f,
        }
        for s, f in (("approach", 1.0), ("contact", 2.0))
        for n in (1, 2)
    ]
    return {
        "task": task,
        "num_samples": 32,
        "horizon_steps": 100,
        "duration": duration,
        "contact_fraction": 0.5,
        "rows": rows,
    }


@pytest.fixture()
def benchmarks(tmp_path: Path) -> Path:
    for task, duration in (("doorknob", 20.0), ("apple", 16.0)):
        (tmp_path / task).mkdir()
        (tmp_path / task / "benchmark.json").write_text(json.dumps(_benchmark(task, duration)))
    return tmp_path


def test_cost_per_sample_step_and_weighting(benchmarks: Path) -> None:
    costs = load_benchmarks(benchmarks)
    apple = costs["apple"]
    assert apple.sample_step_cpu == pytest.approx((1e-4, 2e-4))
    assert apple.weighted(apple.sample_step_cpu) == pytest.approx(1.5e-4)


def test_experiment_jobs_are_priced(benchmarks: Path) -> None:
    jobs, n_jobs = sweep_jobs(["experiment=smoke"])
    assert n_jobs == 2 and len(jobs) == 4
    priced, _ = predict(["experiment=smoke"], load_benchmarks(benchmarks))
    # smoke: 0.3 s, 8 samples x 20 steps, replanning every 50 ms, 1 ms plant
    plans, per_plan = 0.3 / 0.05, 8 * 20 * 1.5e-4 * 1.05
    plant = 0.3 / 0.001 * 45e-6
    for _, seconds in priced:
        assert seconds == pytest.approx(plant + plans * per_plan)


def test_replay_costs_only_the_plant(benchmarks: Path) -> None:
    from analysis.budget import compose

    cost: TaskCost = load_benchmarks(benchmarks)["apple"]
    cfg = compose(["task=apple", "planner=replay", "duration=2"])
    assert job_seconds(cost, cfg) == pytest.approx(2 / 0.001 * 45e-6)


def test_makespan_longest_first() -> None:
    assert makespan([3, 3, 2, 2, 2], 2) == 7
    assert makespan([5, 1, 1], 4) == 5


def test_cli(benchmarks: Path, capsys) -> None:
    assert main(["experiment=smoke", "--benchmarks", str(benchmarks), "--cores", "64"]) == 0
    out = capsys.readouterr().out
    assert "4 jobs" in out and "64 cores" in out
    assert main(["experiment=ablation_lite", "--benchmarks", str(benchmarks / "apple")]) == 2


def test_a_latency_longer_than_the_period_prices_fewer_plans(benchmarks: Path) -> None:
    """preset=paper plans once per modelled compute time (96 ms), not every 10 ms (preset=paper_10ms)."""
    from analysis.budget import compose

    cost: TaskCost = load_benchmarks(benchmarks)["apple"]
    paper, sync = (
        job_seconds(cost, compose(["task=apple", f"preset={p}", "duration=2"]))
        for p in ("paper", "paper_10ms")
    )
    plant = 2 / 0.001 * 45e-6
    assert (sync - plant) / (paper - plant) == pytest.approx(9.6)
    fixed = job_seconds(
        cost, compose(["task=apple", "preset=paper_10ms", "planner.latency=0.05", "duration=2"])
    )
    assert (sync - plant) / (fixed - plant) == pytest.approx(5.0)
