"""analysis.operating_point on constructed records: grouping by point, the cheapest point that works."""

from __future__ import annotations

import json

from analysis.operating_point import cheapest, load, main, summary
from analysis.paper_fig3 import fidelities


def _record(directory, name, samples, horizon, interval, latency, seed, completed, fidelity="paper"):
    run = directory / name
    run.mkdir(parents=True)
    config = {
        "planner": {"num_samples": samples, "horizon": horizon, "replan_period": 0.01, "latency": latency},
        "fidelity": fidelities()[fidelity],
        "seed": seed,
    }
    record = {
        "task": "paper_apple", "seed": seed, "status": "ok", "completed": completed, "ttf": 1.0,
        "milestone_lifted": True, "milestone_handed_off": completed, "replan_interval": interval,
        "latency": latency, "object_position_error_mean": 0.03, "final_object_position_error": 0.05,
        "wall_seconds": samples * horizon, "config": config,
    }  # fmt: skip
    (run / "trial.json").write_text(json.dumps(record))


def test_the_cheapest_point_that_completes(tmp_path):
    points = {  # name: (samples, horizon, interval, latency, completions over 3 seeds)
        "paper": (128, 2.5, 0.096, 0.096, (True, True, True)),
        "s32": (32, 2.5, 0.096, 0.096, (True, False, False)),
        "s64": (64, 2.5, 0.096, 0.096, (True, True, True)),
        "h1": (128, 1.0, 0.096, 0.096, (True, True, False)),
    }
    for name, (s, h, i, lat, done) in points.items():
        for seed, ok in enumerate(done):
            _record(tmp_path, f"{name}_{seed}", s, h, i, lat, seed, ok)
    table = summary(load(tmp_path))
    assert list(table["samples"]) == [32, 128, 64, 128]  # cheapest first (rollout steps per second)
    assert table.set_index("samples").loc[64, "completed"] == 3
    best = cheapest(table, need=1.0).iloc[0]
    assert best["cheapest"] == "64 x 2.5 s, every 96 ms (latency 96 ms)" and best["completed"] == "3/3"
    assert "96 ms: 3/3" in best["paper_point"]
    assert cheapest(table, need=2 / 3).iloc[0]["cheapest"].startswith("128 x 1 s")
    out = tmp_path / "out"
    assert main([str(tmp_path), "--out-dir", str(out), "--need", "3/3"]) == 0
    assert "64 x 2.5 s" in (out / "operating_point.md").read_text()
    assert main([str(tmp_path / "missing")]) == 2
