"""What one plan of the method costs with each planning model (the method study's "What a plan costs"):
``job=benchmark`` of the method on each paper task with each member of :data:`ROLLOUTS`, one thread, at the
states of a replay of the reference (``job.visit=replay``: the approach, inside the acquire window where
``effort=acquire`` draws 128 samples a plan, and the middle of the contact span, after it, 32).

Writes ``figures/plan_benchmark.csv`` (one row per task, planning model and state: the CPU seconds of one
planning iteration, the samples it draws and the steps each rollout runs), which the report reads.
Run it on a quiet machine (nothing else running): it times CPU.

    CONTACTMPC_PAPER_DATA=... python studies/method/plan_benchmark.py
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from release_replay import write_rows  # this folder's script

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
CSV = HERE / "figures" / "plan_benchmark.csv"
TASKS = ("paper_doorknob", "paper_apple", "paper_bottle", "paper_stapler")
ROLLOUTS = ("paper", "fine", "fine_budget", "fine_after_grasp", "fine_from_contact")


def benchmark(task: str, rollout: str, out: Path) -> dict:
    """The benchmark's ``benchmark.json`` of the task's default method with ``rollout``."""
    command = [sys.executable, "launch.py", "job=benchmark", f"task={task}", f"rollout={rollout}",
               "job.threads=[1]", "job.visit=replay", "job.planner_options={}",
               f"hydra.run.dir={out}"]  # fmt: skip
    subprocess.run(command, cwd=REPO, check=True, stdout=subprocess.DEVNULL)
    return json.loads((out / "benchmark.json").read_text())


def main() -> int:
    if not os.environ.get("CONTACTMPC_PAPER_DATA"):
        print("plan_benchmark: error: set CONTACTMPC_PAPER_DATA to the authors' mjpc/tasks", file=sys.stderr)
        return 2
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for task in TASKS:
            for rollout in ROLLOUTS:
                result = benchmark(task, rollout, Path(tmp) / f"{task}_{rollout}")
                for row in result["rows"]:
                    rows.append({"task": task, "rollout": rollout, "state": row["state"],
                                 "planning_timestep": row["planning_timestep"],
                                 "horizon_steps": row["horizon_steps"],
                                 "plan_samples": row["plan_samples"],
                                 "plan_cpu_seconds": row["plan_cpu_seconds"],
                                 "rollout_cpu_seconds": row["rollout_cpu_seconds"],
                                 "num_samples": result["num_samples"]})  # fmt: skip
                    print(
                        f"{task} rollout={rollout} {row['state']}: a plan {row['plan_cpu_seconds']:.3f} CPU-s"
                    )
    write_rows(rows, CSV)
    print(f"wrote {CSV}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
