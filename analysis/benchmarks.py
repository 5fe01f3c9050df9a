"""The per-task benchmark table, and whether two benchmark runs (a quiet and a loaded machine) agree.

Reads the ``benchmark.json`` files that ``job=benchmark`` writes (one per task, searched recursively;
the newest per task) and prints, per task and state (approach, contact): ``ncon``, ``nefc``, CPU per
step of the plant and of the planning model, the bare rollout's CPU time per planning iteration (one
thread), the planner's overhead over it (CPU time), the speed-up of the planning iteration from one to
two threads (wall time), what the default planning-model options save per rollout step against
MuJoCo's (``mujoco_ccd`` priced) and what ``cone: pyramidal`` would save and cost; then per task the
real-time factor of a trial on one thread at the benchmark's planner settings (simulated seconds per CPU
second, from the same per-step costs as :mod:`analysis.budget`), at its own planner settings and,
priced from the same costs, at the paper's as the authors ran it (``preset=paper``: 128 samples x 250
steps, a plan every 96 ms, their modelled compute time on 7 threads) and at the synchronous 10 ms reading
(``preset=paper_10ms``), on one thread and on two.

With ``--against DIR`` it compares the ratios (overhead, CPU time; the planning model's step cost over
the plant's; the option prices) of the two runs state by state and prints the largest relative
difference: CPU-time ratios should not depend on what else the machine is doing.

Command line::

    python -m analysis.benchmarks DIR [--against DIR2]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from analysis.aggregate import TASK_ORDER, ordered
from analysis.budget import TaskCost, newest_benchmarks


def load(directory: str | Path) -> dict[str, dict]:
    """Task name -> its newest ``benchmark.json`` under ``directory`` (see ``newest_benchmarks``).

    Raises:
        ValueError: there is none.
    """
    found = newest_benchmarks(directory)
    if not found:
        raise ValueError(f"no benchmark.json under {directory}")
    return found


def _rows(result: dict, nthread: int) -> dict[str, dict]:
    return {r["state"]: r for r in result["rows"] if r["nthread"] == nthread}


def _priced(result: dict, state: str) -> dict[str, dict]:
    """The option sets priced at ``state`` (name -> price), empty for a benchmark without them."""
    return (result.get("planner_options") or {}).get("states", {}).get(state, {})


def _option(result: dict, state: str, name: str) -> dict | None:
    return _priced(result, state).get(name)


#: The paper's planner as the authors ran it (preset=paper): samples, horizon steps, replan interval (s):
#: continuous replanning, one plan per modelled compute time of 7 threads (96 ms).
PAPER_PLANNER = (128, 250, 0.096)
#: The synchronous reading (preset=paper_10ms): a plan every 10 ms.
PAPER_10MS = (128, 250, 0.01)


def real_time_factor(result: dict, nthread: int = 1, planner: tuple[int, int, float] | None = None) -> float:
    """Simulated seconds per second of a trial: on one thread from the CPU times, on ``nthread`` with
    the planning iteration divided by its measured speed-up. ``planner`` (samples, horizon steps,
    replan period) prices other planner settings from the same per-sample-step costs; default: the
    benchmark's own."""
    cost = TaskCost.from_benchmark(result)
    samples, steps, replan = planner or (
        result["num_samples"],
        result["horizon_steps"],
        result["replan_period"],
    )
    per_second = cost.weighted(cost.plant_step_cpu) / result["plant_timestep"]
    plan = samples * steps * cost.weighted(cost.sample_step_cpu) * cost.weighted(cost.overhead) / replan
    if nthread > 1:
        rows = _rows(result, nthread)
        plan /= cost.weighted(tuple(rows[s]["speedup"] for s in ("approach", "contact")))
    return 1.0 / (per_second + plan)


def ratios(result: dict) -> dict[tuple[str, str], float]:
    """The CPU-time ratios of a benchmark, by (state, name): the planner's overhead, the planning
    model's step over the plant's, and each priced option set's rollout step over the scene's."""
    out = {}
    for state, r in _rows(result, 1).items():
        out[(state, "overhead")] = r["overhead_cpu"]
        out[(state, "model/plant step")] = r["planning_model_step_cpu_us"] / r["plant_step_cpu_us"]
        priced = _priced(result, state)
        for name, p in priced.items():
            if name != "scene":
                out[(state, f"{name}/scene")] = p["step_cpu_us"] / priced["scene"]["step_cpu_us"]
    return out


def table(results: dict[str, dict]) -> str:
    """The per-task markdown table (see the module docstring)."""
    lines = [
        "| task | state | ncon | nefc | plant µs/step | planning model µs/step | rollout s (1 thr) "
        "| overhead | speed-up 2 thr | free saving | pyramidal: saving, gap |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for task in ordered(list(results), TASK_ORDER):
        result = results[task]
        one, two = _rows(result, 1), _rows(result, 2)
        for state, r in one.items():
            scene, ccd = _option(result, state, "scene"), _option(result, state, "mujoco_ccd")
            pyr = _option(result, state, "pyramidal")
            free = f"{100 * (1 - scene['step_cpu_us'] / ccd['step_cpu_us']):.1f} %" if scene and ccd else "–"
            pyramidal = (
                f"{100 * pyr['saving']:.0f} %, {pyr['object_gap_mm']:.2f} mm "
                f"(vs {scene['object_gap_mm']:.2f})"
                if pyr and scene
                else "–"
            )
            speedup = f"{two[state]['speedup']:.2f}" if state in two else "–"
            lines.append(
                f"| {task} | {state} | {r['ncon']} | {r['nefc']} | {r['plant_step_cpu_us']:.1f} "
                f"| {r['planning_model_step_cpu_us']:.1f} | {r['rollout_cpu_seconds']:.3f} "
                f"| {r['overhead_cpu']:.3f} | {speedup} | {free} | {pyramidal} |"
            )
    lines += [
        "",
        "| task | samples x steps, replan | trial length | real time, 1 thread | 2 threads "
        "| paper's planner (96 ms), 1 thread | 2 threads | paper_10ms, 1 thread | 2 threads |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for task in ordered(list(results), TASK_ORDER):
        r = results[task]
        factors = [real_time_factor(r, n, p) for p in (None, PAPER_PLANNER, PAPER_10MS) for n in (1, 2)]
        cells = " | ".join(f"1/{1 / f:.0f}" if f < 0.1 else f"{f:.2f}x" for f in factors)
        lines.append(
            f"| {task} | {r['num_samples']} x {r['horizon_steps']}, {1e3 * r['replan_period']:.0f} ms "
            f"| {r['duration']:.1f} s | {cells} |"
        )
    return "\n".join(lines)


def compare(quiet: dict[str, dict], loaded: dict[str, dict]) -> tuple[str, float]:
    """Markdown of each ratio in both runs and their relative difference; the largest difference."""
    lines = ["| task | state | ratio | quiet | loaded | difference |", "|---|---|---|---|---|---|"]
    worst = 0.0
    for task in ordered([t for t in quiet if t in loaded], TASK_ORDER):
        a, b = ratios(quiet[task]), ratios(loaded[task])
        for key in a:
            if key not in b:
                continue
            diff = b[key] / a[key] - 1
            worst = max(worst, abs(diff))
            lines.append(
                f"| {task} | {key[0]} | {key[1]} | {a[key]:.3f} | {b[key]:.3f} | {100 * diff:+.1f} % |"
            )
    return "\n".join(lines), worst


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m analysis.benchmarks", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("directory", help="benchmark.json files, one per task (searched recursively)")
    parser.add_argument("--against", help="a second run of the same benchmarks (e.g. on a loaded machine)")
    args = parser.parse_args(argv)
    try:
        results = load(args.directory)
        print(table(results))
        if args.against:
            text, worst = compare(results, load(args.against))
            print()
            print(text)
            print(f"\nlargest difference of a CPU-time ratio: {100 * worst:.1f} %")
    except (ValueError, OSError, KeyError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
