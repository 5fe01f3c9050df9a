"""End to end: the smoke sweep through the joblib launcher, then the analysis of its records."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.conftest import REPO_ROOT


@pytest.mark.slow
def test_smoke_experiment_runs_and_is_analysed(tmp_path):
    sweep = tmp_path / "smoke"
    # the synthesised references from the default cache (outputs/cache/references), as a user's run has
    r = subprocess.run(
        [
            sys.executable,
            "launch.py",
            "experiment=smoke",
            f"hydra.sweep.dir={sweep}",
        ],
        cwd=REPO_ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    records = [json.loads(p.read_text()) for p in sweep.rglob("trial.json")]
    assert len(records) == 4
    assert {(rec["task"], rec["variant"]) for rec in records} == {
        (t, v) for t in ("doorknob", "apple") for v in ("full", "no_contact")
    }
    assert all(rec["status"] == "ok" for rec in records), [rec.get("error") for rec in records]
    assert "joblib" in (sweep / "multirun.yaml").read_text()

    out = tmp_path / "analysis"
    a = subprocess.run(
        [sys.executable, "-m", "analysis", str(sweep), "--out-dir", str(out)],
        cwd=REPO_ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert a.returncode == 0, a.stderr
    assert (out / "fig3.png").stat().st_size > 10_000
    table = (out / "results.csv").read_text().splitlines()
    assert len(table) == 5  # header + 4 trials
    assert "doorknob" in (out / "results.md").read_text()
