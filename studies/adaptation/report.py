"""Adaptation under mismatch: how far the plant can differ from the planner's model (a misplaced object, a
heavier one) before each method stops completing the synthetic tasks, and what robust planning buys."""

from __future__ import annotations

from pathlib import Path

from analysis import robustness

QUESTION = "How far can the plant differ from the planner's model before each method stops completing a task?"
TITLE = "Adaptation under mismatch"
EXPERIMENTS = [
    "python launch.py experiment=robustness_lite hydra.sweep.dir=studies/adaptation/records/robustness_lite",
    "python launch.py experiment=robustness_mass_lite"
    " hydra.sweep.dir=studies/adaptation/records/robustness_mass_lite",
]
#: The sweeps and the axis each varies.
SWEEPS = {"robustness_lite": "offset", "robustness_mass_lite": "mass"}
#: Where the tables and the prose below were recorded (the README, before the studies); their records
#: (outputs/sweeps/robustness_lite, robustness_mass_lite) were not kept.
NOT_KEPT = {"robustness_lite": "00f3fa9", "robustness_mass_lite": "8051f82"}
HERE = Path(__file__).resolve().parent


def report(study) -> str:
    made = []
    for sweep, axis in SWEEPS.items():
        d = study.dir / "records" / sweep
        if not any(d.rglob("trial.json")) if d.is_dir() else True:
            continue
        df = robustness.load(d)
        image = study.draw(
            f"{sweep}.png",
            lambda path, df=df, axis=axis: robustness.figure(
                robustness.summary(df, axis=axis), path, axis=axis
            ),
            f"success rate and TTF against the object's {axis} error",
        )
        made.append(
            f"### `{sweep}` ({len(df)} trials, from its kept records)\n\n{image}\n\n"
            + robustness.markdown(robustness.summary(df, axis=axis), axis=axis)
        )
    missing = [s for s in SWEEPS if not any((study.dir / "records" / s).rglob("trial.json"))]
    kept = "\n".join(made) + "\n" if made else ""
    lost = ""
    if missing:
        lost = (
            "## As recorded (records not kept)\n\n"
            + "; ".join(f"`{s}`: recorded at commit {NOT_KEPT[s]}" for s in missing)
            + ", records not kept (the sweeps ran into `outputs/`, which is not in git). Re-make with: "
            + "; ".join(f"`{e}`" for e in EXPERIMENTS if any(s in e for s in missing))
            + ", then `python -m analysis.study adaptation` (the report then shows the tables made from "
            "those records). Each sweep costs about 2 CPU-hours at the lite preset. Below, the section as "
            "it was recorded: its tables, its prose and its figures (drawn by `python -m analysis.robustness "
            "DIR [--axis mass]` from those records).\n\n" + (HERE / "not_kept.md").read_text()
        )
    return kept + lost


def glance(study) -> list[dict]:
    return []
