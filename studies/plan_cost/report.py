"""What a plan costs (issue 32): where a plan's time goes over a trial's states, by phase and by part; which
cuts of the planning model save time and what they cost in agreement with the plant; the latency of
``preset=paper`` calibrated from a whole trial's states instead of one."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
from omegaconf import OmegaConf

from analysis import operating_point as op
from analysis.online import by_slowdown
from analysis.online import slowdown as online_slowdown
from analysis.prose import of, seeds
from analysis.summarize import Fmt
from analysis.summarize import markdown as _markdown

QUESTION = (
    "Where does a plan's time go over a whole trial, which planning-model cuts are free, and what latency "
    "does a calibration over a trial's states give preset=paper?"
)
TITLE = "What a plan costs: the profile, the cuts, the calibrated latency"
_PROFILE = (
    "python launch.py job=profile task={task} variant={variant} preset=paper_32samples seed=0 {visit} "
    "job.repeats=2 scene.planning_cuts='{{hand_pairs: across_fingers}}' '+job.alternatives.exact={{}}' "
    "'+job.alternatives.none={{hand_pairs: none}}' hydra.run.dir=outputs/plan_cost/{out}/{task}_{variant}"
)
_REPLAY = [("paper_apple", "full"), ("paper_bottle", "full"), ("paper_doorknob", "full"),
           ("paper_stapler", "full"), ("paper_stapler", "wrist_clearance")]  # fmt: skip
_PAIR = [("paper_apple", "full"), ("paper_stapler", "full")]
#: The calibration on a quiet machine: the exact planning model (no cuts, no alternatives), one repeat.
_QUIET = (
    "python launch.py job=profile task={task} variant={variant} preset=paper_32samples seed=0 "
    "job.visit=replay job.every=5 job.repeats=1 hydra.run.dir=outputs/plan_cost/{out}/{task}_{variant}"
)
_LOOP = [("paper_apple", "full", 20), ("paper_bottle", "full", 14), ("paper_stapler", "wrist_clearance", 20)]
#: The method (the paper tasks' default) profiled with its link distances read to shaping=clearance's 5 cm,
#: beside the same planning model reading them to the clearance term's 1 cm margin and without sensors.
_METHOD = (
    "python launch.py job=profile task={task} seed=0 job.visit=replay job.every=2.5 job.repeats=1 "
    "scene.link_distance_cutoff=0.05 '+job.alternatives.near={{distance_cutoff: 0.01}}' "
    "'+job.alternatives.no_sensors={{options: {{disableflags: 8192}}}}' "
    "hydra.run.dir=outputs/plan_cost/profile_near/{task}"
)
#: The method as it runs (its distances to 1 cm, planner.lazy_distances), beside it without sensors.
_LAZY = (
    "python launch.py job=profile task={task} seed=0 job.visit=replay job.every=2.5 job.repeats=1 "
    "'+job.alternatives.no_sensors={{options: {{disableflags: 8192}}}}' "
    "hydra.run.dir=outputs/plan_cost/profile_lazy/{task}"
)
_METHOD_PAIRS = [("paper_stapler", "paper_apple"), ("paper_bottle", "paper_doorknob")]
EXPERIMENTS = [
    *(
        _PROFILE.format(task=t, variant=v, visit="job.visit=replay job.every=5", out="profile")
        for t, v in _REPLAY
    ),
    *(
        _PROFILE.format(
            task=t, variant=v, visit=f"job.visit=planner job.every=2.5 duration={d}", out="profile_loop"
        )
        for t, v, d in _LOOP
    ),
    *(
        _QUIET.format(task=t, variant=v, out="profile_quiet") + "  # one at a time, nothing else running"
        for t, v in _REPLAY
    ),
    " & ".join(_QUIET.format(task=t, variant=v, out="profile_pair") for t, v in _PAIR)
    + " & wait  # two at once, nothing else running",
    "python studies/plan_cost/profile_table.py outputs/plan_cost/profile "
    "--csv studies/plan_cost/records/profile_replay.csv --runs studies/plan_cost/records/runs_replay.csv",
    *(
        f"python studies/plan_cost/profile_table.py outputs/plan_cost/profile_{k} "
        f"--csv studies/plan_cost/records/profile_{k}.csv --runs studies/plan_cost/records/runs_{k}.csv"
        for k in ("quiet", "pair")
    ),
    "python studies/plan_cost/profile_table.py outputs/plan_cost/profile_loop "
    "--csv studies/plan_cost/records/profile_loop.csv --runs studies/plan_cost/records/runs_loop.csv",
    *(
        " & ".join(_METHOD.format(task=t) for t in pair) + " & wait  # two at once, nothing else running"
        for pair in _METHOD_PAIRS
    ),
    "python studies/plan_cost/profile_table.py outputs/plan_cost/profile_near "
    "--csv studies/plan_cost/records/profile_method.csv --runs studies/plan_cost/records/runs_method.csv",
    *(
        " & ".join(_LAZY.format(task=t) for t in pair) + " & wait  # two at once, nothing else running"
        for pair in _METHOD_PAIRS
    ),
    "python studies/plan_cost/profile_table.py outputs/plan_cost/profile_lazy "
    "--csv studies/plan_cost/records/profile_lazy.csv --runs studies/plan_cost/records/runs_lazy.csv",
    "bash studies/plan_cost/run_online.sh map  # the map: records/map/<run>/trial.json",
    "python -m pytest -q -s tests/test_agreement.py -k across_fingers  # the gaps it prints per contact state"
    " -> records/agreement.csv; its none column: the same measure with hand_pairs=none for the cut",
]

HERE = Path(__file__).resolve().parent
PARTS = ("collision", "constraint", "sensors", "kinematics", "physics_rest", "cost", "planner_rest")
PHASES = ("before", "contact", "after", "all")
#: The cut the scene ran with (``scene.planning_cuts``) and the alternatives timed beside it.
FAST, EXACT, NONE = "across_fingers", "exact", "none"
#: The goal of issue 32, item 2: the per sample-step cost over a trial this many times lower.
GOAL = 1.5


def _latency_model() -> tuple[int, int, int, float]:
    """``preset=paper``'s latency model: samples, horizon steps, threads and the modelled per sample-step
    cost (s), from ``conf/preset/paper.yaml`` and the scene's planning timestep (``Scene``'s default)."""
    import inspect

    from contactmpc.scene import Scene

    preset = OmegaConf.load(HERE.parent.parent / "conf" / "preset" / "paper.yaml").planner
    dt = inspect.signature(Scene.__init__).parameters["planner_timestep"].default
    model = preset.latency_model
    return (
        int(preset.num_samples),
        round(preset.horizon / dt),
        int(model.threads),
        float(model.sample_step_seconds),
    )


def _load(study) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """The study's records: every visited state's row (with ``visit``), one row per run, the agreement."""
    rec = study.dir / "records"
    rows = pd.concat(
        [
            pd.read_csv(rec / f"profile_{v}.csv").assign(visit=k)
            for v, k in (("replay", "replay"), ("loop", "planner"))
        ]
    )
    runs = pd.concat([pd.read_csv(rec / f"runs_{v}.csv") for v in ("replay", "loop")])
    for df in (rows, runs):
        df["label"] = df["run"].str.rsplit(" ", n=1).str[0]
    return rows, runs, pd.read_csv(rec / "agreement.csv")


def markdown(df: pd.DataFrame) -> str:
    return _markdown(df).rstrip("\n")


def _f(x: float, d: int = 1) -> str:
    return f"{x:.{d}f}"


def _na(x: float, d: int = 1) -> str:
    """``x`` to ``d`` places, ``—`` where it is missing."""
    return "—" if pd.isna(x) else _f(x, d)


def _range(values, d: int = 1, unit: str = "") -> str:
    v = np.asarray(list(values), dtype=float)
    return (
        f"{v.min():.{d}f}{unit}" if np.isclose(v.min(), v.max()) else f"{v.min():.{d}f}-{v.max():.{d}f}{unit}"
    )


def _phases(g: pd.DataFrame):
    """(phase, its rows) for each phase present and ``all``."""
    for p in PHASES:
        sel = g if p == "all" else g[g["phase"] == p]
        if len(sel):
            yield p, sel


def _table(columns: dict) -> str:
    """``columns`` (header -> values) as a pipe table."""
    return markdown(pd.DataFrame(columns))


def profile_table(rows: pd.DataFrame, visit: str) -> str:
    out = []
    for label, g in rows[rows["visit"] == visit].groupby("label", sort=False):
        for p, sel in _phases(g):
            m = sel.mean(numeric_only=True)
            out.append(
                {"run": label, "phase": p, "states": len(sel), "plan": _f(m["plan_us"]),
                 "rollout": _f(m["rollout_us"]), **{k: _f(m[k]) for k in PARTS},
                 "ncon": _f(m["ncon"]), "nefc": _f(m["nefc"])}
            )  # fmt: skip
    return markdown(pd.DataFrame(out))


def _exact_us(g: pd.DataFrame) -> np.ndarray:
    """The exact planning model's per sample-step cost at each state: its column where the run timed it
    beside a cut scene (``job.alternatives.exact``), else the plan's (a run without cuts plans on it)."""
    col = f"plan_{EXACT}_us"
    return (g[col] if col in g and g[col].notna().all() else g["plan_us"]).to_numpy()


def calibration(rows: pd.DataFrame, runs: pd.DataFrame) -> pd.DataFrame:
    """Per run: the exact planning model's per sample-step cost over the visited states and the latency it
    implies for ``preset=paper`` (samples x horizon steps x cost / threads)."""
    samples, steps, threads, _ = _latency_model()
    out = []
    for (visit, label), g in rows.groupby(["visit", "label"], sort=False):
        us = _exact_us(g)
        ms = us * samples * steps / threads / 1e3
        run = runs[(runs["visit"] == visit) & (runs["label"] == label)].iloc[0]
        out.append(
            {"run": label, "visit": visit, "every": run["every"], "states": len(us), "median": np.median(us),
             "min": us.min(), "max": us.max(), "mean": us.mean(), "ms": np.median(ms), "ms_min": ms.min(),
             "ms_max": ms.max(), "load_before": run["load_before"], "load_after": run["load_after"]}
        )  # fmt: skip
    return pd.DataFrame(out)


def calibration_table(cal: pd.DataFrame) -> str:
    columns = {
        "run": cal["run"],
        "visit": [f"{v} every {e:g} s" for v, e in zip(cal["visit"], cal["every"], strict=True)],
        "states": cal["states"],
        "median µs": cal["median"].map(_f),
        "range µs": [_range(r) for r in zip(cal["min"], cal["max"], strict=True)],
        "mean µs": cal["mean"].map(_f),
        "latency ms (median)": cal["ms"].map(lambda x: _f(x, 0)),
        "latency range ms": [_range(r, 0) for r in zip(cal["ms_min"], cal["ms_max"], strict=True)],
        "load before / after": [
            f"{a:.1f} / {b:.1f}" for a, b in zip(cal["load_before"], cal["load_after"], strict=True)
        ],
    }
    return _table(columns)


def speedups(rows: pd.DataFrame) -> pd.DataFrame:
    """Per run and phase: the mean per sample-step cost of the exact, the scene's (across_fingers) and the
    none planning models over the same states, the speed-ups (means) and the medians of per-state ratios."""
    out = []
    for (visit, label), g in rows.groupby(["visit", "label"], sort=False):
        for p, sel in _phases(g):
            ex, fa, no = (sel[c].to_numpy() for c in (f"plan_{EXACT}_us", "plan_us", f"plan_{NONE}_us"))
            out.append(
                {"run": label, "visit": visit, "phase": p, "states": len(sel), "exact": ex.mean(),
                 "fast": fa.mean(), "none": no.mean(), "fast_x": ex.mean() / fa.mean(),
                 "fast_med": np.median(ex / fa), "none_x": fa.mean() / no.mean(),
                 "none_med": np.median(fa / no), "exact_none_x": ex.mean() / no.mean()}
            )  # fmt: skip
    return pd.DataFrame(out)


def speedup_table(sp: pd.DataFrame) -> str:
    columns = {
        "run": sp["run"],
        "visit": sp["visit"],
        "phase": sp["phase"],
        "exact µs": sp["exact"].map(_f),
        f"{FAST} µs": sp["fast"].map(_f),
        f"exact / {FAST} (means; median per state)": [
            f"{a:.2f}x; {b:.2f}x" for a, b in zip(sp["fast_x"], sp["fast_med"], strict=True)
        ],
        f"{NONE} µs": sp["none"].map(_f),
        f"{FAST} / {NONE} (means; median per state)": [
            f"{a:.2f}x; {b:.2f}x" for a, b in zip(sp["none_x"], sp["none_med"], strict=True)
        ],
    }
    return _table(columns)


def agreement(ag: pd.DataFrame) -> pd.DataFrame:
    out = []
    for task, g in ag.groupby("task", sort=False):
        d_fast = g[f"{FAST}_mm"] - g[f"{EXACT}_mm"]
        has = g[f"{NONE}_mm"].notna()
        d_none = (g[f"{NONE}_mm"] - g[f"{EXACT}_mm"])[has]
        out.append(
            {"task": task, "states": len(g), "exact": g[f"{EXACT}_mm"].median(),
             "fast_diff_med": d_fast.median(), "fast_diff_max": d_fast.abs().max(),
             "none_states": int(has.sum()),
             "none": g.loc[has, f"{NONE}_mm"].median() if has.any() else np.nan,
             "none_diff_med": d_none.median() if has.any() else np.nan,
             "none_diff_max": d_none.max() if has.any() else np.nan}
        )  # fmt: skip
    return pd.DataFrame(out)


def agreement_table(agr: pd.DataFrame) -> str:
    def mm(x: float, sign: bool = False) -> str:
        return "—" if pd.isna(x) else (f"{x:+.3f}" if sign else f"{x:.3f}")

    columns = {
        "task": agr["task"],
        "contact states": agr["states"],
        "exact: median gap mm": agr["exact"].map(mm),
        f"{FAST} - exact: median mm": agr["fast_diff_med"].map(lambda x: mm(x, True)),
        f"{FAST} - exact: largest abs mm": agr["fast_diff_max"].map(mm),
        f"{NONE}: states": agr["none_states"].map(lambda n: n or "—"),
        f"{NONE}: median gap mm": agr["none"].map(mm),
        f"{NONE} - exact: median mm": agr["none_diff_med"].map(lambda x: mm(x, True)),
        f"{NONE} - exact: largest mm": agr["none_diff_max"].map(lambda x: mm(x, True)),
    }
    return _table(columns)


def trials_table(runs: pd.DataFrame, rows: pd.DataFrame) -> str:
    t = runs[runs["trial_num_plans"].notna()]
    last = rows[rows["visit"] == "planner"].groupby("label")["time"].max()
    columns = {
        "run": t["label"],
        "seed": t["seed"].astype(int),
        "states (the last at)": [
            f"{n} ({last[lb]:.1f} s)" for n, lb in zip(t["states"], t["label"], strict=True)
        ],
        "completed": t["trial_completed"].astype(bool),
        "TTF": t["trial_ttf"].map(lambda x: _f(x, 2)),
        "finished cleanly": t["trial_finished_cleanly"].astype(bool),
        "plans": t["trial_num_plans"].astype(int),
        "wall µs per sample-step": t["trial_plan_us_per_sample_step"].map(_f),
    }
    return _table(columns)


def report(study) -> str:
    rows, runs, ag = _load(study)
    samples, steps, threads, model_s = _latency_model()
    model_us = model_s * 1e6
    model_ms = samples * steps * model_us / threads / 1e3
    loads = pd.concat([runs["load_before"], runs["load_after"]])
    machine = sorted({f"{c} ×{int(n)}" for c, n in zip(runs["cpu"], runs["logical_cpus"], strict=True)})
    preset = sorted({r.rsplit(" ", 1)[1] for r in rows["run"]})
    rp = rows[rows["visit"] == "replay"]
    lp = rows[rows["visit"] == "planner"]
    n_states = {v: len(g) for v, g in rows.groupby("visit")}

    # where the time goes (replay, all states, per run)
    per_run = rp.groupby("label", sort=False).mean(numeric_only=True)
    physics = (per_run["collision"] + per_run["constraint"]) / per_run["plan_us"]
    rollout = per_run["rollout_us"] / per_run["plan_us"]
    cost_share = per_run["cost"] / per_run["plan_us"]
    by_phase = rp.groupby(["label", "phase"], sort=False)["plan_us"].mean().unstack()
    contact_x = by_phase["contact"] / by_phase["before"]
    wc = [lb for lb in per_run.index if "wrist_clearance" in lb]
    full_twin = {
        lb: lb.replace("wrist_clearance", "full")
        for lb in wc
        if lb.replace("wrist_clearance", "full") in per_run.index
    }
    sensor_text = "".join(
        f" The clearance term's `geomdist` sensors make the difference in {lb}: "
        f"{_f(per_run.loc[lb, 'sensors'])} µs of sensors per sample-step against "
        f"{_f(per_run.loc[f, 'sensors'])} µs in {f}, the plan "
        f"{per_run.loc[lb, 'plan_us'] / per_run.loc[f, 'plan_us']:.2f}x as dear."
        for lb, f in full_twin.items()
    )

    # calibration
    cal = calibration(rows, runs)
    rc = cal[cal["visit"] == "replay"]
    full_rc = rc[rc["run"].str.endswith(" full")]

    # cuts
    sp = speedups(rows)
    sp_all = sp[sp["phase"] == "all"]
    reached = sp_all[sp_all["exact_none_x"] >= GOAL]
    best = sp.loc[sp["none_x"].idxmax()]

    # agreement
    agr = agreement(ag)
    fast_moved = int((ag[f"{FAST}_mm"] != ag[f"{EXACT}_mm"]).sum())
    none_paper = agr[agr["none_states"] > 0]
    worst = ag.loc[(ag[f"{NONE}_mm"] - ag[f"{EXACT}_mm"]).idxmax()]

    # replay vs the closed loop, the same run, phase by phase
    pairs = []
    for label, g in lp.groupby("label", sort=False):
        r = rp[rp["label"] == label]
        for p in ("before", "contact"):
            a, b = g[g["phase"] == p], r[r["phase"] == p]
            if len(a) and len(b):
                pairs.append(
                    (label, p, a["plan_us"].mean(), b["plan_us"].mean(), a["ncon"].mean(), b["ncon"].mean())
                )
    dearer = [x for x in pairs if x[2] > x[3]]
    contact_pairs = [x for x in pairs if x[1] == "contact"]
    lc = cal[cal["visit"] == "planner"].set_index("run")["median"]
    rcm = rc.set_index("run")["median"]
    both = [lb for lb in lc.index if lb in rcm.index]

    out = [
        "## What is measured",
        "",
        "`job=profile` (`contactmpc/jobs/profile.py`) visits a trial's states (`job.visit=replay`: the "
        "reference replayed, a state every `job.every` s of the whole trial; `job.visit=planner`: the closed "
        "loop's own states, the object held) and times, at each, one planning iteration on one thread (CPU "
        "time, the median of `job.repeats`), interleaved with the same iteration on the alternatives' "
        "planning models and with the bare rollout. It splits the rollout by MuJoCo's per-part timers (a "
        "single-threaded `mj_step` loop over the same candidates: their shares of `mjTIMER_STEP`, applied to "
        "the rollout's CPU time); `cost` is the cost evaluation and `planner_rest` what the plan spends "
        "beyond the rollout and the cost (negative where the split's noise exceeds it). Every figure is µs "
        "per sample-step (one candidate's one planning-model step). A state's phase is `before` the first "
        "contact the reference expects, in `contact`, or `after` the last. The scene ran with "
        f"`scene.planning_cuts={{hand_pairs: {FAST}}}`; the exact planning model (`{EXACT}`) and one without "
        f"hand-hand contacts (`{NONE}`) were timed beside it at the same states.",
        "",
        "**Measured under load** (except the quiet-core calibration, below). The runs "
        f"({Fmt.listing(preset)} preset, seed "
        f"{Fmt.listing(sorted({str(int(s)) for s in runs['seed']}))}) ran on {Fmt.listing(machine)} "
        f"shared with other jobs: the 1-minute load average was {_range(loads)} before and after them. "
        "Every figure is CPU time under contention, not a quiet core's: the split between parts and the "
        "ratios between planning models timed at the same states (interleaved) hold "
        "better than the absolute costs.",
        "",
        f"Records: `records/profile_replay.csv` ({n_states.get('replay', 0)} states) and "
        f"`records/profile_loop.csv` ({n_states.get('planner', 0)} states), every visited state's row; "
        "`records/runs_replay.csv` and `records/runs_loop.csv`, one row per run (how it visited, the "
        "machine and its load, the visited trial's outcome); `records/agreement.csv`, plant against "
        "planning model at each contact state (below).",
        "",
        "## Where a plan's time goes",
        "",
        "The reference replayed, mean over the visited states of each phase (µs per sample-step):",
        "",
        profile_table(rows, "replay"),
        "",
        "- **The physics is the plan.** The rollout (the planning model's physics and sensors) takes "
        f"{_range(100 * rollout, 0)} % of the plan's time over each replayed trial, collision and the "
        f"constraint solver alone {_range(100 * physics, 0)} %; the cost evaluation "
        f"{_range(100 * cost_share, 0)} %." + sensor_text,
        f"- **Contact is the dear phase**: a state in contact costs {_range(contact_x, 2)}x one before "
        "contact (more contacts and constraint rows, `ncon` and `nefc`, in the solver).",
        "",
        "The closed loop (the trial's own states), the first seconds of each trial:",
        "",
        profile_table(rows, "planner"),
        "",
        "The visited closed-loop trials: each was cut short (`duration`), so its outcome is that of the "
        "cut-short trial, not a completion check; the wall time of its plans ran under the load above and "
        "is not comparable with the CPU-time figures:",
        "",
        trials_table(runs, rows),
        "",
        f"**The replay {'under-prices' if 2 * len(dearer) > len(pairs) else 'does not under-price'} the "
        f"closed loop's states.** Phase by phase, the closed loop's states cost more than the replay's in "
        f"{len(dearer)} of {len(pairs)} (run, phase) pairs; in contact "
        + "; ".join(
            f"{lb} {a:.1f} against {b:.1f} µs ({a / b:.2f}x, {c:.1f} against {d:.1f} contacts)"
            for lb, _, a, b, c, d in contact_pairs
        )
        + f"; the loop's contact states held more contacts in {sum(c > d for *_, c, d in contact_pairs)} of "
        f"{len(contact_pairs)}. The replay's contact states are the reference's, reached by its replayed "
        "controls; in the loop the hand holds the object as the planner grasped it. The calibrations' "
        "medians (below) differ likewise: "
        + "; ".join(f"{lb} {lc[lb]:.1f} µs in the loop against {rcm[lb]:.1f} replayed" for lb in both)
        + ". The loop visited only the first seconds (no `after` states, which are cheap in the replay), "
        "so a calibration over the replay's states prices a trial low on both counts.",
        "",
        "## The latency of preset=paper, calibrated over whole trials",
        "",
        f"`preset=paper` models the loop's latency as {samples} samples x {steps} steps x "
        f"{model_us:.0f} µs / {threads} threads = {model_ms:.0f} ms, the {model_us:.0f} µs from one "
        "benchmark state. Calibrated on the exact planning model over each trial's visited states "
        f"({samples} x {steps} x µs / {threads}):",
        "",
        calibration_table(cal),
        "",
        f"- Over the replayed trials of the paper's method the median sample-step costs "
        f"{_range(full_rc['median'])} µs ({_range(full_rc['median'] / model_us, 1)}x the modelled "
        f"{model_us:.0f} µs): a latency of {_range(full_rc['ms'], 0)} ms, not {model_ms:.0f} ms"
        f" (single states {_range(full_rc[['ms_min', 'ms_max']].to_numpy().ravel(), 0)} ms); with the "
        f"clearance term (wrist_clearance) {_range(rc.loc[rc['run'].isin(wc), 'ms'], 0)} ms. "
        "Under load and on this CPU: the authors' threads may be faster, so the range is an upper reading "
        "of theirs. The figure the calibrated presets use is the quiet core's (next section); "
        "`preset=paper` keeps its 21 µs, so its records stay the same trials.",
        "",
        *quiet_section(study, rows, runs),
        "## The cuts",
        "",
        f"Each planning model timed at the same states, interleaved ({FAST}: no contacts between two "
        f"links of one finger, the scene's; {NONE}: no contacts between any two links of the hand; "
        f"{EXACT}: the planning model as it is without cuts):",
        "",
        speedup_table(sp),
        "",
        f"- **`hand_pairs: {FAST}` saves nothing**: over each run's states the exact model costs "
        f"{_range(sp_all['fast_x'], 2)}x the cut one (means), noise around 1. The links of a finger never "
        f"touch (the agreement below: the cut changes the object's gap at {fast_moved} of {len(ag)} contact "
        "states), and the narrow-phase tests of the pairs it drops are lost in the noise.",
        f"- **`hand_pairs: {NONE}` saves {_range(sp_all['none_x'], 2)}x** against `{FAST}` over each run's "
        "states "
        f"(the most, {best['none_x']:.2f}x, in {best['run']}'s {best['phase']} states, {best['visit']}), "
        "but it changes what is simulated: fingers no longer press on each other or on the palm, and the "
        "planning model's object moves away from the plant's (below).",
        f"- **The goal of issue 32 ({GOAL:g}x lower per sample-step over each paper task, against the "
        f"planning model without cuts) is {'not ' if len(reached) < len(sp_all) else ''}reached**: "
        f"{len(reached)} of {len(sp_all)} runs reach it over the trial even with `{NONE}`, the cut that "
        f"is not free (exact / {NONE}: {_range(sp_all['exact_none_x'], 2)}x). What the plan spends is "
        "physics — collision and the constraint solver, "
        f"{_range(100 * physics, 0)} % of it — which no cut found here removes without changing the "
        "simulated contacts; of the issue's other levers, the solver's iterations and tolerance are priced "
        "below (*The constraint solver's settings*), and so are the clearance sensors read only near the "
        "object (*The method's plan*).",
        "",
        "## Agreement of the cuts",
        "",
        "Plant against planning model at each contact state of the reference (the object's gap after "
        "0.5 s of the reference's controls, `tests/test_agreement.py`'s measure), with the exact planning "
        f"model, with `{FAST}` and (paper tasks) with `{NONE}`:",
        "",
        agreement_table(agr),
        "",
        f"`{FAST}` moves the object at {fast_moved} of {len(ag)} contact states. `{NONE}` moves it further "
        "from the plant at the median state by "
        + Fmt.listing(
            [
                f"{x:+.2f} mm ({t})"
                for t, x in zip(none_paper["task"], none_paper["none_diff_med"], strict=True)
            ]
        )
        + f", up to {worst[f'{NONE}_mm'] - worst[f'{EXACT}_mm']:+.1f} mm ({worst['task']} at "
        f"{worst['time']:.2f} s): not free, so `scene.planning_cuts` stays off by default.",
        "",
        "",
        *method_section(study),
        "",
        *solver_section(study),
        "",
        *map_section(study),
        "",
        *online_section(study.dir / "records" / "online"),
    ]
    return "\n".join(out) + "\n"


def _method_rows(rec: Path) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The method's profiles, one row per visited state: ``far`` (distances read to 5 cm), ``near`` (to
    1 cm) and ``bare`` (no sensors) from ``profile_method.csv``; where ``profile_lazy.csv`` is kept, the
    method as it runs (1 cm and ``planner.lazy_distances``: ``lazy``) and, interleaved with it, no sensors
    (``lazy_bare``) in that second run. With the runs of both."""
    rows = pd.read_csv(rec / "profile_method.csv")
    rows["task"] = rows["run"].str.split(" ").str[0].str.removeprefix("paper_")
    rows = rows.rename(columns={"plan_us": "far", "plan_near_us": "near", "plan_no_sensors_us": "bare"})
    runs = [pd.read_csv(rec / "runs_method.csv")]
    if (rec / "profile_lazy.csv").is_file():
        lazy = pd.read_csv(rec / "profile_lazy.csv")
        lazy["task"] = lazy["run"].str.split(" ").str[0].str.removeprefix("paper_")
        lazy = lazy.rename(columns={"plan_us": "lazy", "plan_no_sensors_us": "lazy_bare"})
        rows = rows.merge(lazy[["task", "time", "lazy", "lazy_bare"]], on=["task", "time"])
        runs.append(pd.read_csv(rec / "runs_lazy.csv"))
    return rows, pd.concat(runs)


def method_section(study) -> list[str]:
    """The method's plan over each paper task's replayed trial: its per sample-step cost by phase with the
    link distances read to 5 cm, to the clearance term's 1 cm margin, also only in the plans that read
    them (``planner.lazy_distances``: the method as it runs), and without sensors; and what its grasp's
    plans (``acquire_samples``) cost on the paper's 7 threads against the calibrated latency."""
    head = ["## The method's plan, and its distances computed only where they are read", ""]
    rec = study.dir / "records"
    if not (rec / "profile_method.csv").is_file():
        return [*head, "No profile of the method is kept yet (`records/profile_method.csv`)."]
    rows, runs = _method_rows(rec)
    lazy = "lazy" in rows
    own = "lazy" if lazy else "near"  # the method as it runs
    method = sorted({r.split(" ")[1] for r in rows["run"]})
    _, steps, threads, _ = _latency_model()
    calibrated = float(_preset(CALIBRATED["latency"]).planner.latency)
    table = []
    for task, g in rows.groupby("task", sort=False):
        for phase in PHASES:
            sel = g if phase == "all" else g[g["phase"] == phase]
            if sel.empty:
                continue
            m = sel.mean(numeric_only=True)
            # the saving against 5 cm, each run's cost over its own no-sensor model timed interleaved with
            # it (two runs at different times: the machine's speed divides out)
            own_bare = m["lazy_bare"] if lazy else m["bare"]
            table.append(
                {"task": task, "phase": phase, "states": len(sel), "samples": _span(sel["plan_samples"]),
                 "far": m["far"], "near": m["near"], "own": m[own], "bare": m["bare"], "own_bare": own_bare,
                 "saved": (m["far"] / m["bare"]) / (m[own] / own_bare), "rollout": m["rollout_us"]}
            )  # fmt: skip
    t = pd.DataFrame(table)
    columns = {
        "task": t["task"],
        "phase": t["phase"],
        "states": t["states"],
        "samples a plan": t["samples"],
        "plan µs, distances to 5 cm": t["far"].map(_f),
        "to 1 cm": t["near"].map(_f),
        "without sensors": t["bare"].map(_f),
        **(
            {
                "to 1 cm, only where read (the method's; 2nd run)": t["own"].map(_f),
                "without sensors (2nd run)": t["own_bare"].map(_f),
            }
            if lazy
            else {}
        ),
        "saving, 5 cm / the method's": t["saved"].map(lambda x: f"{x:.2f}x"),
        "rollout µs (its candidates)": t["rollout"].map(_f),
    }
    grasp = []
    for task, g in rows.groupby("task", sort=False):
        most = g["plan_samples"].max()
        sel = g[g["plan_samples"] == most]
        us, far = sel[own].to_numpy(), sel["far"].to_numpy()
        ms = most * steps * us / threads / 1e3
        grasp.append(
            {"task": task, "samples": most, "states": len(us), "us": np.median(us), "lo": us.min(),
             "hi": us.max(), "ms": np.median(ms), "ms_lo": ms.min(), "ms_hi": ms.max(),
             "ms_far": np.median(most * steps * far / threads / 1e3)}
        )  # fmt: skip
    gr = pd.DataFrame(grasp)
    grasp_columns = {
        "task": gr["task"],
        "samples": gr["samples"],
        "states": gr["states"],
        "median µs (range)": [
            f"{_f(a)} ({_range((b, c))})" for a, b, c in zip(gr["us"], gr["lo"], gr["hi"], strict=True)
        ],
        f"latency on {threads} threads, ms: median (range)": [
            f"{a:.0f} ({_range((b, c), 0)})"
            for a, b, c in zip(gr["ms"], gr["ms_lo"], gr["ms_hi"], strict=True)
        ],
        "× the calibrated": (gr["ms"] / (calibrated * 1e3)).map(lambda x: f"{x:.1f}x"),
        "median ms, distances to 5 cm (1st run)": gr["ms_far"].map(lambda x: f"{x:.0f}"),
    }
    alls = t[t["phase"] == "all"].set_index("task")
    grasping = t[t["phase"].isin(["before", "contact"])]
    sensors = 1 - alls["own_bare"] / alls["own"]
    loads = pd.concat([runs["load_before"], runs["load_after"]])
    cpu = sorted(set(runs["cpu"]))
    worst = gr.loc[gr["ms"].idxmax()]
    over = gr[gr["ms"] > calibrated * 1e3 * 1.05]  # more than the calibrated figure, beyond its rounding
    saved = alls["saved"]
    best = saved.idxmax()
    return [
        *head,
        f"The method ({', '.join(f'`{m}`' for m in method)}, the paper tasks' default) profiled over each "
        f"paper task's replayed trial (a state every 2.5 s, seed 0), two runs at once on a quiet machine "
        f"({', '.join(cpu)}; 1-minute load average {loads.min():.1f}-{loads.max():.1f}). Its clearance term "
        "reads each link's distance to the object from `geomdist` sensors, one per pair of link geom and "
        "object geom, which MuJoCo computes at every step of every rollout. Priced at the same states: the "
        "distances read to 5 cm (`shaping=clearance`'s `scene.link_distance_cutoff`), and, interleaved with "
        "it, read only to the term's 1 cm margin (`scene.planning_cuts={distance_cutoff: 0.01}`)"
        + (
            "; then, in a second run, the method as it runs: to 1 cm and only in the plans whose window "
            "has the link before its first expected contact (`planner.lazy_distances`), interleaved with "
            "the same planning model without any sensor (what the sensors still cost)"
            if lazy
            else "; and with no sensors at all (what the sensors cost)"
        )
        + ". Each setting leaves every cost the same bit for bit (`tests/test_cost.py`), so every trial. "
        "A plan is priced per the samples it draws (`samples a plan`: 128 while `effort=acquire_error` draws "
        "the grasp's), the rollout per its 32 candidates (`records/profile_method.csv`"
        + (", `records/profile_lazy.csv`" if lazy else "")
        + " and their runs):",
        "",
        _table(columns),
        "",
        f"- **Over each trial the method's plan costs {_range(saved.to_numpy(), 2)}x less** than with the "
        f"distances read to 5 cm at every step (mean per sample-step), the trial unchanged; the most on the "
        f"{best} ({saved[best]:.2f}x), and "
        f"{_range(grasping['saved'].to_numpy(), 2)}x in the grasp's phases (before and in contact); each "
        "run's cost taken over its own planning model without sensors, timed interleaved with it, so that "
        "the machine's speed at the two runs' times divides out. "
        + (
            "Reading them only to the margin alone saves "
            f"{_range((alls['far'] / alls['near']).to_numpy(), 2)}x. "
            if lazy
            else ""
        )
        + f"The sensors still cost {_range(100 * sensors.to_numpy(), 0)} % of the method's plan over the "
        "trial (1 - without sensors / the method's).",
        "",
        f"The grasp's plans ({int(gr['samples'].max())} samples x {steps} steps, the states where the "
        f"method draws the most) on the paper's {threads} threads at the method's own cost, against the "
        f"{calibrated * 1e3:.0f} ms every simulated trial of the calibrated presets charges:",
        "",
        _table(grasp_columns),
        "",
        (
            f"- **The calibrated latency is optimistic for the method's grasp on "
            f"{Fmt.listing([f'the {x}' for x in over['task']])}**"
            if len(over)
            else "- **The method's grasp fits the calibrated latency on every task** (within 5 %)"
        )
        + f": on {threads} threads of this CPU its plans of the grasp would land after "
        f"{_range(gr['ms'].to_numpy(), 0)} ms (medians), "
        f"{_range((gr['ms'] / (calibrated * 1e3)).to_numpy(), 1)}x the {calibrated * 1e3:.0f} ms; the most "
        f"on the {worst['task']} ({worst['ms']:.0f} ms, {worst['ms'] / (calibrated * 1e3):.1f}x). The "
        "figure was calibrated on the paper's method (no clearance sensors, `variant=full`), and these are "
        "the replay's states, which price the closed loop's low (*Where a plan's time goes*); the online "
        "runs' grasp plans pay more still (*Online* below, and the method study's *Online, in wall-clock "
        "time*).",
    ]


#: The constraint solver's settings timed beside the method's planning model (``job.alternatives`` of
#: ``records/profile_solver.csv``): name -> what it sets on top of the scene's options.
SOLVER_SETS = {
    "it5": "`iterations: 5, ls_iterations: 10`",
    "it2": "`iterations: 2, ls_iterations: 5`",
    "tol5": "`tolerance: 1e-5`",
    "pyr": "`cone: pyramidal`",
}


def solver_section(study) -> list[str]:
    """The constraint solver's settings (:data:`SOLVER_SETS`) priced against the method's planning model
    over a closed-loop trial (``records/profile_solver.csv``, ``records/runs_solver.csv``): per phase, the
    mean per sample-step cost of each and the speed-ups (means; median of the per-state ratios)."""
    head = ["## The constraint solver's settings", ""]
    rec = study.dir / "records"
    if not (rec / "profile_solver.csv").is_file():
        return [*head, "No profile of the solver's settings is kept yet (`records/profile_solver.csv`)."]
    rows = pd.read_csv(rec / "profile_solver.csv")
    runs = pd.read_csv(rec / "runs_solver.csv")
    sets = [k for k in SOLVER_SETS if f"plan_{k}_us" in rows]
    table, alls = [], {}
    for label, g in rows.groupby("run", sort=False):
        for phase, sel in _phases(g):
            base = sel["plan_us"].to_numpy()
            row = {"run": label, "phase": phase, "states": len(sel), "ncon": _f(sel["ncon"].mean()),
                   "the method's model µs": _f(base.mean())}  # fmt: skip
            for k in sets:
                alt = sel[f"plan_{k}_us"].to_numpy()
                row[f"{k} µs (x; median)"] = (
                    f"{_f(alt.mean())} ({base.mean() / alt.mean():.2f}x; {np.median(base / alt):.2f}x)"
                )
                if phase == "all":
                    alls[k] = base.mean() / alt.mean()
                elif phase == "contact":
                    alls[f"{k}_contact"] = base.mean() / alt.mean()
            table.append(row)
    t = pd.DataFrame(table)
    run = runs.iloc[0]
    loads = pd.concat([runs["load_before"], runs["load_after"]])
    best = max(sets, key=lambda k: alls[k])
    return [
        *head,
        "The scene's planning model solves its constraints with Newton's method, at most 100 iterations, "
        "tolerance 1e-8 (MuJoCo's defaults), on elliptic friction cones (the scene's; MuJoCo's default is "
        "pyramidal). `job=profile` of the method "
        f"(`{run['run']}`) over its own closed-loop trial (`job.visit=planner`, seed {int(run['seed'])}, "
        f"a state every {run['every']:g} s, {int(run['states'])} states) timed each of these settings "
        "beside it, interleaved (`+job.alternatives.<name>={options: {...}}`): "
        + Fmt.listing([f"`{k}` {v}" for k, v in SOLVER_SETS.items() if k in sets])
        + f". One run on {run['cpu']} ×{int(run['logical_cpus'])} beside two niced trials (1-minute load "
        f"average {loads.min():.1f}-{loads.max():.1f}): the ratios, timed interleaved, hold better than the "
        "absolute costs (`records/profile_solver.csv`, `records/runs_solver.csv`):",
        "",
        _table({c: t[c] for c in t.columns}),
        "",
        f"- **No setting of the solver halves the plan**: over the trial the most is `{best}` "
        f"({alls[best]:.2f}x), and "
        + Fmt.listing([f"`{k}` {alls[k]:.2f}x" for k in sets if k != best])
        + ". What they save, they save in contact ("
        + Fmt.listing([f"`{k}` {alls[f'{k}_contact']:.2f}x" for k in sets if f"{k}_contact" in alls])
        + "), where the solver works hardest: a cap there stops it before it has converged, a looser "
        "tolerance stops it no sooner, and the pyramidal cone is another friction model; what saves "
        "anything changes the contacts the plans see, so none is an option of the library.",
    ]


def _span(counts) -> str:
    """``"2"`` or ``"1-2"``: the range of ``counts``."""
    lo, hi = min(counts), max(counts)
    return f"{lo}" if lo == hi else f"{lo}-{hi}"


ONLINE_COLUMNS = {
    "real-time factor": "real_time_factor",
    "replan interval median / p95 (ms)": ("replan_interval_median", "replan_interval_p95"),
    "plan age median / p95 (ms)": ("plan_latency_median", "plan_latency_p95"),
    "TTF": "ttf",
    "completed": "completed",
    "trials at once": "concurrent_trials",
}


def online_section(folder: Path) -> list[str]:
    """The paper's real-time claim: ``job=online`` runs (``records/online/<run>/trial.json``, made by
    ``run_online.sh``), one row each, and what is not measured yet."""
    runs = sorted(folder.glob("*/trial.json"))
    head = [
        "## Online in real time",
        "",
        "`job=online` runs the plant in wall-clock time and the planner in a second thread on 2 threads "
        "here (`planner.nthread=2`), at `preset=paper_32samples`; `job.slowdown` 2 and 3 stand in for real "
        "time on 4 and 6 threads of this CPU (`bash studies/plan_cost/run_online.sh online`).",
        "",
    ]
    if not runs:
        return [*head, "No online run is kept yet."]
    lines = [
        "| run | " + " | ".join(ONLINE_COLUMNS) + " |",
        "|---|" + "--:|" * len(ONLINE_COLUMNS),
    ]
    slowdowns = set()
    per_cell: dict[tuple[str, float], int] = {}
    records = [json.loads(path.read_text()) for path in runs]
    for path, r in zip(runs, records, strict=True):
        slowdown = online_slowdown(r)
        slowdowns.add(slowdown)
        cell = (f"{r.get('task')} {r.get('variant')}", slowdown)
        per_cell[cell] = per_cell.get(cell, 0) + 1
        cells = []
        for key in ONLINE_COLUMNS.values():
            if isinstance(key, tuple):
                cells.append(" / ".join(f"{1000 * r[k]:.0f}" for k in key))
            elif isinstance(r.get(key), float):
                cells.append(f"{r[key]:.3f}" if key == "real_time_factor" else f"{r[key]:.2f}")
            else:
                cells.append(str(r.get(key)))
        lines.append(f"| {path.parent.name} | " + " | ".join(cells) + " |")
    done = sorted(x for x in slowdowns if x is not None)
    missing = [f"slowdown {x:g}" for x in (1, 2, 3) if x not in done]
    fewer = sorted(f"{c} at slowdown {x:g}" for (c, x), n in per_cell.items() if n < 2)
    if fewer:
        missing.insert(0, "a second run of " + Fmt.listing(fewer))
    return [
        *head,
        *lines,
        "",
        f"{len(runs)} run{'s' if len(runs) != 1 else ''} kept, at slowdown "
        f"{', '.join(f'{x:g}' for x in done)}, {_span(per_cell.values())} a cell. "
        "The other runs were stopped (SIGSTOP) while these ran, so 'trials at once' counts them though "
        "they did not run." + (" Not measured yet: " + Fmt.listing(missing) + "." if missing else ""),
        "",
        *threads_needed(records),
    ]


def threads_needed(records: list[dict]) -> list[str]:
    """Per task and variant: the runs completed at each slowdown, the median replan interval, and the
    smallest slowdown at which every run completed (real time on 2 x that many threads of this CPU)."""
    table, prose, df = by_slowdown(records)
    if not len(df):
        return []
    return [
        "How many threads real time needs (a slowdown s on 2 threads stands in for 2s threads; a run "
        "that completes at one slowdown may still fail at a larger one, as a trial's outcome varies with its "
        "seed and its timing):",
        "",
        _table(table),
        "",
        "- " + "; ".join(prose) + ". The paper ran in real time on 7 threads of an Apple M1 laptop; on this "
        "2-core AMD EPYC the loop at 2 threads keeps real time (factor 1.000) but plans land "
        + _range([1e3 * v for v in df[df["slowdown"] == 1]["interval"]], 0)
        + " ms apart (median per run) at slowdown 1.",
    ]


#: The runs on a quiet machine: ``records/profile_<key>.csv`` and ``records/runs_<key>.csv``.
QUIET = {"quiet": "one at a time", "pair": "two at once"}
#: The presets that carry the calibrated figure (``conf/preset/<name>.yaml``).
CALIBRATED = {"model": "paper_calibrated", "latency": "paper_32samples_calibrated"}


def _load_quiet(study) -> dict[str, tuple[pd.DataFrame, pd.DataFrame]]:
    """The quiet machine's records, by key of :data:`QUIET`: every visited state's row and one row per run
    (each with ``label`` and ``visit``), those that exist."""
    rec = study.dir / "records"
    out = {}
    for k in QUIET:
        if (rec / f"profile_{k}.csv").is_file():
            rows, runs = pd.read_csv(rec / f"profile_{k}.csv"), pd.read_csv(rec / f"runs_{k}.csv")
            for df in (rows, runs):
                df["label"] = df["run"].str.rsplit(" ", n=1).str[0]
            rows["visit"] = rows["label"].map(runs.set_index("label")["visit"])
            out[k] = (rows, runs)
    return out


def _preset(name: str):
    """``conf/preset/<name>.yaml`` as written (its own keys, not composed with its defaults)."""
    return OmegaConf.load(HERE.parent.parent / "conf" / "preset" / f"{name}.yaml")


def quiet_section(study, rows: pd.DataFrame, runs: pd.DataFrame) -> list[str]:
    """One job on a quiet core against two at once and against the loaded runs; the calibration made
    from the quiet runs, the figure the calibrated presets hold, and whether they agree."""
    quiet = _load_quiet(study)
    head = ["## The latency, calibrated on a quiet core", ""]
    if "quiet" not in quiet:
        return [*head, "No quiet-machine run is kept yet (`records/profile_quiet.csv`)."]
    samples, steps, threads, model_s = _latency_model()
    cals = {k: calibration(r, u) for k, (r, u) in quiet.items()}
    loaded = calibration(rows[rows["visit"] == "replay"], runs[runs["visit"] == "replay"])
    q = cals["quiet"].set_index("run")
    pair = cals["pair"].set_index("run") if "pair" in cals else pd.DataFrame(columns=q.columns)
    ld = loaded.set_index("run")

    def load(c: pd.DataFrame) -> str:
        return _range(pd.concat([c["load_before"], c["load_after"]])) if len(c) else "—"

    def cell(c: pd.DataFrame, run: str) -> str:
        return _f(c.loc[run, "median"]) if run in c.index else "—"

    compare = {
        "run": q.index,
        f"quiet, {QUIET['quiet']}: median µs": [cell(q, r) for r in q.index],
        f"quiet, {QUIET['pair']}: median µs": [cell(pair, r) for r in q.index],
        "loaded: median µs": [cell(ld, r) for r in q.index],
        "loaded / quiet": [
            f"{ld.loc[r, 'median'] / q.loc[r, 'median']:.2f}x" if r in ld.index else "—" for r in q.index
        ],
    }
    in_pair = [r for r in q.index if r in pair.index]
    in_loaded = [r for r in q.index if r in ld.index]
    pair_x = [pair.loc[r, "median"] / q.loc[r, "median"] for r in in_pair]
    load_x = [ld.loc[r, "median"] / q.loc[r, "median"] for r in in_loaded]
    higher = sum(x > 1 for x in load_x)
    # the load's effect against the spread of two quiet runs of the same states (one alone, one beside
    # another job), or within 10 % where there is no second run
    load_dev = max(abs(x - 1) for x in load_x)
    pair_dev = max((abs(x - 1) for x in pair_x), default=0.1)
    barely = load_dev <= pair_dev

    # the derivation: the paper's method (full) on the paper tasks, each task's quiet median
    full = cals["quiet"][cals["quiet"]["run"].str.endswith(" full")]
    clear = cals["quiet"][~cals["quiet"]["run"].str.endswith(" full")]
    derived_us = float(np.median(full["median"]))
    derived_ms = samples * steps * derived_us / threads / 1e3
    per_task_ms = full["median"] * samples * steps / threads / 1e3
    model = _preset(CALIBRATED["model"]).planner.latency_model.sample_step_seconds
    lat = _preset(CALIBRATED["latency"]).planner.latency
    want_us, want_s = round(derived_us) * 1e-6, round(derived_ms, -1) / 1e3
    agree_model, agree_lat = np.isclose(model, want_us), np.isclose(lat, want_s)
    if agree_model and agree_lat:
        verdict = (
            f"The presets agree with the records: `preset={CALIBRATED['model']}` holds {model * 1e6:g} µs "
            "per sample-step (the figure rounded to 1 µs) and "
            f"`preset={CALIBRATED['latency']}` `planner.latency` {lat:g} s (the latency rounded to 10 ms)."
        )
    else:
        wrong = []
        if not agree_model:
            wrong.append(
                f"`preset={CALIBRATED['model']}` holds {model * 1e6:g} µs per sample-step, the records give "
                f"{want_us * 1e6:g} µs"
            )
        if not agree_lat:
            wrong.append(
                f"`preset={CALIBRATED['latency']}` holds `planner.latency` {lat:g} s, the records give "
                f"{want_s:g} s"
            )
        verdict = "**The presets disagree with the records**: " + "; ".join(wrong) + ". Update the presets."
    runs_q = quiet["quiet"][1]
    return [
        *head,
        "The calibration above ran under load. The same replayed trials were timed again on a quiet "
        "machine (nothing else running): each run alone on one of the two cores, then "
        f"{Fmt.listing(list(pair.index)) if len(pair) else 'none'} at once (two jobs on the two cores). "
        "The scene ran without cuts, so the plan itself is the exact planning model, one repeat per state "
        f"(`records/profile_quiet.csv`, `records/profile_pair.csv`, their runs in `records/runs_quiet.csv` "
        "and `records/runs_pair.csv`).",
        "",
        "### One job on a quiet core against two at once and against the loaded runs",
        "",
        f"The exact planning model's median per sample-step cost over each run's states (1-minute load "
        f"average before and after: quiet {load(cals['quiet'])}, two at once "
        f"{load(cals['pair']) if 'pair' in cals else '—'}, loaded {load(loaded)}):",
        "",
        _table(compare),
        "",
        f"- **The load {'barely moves' if barely else 'moves'} the CPU-time figure.** The loaded runs' "
        f"medians are {_range(load_x, 2)}x the quiet ones ({higher} of {len(load_x)} higher, at most "
        f"{100 * load_dev:.0f} % off)"
        + (
            f"; the same states timed again with two jobs at once, {_range(pair_x, 2)}x (at most "
            f"{100 * pair_dev:.0f} % off): "
            + ("a second quiet run differs from the first at least as much as" if barely else "less than")
            + " the loaded one does"
            if pair_x
            else ""
        )
        + ". CPU time counts only the time a thread runs, so waiting for a core does not enter it; what "
        "load can leave is the cache and memory bandwidth shared with the other jobs. Each run's states "
        "spread far wider than these differences (the ranges below).",
        "",
        "### The calibration on a quiet core: the figure the presets use",
        "",
        f"{samples} x {steps} x µs / {threads} threads, per run:",
        "",
        calibration_table(cals["quiet"]),
        "",
        f"- **The paper's method's sample-step costs {derived_us:.1f} µs**: the median over the "
        f"{len(full)} paper tasks ({Fmt.listing(list(full['run']))}) of each task's median. Latency: "
        f"{samples} x {steps} x {derived_us:.1f} µs / {threads} = **{derived_ms:.0f} ms**, not the "
        f"{samples * steps * model_s * 1e3 / threads:.0f} ms of `preset=paper` ({model_s * 1e6:.0f} µs from "
        f"one state); per task {_range(per_task_ms, 0)} ms"
        + "".join(f"; {r} {c:.0f} ms" for r, c in zip(clear["run"], clear["ms"], strict=True))
        + f". On {Fmt.listing(sorted({str(c) for c in runs_q['cpu']}))}: the authors' threads may be "
        "faster, so this is an upper reading of their latency.",
        f"- {verdict}",
        "",
    ]


#: The map (``run_online.sh map``, ``records/map/<run>/trial.json``): (task, variant) -> the latencies (s)
#: it runs at preset=paper_32samples, and its seeds.
MAP = {("apple", "full"): (0.15, 0.17, 0.2, 0.3), ("stapler", "wrist_clearance"): (0.17,)}
MAP_SEEDS = (0, 1, 2)
#: The kept trials at the paper latency (96 ms) and preset=paper_32samples: (task, variant) -> the study
#: whose records hold them.
MAP_BASE = {("apple", "full"): "fig3_paper", ("stapler", "wrist_clearance"): "stapler"}
CHOSEN = (32, 2.5, 0.096, 0.096)


def _map_trials(study) -> pd.DataFrame:
    """The map's trials (:func:`analysis.operating_point.points`), with ``source``; the 96 ms rows from the
    studies of :data:`MAP_BASE` (the stapler's as its report reads them), the text's reading."""
    from analysis.study import Study

    frames = []
    folder = study.dir / "records" / "map"
    if any(folder.glob("*/trial.json")):
        df = study.records()
        df = df[[Path(p).parent.parent == folder for p in df["record_path"]]]
        if len(df):
            frames.append(op.points(df).assign(source="the map"))
    for (task, variant), name in MAP_BASE.items():
        other = Study(name, root=study.root)
        if hasattr(other.spec, "trials"):
            pts = other.spec.trials(other)[0]
        else:
            pts = op.points(other.records())
        sel = (pts["task"] == task) & (pts["variant"] == variant) & (pts["fidelity"] == "paper")
        frames.append(pts[sel & op.at_point(pts, CHOSEN)].assign(source=f"studies/{name}"))
    df = pd.concat(frames, ignore_index=True)
    keep = pd.Series(False, index=df.index)
    for task, variant in MAP:
        keep |= (df["task"] == task) & (df["variant"] == variant)
    df = df[keep & (df["samples"] == CHOSEN[0]) & (df["horizon"] == CHOSEN[1])]
    return df[df["fidelity"] == "paper"].copy()


def map_section(study) -> list[str]:
    """The loop slower than the paper's 96 ms: per task and variant, one row per latency (the 96 ms row
    from the kept records), and where completion first drops."""
    df = _map_trials(study)
    calibrated = _preset(CALIBRATED["latency"]).planner.latency
    plan = MAP.items()
    out = [
        "## The map above the paper's latency",
        "",
        "Each plan applied (and the next started) L after its state, `preset=paper_32samples` with "
        "`planner.latency=L`, one thread (`bash studies/plan_cost/run_online.sh map`; "
        + Fmt.listing([f"{t} {v} at {', '.join(f'{1e3 * x:.0f}' for x in lats)} ms" for (t, v), lats in plan])
        + f", seeds {seeds(MAP_SEEDS)}). The 96 ms rows are the kept trials of the same preset at the "
        "paper's latency (the text's reading): "
        + Fmt.listing([f"{t} {v} from `{name}`" for (t, v), name in MAP_BASE.items()])
        + f". {1e3 * calibrated:.0f} ms is the calibrated latency (`preset={CALIBRATED['latency']}`).",
        "",
    ]
    missing, prose = [], []
    for (task, variant), lats in MAP.items():
        g = df[(df["task"] == task) & (df["variant"] == variant)]
        by = {round(float(x), 3): h for x, h in g.groupby(g["latency"].round(3))}
        rows = []
        for lat in sorted(by):
            h = by[lat]
            rows.append(
                {"latency ms": f"{1e3 * lat:.0f}" + (" (calibrated)" if np.isclose(lat, calibrated) else ""),
                 "trials": len(h), "completed": int(h["completed"].sum()),
                 "finished cleanly": int((h["finished_cleanly"] == True).sum()),  # noqa: E712
                 "median TTF": _na(h["ttf"].median(), 2), "median CPU-s": _na(h["compute"].median(), 0),
                 "seeds": seeds(h["seed"]), "from": Fmt.listing(sorted(set(h["source"])))}
            )  # fmt: skip
        out += [f"**{task} {variant}:**", "", _table({k: [r[k] for r in rows] for k in rows[0]}), ""]
        for lat in lats:
            done = set(by[lat]["seed"].astype(int)) if lat in by else set()
            left = [s for s in MAP_SEEDS if s not in done]
            if left:
                missing.append(f"{task} {variant} at {1e3 * lat:.0f} ms (seeds {seeds(left)})")
        base = by.get(CHOSEN[3])
        above = [lat for lat in sorted(by) if lat > CHOSEN[3]]
        if base is None or not above:
            continue
        r0 = base["completed"].mean()
        drop = [lat for lat in above if by[lat]["completed"].mean() < r0]
        same = base[base["seed"].isin(MAP_SEEDS)]
        on_seeds = (
            f" ({of(same['completed'].sum(), len(same))} on seeds {seeds(MAP_SEEDS)})" if len(same) else ""
        )
        base_text = f"{of(base['completed'].sum(), len(base))} at 96 ms{on_seeds}"
        if drop:
            d = by[drop[0]]
            prose.append(
                f"- **{task} {variant}: completion first drops at {1e3 * drop[0]:.0f} ms**, "
                f"{of(d['completed'].sum(), len(d))} against {base_text}"
                + (
                    "; below it " + Fmt.listing(
                        [f"{1e3 * x:.0f} ms {of(by[x]['completed'].sum(), len(by[x]))}" for x in above
                         if x < drop[0]]
                    )
                    if any(x < drop[0] for x in above) else ""
                )
                + "."
            )  # fmt: skip
        else:
            prose.append(
                f"- **{task} {variant}: completion holds up to {1e3 * above[-1]:.0f} ms**, the largest "
                "latency measured: "
                + Fmt.listing([f"{1e3 * x:.0f} ms {of(by[x]['completed'].sum(), len(by[x]))}" for x in above])
                + f" against {base_text}."
            )
        clean = {lat: int((by[lat]["finished_cleanly"] == True).sum()) for lat in by}  # noqa: E712
        clean_same = int((same["finished_cleanly"] == True).sum()) if len(same) else None  # noqa: E712
        prose.append(
            f"- {task} {variant}, finished cleanly: {of(clean[CHOSEN[3]], len(base))} at 96 ms"
            + (
                f" ({of(clean_same, len(same))} on seeds {seeds(MAP_SEEDS)})"
                if clean_same is not None
                else ""
            )
            + "; "
            + Fmt.listing([f"{1e3 * x:.0f} ms {of(clean[x], len(by[x]))}" for x in above])
            + (
                f". At the calibrated {1e3 * calibrated:.0f} ms: completed "
                f"{of(int(by[calibrated]['completed'].sum()), len(by[calibrated]))}, finished cleanly "
                f"{of(clean[calibrated], len(by[calibrated]))}."
                if calibrated in by
                else "."
            )
        )
    if not prose:
        prose.append("- Where the method stops working: not measured yet (no map trial above 96 ms is kept).")
    task_conf = (HERE.parent.parent / "conf" / "task" / "paper_apple.yaml").read_text()
    if f"preset: {CALIBRATED['latency']}" in task_conf:
        prose.append(
            f"- **The chosen preset, at the calibrated latency**: the paper tasks run "
            f"`preset={CALIBRATED['latency']}` by default (32 samples, {1e3 * calibrated:.0f} ms), the "
            "method study's point; a 32-sample plan costs a quarter of the paper point's, so this is the "
            "paper's loop with a quarter of its samples, not a faster loop (on 7 threads of this CPU its own "
            f"latency would be about {1e3 * calibrated / 4:.0f} ms)."
        )
    if missing:
        prose.append("- Not measured yet: " + Fmt.listing(missing) + ".")
    return [*out, *prose]
