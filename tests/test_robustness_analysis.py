"""analysis.robustness: success against the object's offset, per task and method, from records."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from analysis.robustness import bootstrap, load, main, summary, survives


@pytest.fixture()
def sweep(tmp_path: Path) -> Path:
    """apple: full completes up to 2 cm (3 of 3), fails at 3 cm; replay only at 0 cm."""
    job = 0
    for method, limit in (("full", 0.02), ("replay", 0.0)):
        for offset in (0.0, 0.01, 0.02, 0.03):
            for seed in range(3):
                a = np.random.default_rng(seed).uniform(0, 2 * np.pi)
                record = {
                    "task": "apple",
                    "variant": method,
                    "seed": seed,
                    "status": "ok",
                    "completed": offset <= limit,
                    "ttf": 1.0 if offset <= limit else 0.3,
                    "perturbation": {"object_offset": [offset * np.cos(a), offset * np.sin(a), 0.0]},
                }
                (tmp_path / str(job)).mkdir()
                (tmp_path / str(job) / "trial.json").write_text(json.dumps(record))
                job += 1
    return tmp_path


def test_success_rates_and_survival(sweep: Path) -> None:
    table = summary(load(sweep))
    full = table[table["method"] == "full"].set_index("offset")
    assert list(full["success"]) == [1.0, 1.0, 1.0, 0.0]
    assert list(full["trials"]) == [3, 3, 3, 3]
    surv = survives(table).set_index("method")["offset"]
    assert surv["full"] == 0.02 and surv["replay"] == 0.0
    assert list(table["method"].drop_duplicates()) == ["replay", "full"]  # method order


def test_bootstrap_interval() -> None:
    lo, hi = bootstrap(np.array([1.0, 1.0, 0.0, 0.0]), np.random.default_rng(0))
    assert 0.0 <= lo < 0.5 < hi <= 1.0
    assert bootstrap(np.ones(3), np.random.default_rng(0)) == (1.0, 1.0)


def test_cli(sweep: Path, tmp_path: Path, capsys) -> None:
    assert main([str(sweep), "--out-dir", str(tmp_path / "out")]) == 0
    assert (tmp_path / "out" / "robustness.png").stat().st_size > 5000
    assert "| apple | full | 3 cm | 0.00" in (tmp_path / "out" / "robustness.md").read_text()
    assert main([str(tmp_path / "empty"), "--out-dir", str(tmp_path / "x")]) == 2


def test_mass_axis(tmp_path: Path) -> None:
    """The mass error (drawn factor - 1) as the axis: robust survives +60 %, full only +30 %."""
    job = 0
    for method, limit in (("full", 0.3), ("robust", 0.6)):
        for error in (0.0, 0.3, 0.6, 0.9):
            for seed in range(3):
                record = {
                    "task": "bottle",
                    "variant": method,
                    "seed": seed,
                    "status": "ok",
                    "completed": error <= limit,
                    "ttf": 1.0,
                    "perturbation": {"object_offset": [0.0, 0.0, 0.0], "mass_scale": 1.0 + error},
                    "milestone_lifted": error <= limit + 0.3,
                }
                (tmp_path / str(job)).mkdir()
                (tmp_path / str(job) / "trial.json").write_text(json.dumps(record))
                job += 1
    surv = survives(summary(load(tmp_path), axis="mass"), axis="mass").set_index("method")["mass"]
    assert surv["full"] == pytest.approx(0.3) and surv["robust"] == pytest.approx(0.6)
    assert main([str(tmp_path), "--out-dir", str(tmp_path / "out"), "--axis", "mass"]) == 0
    text = (tmp_path / "out" / "robustness.md").read_text()
    assert "| bottle | robust | +60 % |" in text and "mass error" in text
    assert "| bottle | full | +60 % | 0.00 (0.00–0.00) | 1.00 (1.00–1.00) | lifted 3/3 |" in text
    assert "| bottle | full | +90 % | 0.00 (0.00–0.00) | 1.00 (1.00–1.00) | lifted 0/3 |" in text
