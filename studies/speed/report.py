"""Speed: where a trial's time goes (per-step physics, the planner's overhead over the bare rollout, the
threads), what the planning-model options save, and what a sweep will cost before it is launched."""

from __future__ import annotations

from pathlib import Path

QUESTION = "Where does a trial's time go, and what will a sweep cost before it is launched?"
TITLE = "Speed: where a trial's time goes, and what a sweep will cost"
EXPERIMENTS = [
    "python launch.py job=benchmark task=<task> hydra.run.dir=outputs/benchmarks/quiet/<task>"
    "  # each task, on a quiet machine; then python -m analysis.benchmarks outputs/benchmarks/quiet",
    "python -m analysis.budget experiment=<experiment> --benchmarks outputs/benchmarks/quiet [--measured "
    "SWEEP]",
]
#: Where the tables and the prose below were recorded (the README, before the studies). The
#: ``benchmark.json`` files (outputs/benchmarks/quiet, outputs/benchmarks/loaded) and the sweeps the
#: budget was checked against were not kept.
NOT_KEPT_REVISION = "2bbc6a7"
HERE = Path(__file__).resolve().parent


def report(study) -> str:
    return (
        f"Recorded at commit {NOT_KEPT_REVISION} (README, 2026-11-21), records not kept: the "
        f"`benchmark.json` "
        "files of the quiet and loaded runs and the sweeps the budget was checked against ran into "
        "`outputs/`, which is not in git. The wall times and the two-thread speed-up are only meaningful on "
        "a quiet machine, so they are not re-made here on a shared one. Re-make with: `python launch.py "
        "job=benchmark task=<task> hydra.run.dir=outputs/benchmarks/quiet/<task>` for each of the eight "
        "tasks (with nothing else running), then `python -m analysis.benchmarks "
        "outputs/benchmarks/quiet` (and `--against outputs/benchmarks/loaded` for a loaded run); the budget "
        "check with `python -m analysis.budget experiment=robustness_lite --benchmarks "
        "outputs/benchmarks/quiet --measured outputs/sweeps/robustness_lite`. The section as it was "
        "recorded:\n\n" + (HERE / "not_kept.md").read_text()
    )
