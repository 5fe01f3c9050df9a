"""The plan-cost study's tables from ``job=profile`` runs (issue 32, items 1-3).

    python studies/plan_cost/profile_table.py outputs/plan_cost/profile \
        --csv studies/plan_cost/records/profile_replay.csv --runs studies/plan_cost/records/runs_replay.csv

Reads every ``profile.json`` under the given directories and prints, in markdown: the per sample-step cost
by run (task, variant, preset) x phase x part; the calibration (median and range of the plan's per
sample-step cost over the visited states, and the latency it implies for preset=paper, 128 x 250 on 7
threads); and, where a run timed planning-model cuts beside the scene's (``job.alternatives``), the
speed-up per run and phase (the mean cost over the states, old / new) with the median of the per-state
ratios. The machine's load during each run is printed with it. ``--csv`` also writes every state's row,
``--runs`` one row per run (how it visited, the machine and its load, the visited trial's outcome): the
records ``studies/plan_cost/report.py`` makes the study's report from.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path

import numpy as np

PARTS = ("collision", "constraint", "sensors", "kinematics", "physics_rest", "cost", "planner_rest")


def load(dirs: list[str]) -> list[dict]:
    runs = []
    for d in dirs:
        for path in sorted(Path(d).rglob("profile.json")):
            run = json.loads(path.read_text())
            run["path"] = str(path)
            runs.append(run)
    return runs


def label(run: dict) -> str:
    labels = run.get("labels") or {}
    return " ".join(str(labels.get(k) or "-") for k in ("task", "variant", "preset"))


def run_row(run: dict) -> dict:
    """One run's row for ``--runs``: its label, how it visited the trial, the machine and its load (1-min
    load average before and after), and the visited closed-loop trial's outcome where it ran one."""
    machine = run.get("machine") or {}
    row = {
        "run": label(run),
        "visit": run["visit"],
        "every": run["every"],
        "repeats": run.get("repeats"),
        "seed": run.get("seed"),
        "states": len(run["rows"]),
        "alternatives": " ".join(run.get("alternatives", {})),
        "cpu": machine.get("cpu"),
        "logical_cpus": machine.get("logical_cpus"),
        "load_before": run["load_before"][0],
        "load_after": run["load_after"][0],
        "seconds": run.get("seconds"),
    }
    trial = run.get("trial") or {}
    for k in ("completed", "ttf", "finished_cleanly", "num_plans", "plan_us_per_sample_step"):
        row[f"trial_{k}"] = trial.get(k)
    return row


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dirs", nargs="+", help="directories holding profile.json files")
    parser.add_argument("--csv", help="write every visited state's row here")
    parser.add_argument("--runs", help="write one row per run here (visit, machine, load, visited trial)")
    args = parser.parse_args(argv)
    runs = load(args.dirs)
    if not runs:
        print(f"error: no profile.json under {', '.join(args.dirs)}", file=sys.stderr)
        return 1
    print("Per sample-step cost (us of one thread's CPU time), mean over the visited states of each phase:\n")
    cols = ["run", "phase", "states", "plan", "rollout", *PARTS, "ncon", "nefc"]
    print("| " + " | ".join(cols) + " |\n|" + "---|" * len(cols))
    for run in runs:
        for phase, s in run["summary"].items():
            cells = [label(run), phase, s["states"], s["plan_us"], s["rollout_us"], *(s[p] for p in PARTS)]
            cells += [s["ncon"], s["nefc"]]
            print("| " + " | ".join(c if isinstance(c, str) else f"{c:.1f}" for c in cells) + " |")
    print("\nCalibration: per sample-step cost over the states; preset=paper latency (128 x 250 / 7):\n")
    print("| run | states | visit | median us | range us | mean us | latency ms | range ms | load |")
    print("|---|---|---|---|---|---|---|---|---|")
    for run in runs:
        us = np.array([r["plan_us"] for r in run["rows"]])
        if "exact" in run.get("alternatives", {}):  # calibrate on the exact planning model
            us = np.array([r["plan_exact_us"] for r in run["rows"]])
        ms = us * 128 * 250 / 7 / 1e3
        print(
            f"| {label(run)} | {len(us)} | {run['visit']} every {run['every']} s | {np.median(us):.1f} | "
            f"{us.min():.1f}-{us.max():.1f} | {us.mean():.1f} | {np.median(ms):.0f} | "
            f"{ms.min():.0f}-{ms.max():.0f} | {run['load_before'][0]:.1f} / {run['load_after'][0]:.1f} |"
        )
    trials = [run for run in runs if run.get("trial")]
    if trials:
        print(
            "\nThe visited closed-loop trials (the scene's planning model; wall time of the trial's plans):\n"
        )
        print("| run | fast | seed | completed | TTF | finished cleanly | plans | wall us per sample-step |")
        print("|---|---|---|---|---|---|---|---|")
        for run in trials:
            t, fast = run["trial"], "exact" in run.get("alternatives", {})
            ttf = "-" if t["ttf"] is None else f"{t['ttf']:.2f}"
            print(
                f"| {label(run)} | {fast} | {run.get('seed', '-')} | {t['completed']} | {ttf} | "
                f"{t['finished_cleanly']} | {t['num_plans']} | {t['plan_us_per_sample_step']:.1f} |"
            )
    alts = [(run, a) for run in runs for a in run.get("alternatives", {})]
    if alts:
        print("\nPlanning-model cuts timed beside the scene's (interleaved, same states), per sample-step:\n")
        print("| run | old | new | phase | old us | new us | speed-up (means) | median per-state speed-up |")
        print("|---|---|---|---|---|---|---|---|")
        for run, a in alts:
            # the scene's model is the old one, unless the alternative is "exact" (a run with
            # scene.planning_cuts timing the exact planning model beside its cut one)
            names = ("exact", "fast") if a == "exact" else ("scene", a)
            for phase in ("before", "contact", "after", "all"):
                sel = [r for r in run["rows"] if phase in ("all", r["phase"])]
                if not sel:
                    continue
                scene = np.array([r["plan_us"] for r in sel])
                alt = np.array([r[f"plan_{a}_us"] for r in sel])
                old, new = (alt, scene) if a == "exact" else (scene, alt)
                cells = f"{old.mean():.1f} | {new.mean():.1f} | {old.mean() / new.mean():.2f}x"
                ratio = np.median(old / new)
                print(f"| {label(run)} | {names[0]} | {names[1]} | {phase} | {cells} | {ratio:.2f}x |")
    if args.csv:
        rows = [{"run": label(run), **r} for run in runs for r in run["rows"]]
        keys = list(dict.fromkeys(k for r in rows for k in r))
        Path(args.csv).parent.mkdir(parents=True, exist_ok=True)
        with open(args.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=keys)
            w.writeheader()
            w.writerows(rows)
        print(f"\nwrote {args.csv}")
    if args.runs:
        Path(args.runs).parent.mkdir(parents=True, exist_ok=True)
        rows = [run_row(run) for run in runs]
        with open(args.runs, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        print(f"wrote {args.runs}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
