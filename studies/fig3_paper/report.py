"""Does the full method beat each ablation on the paper's own tasks (Fig. 3), at the operating point
that works, under both readings of the method, by TTF and by completion?"""

from __future__ import annotations

import inspect

import numpy as np
import pandas as pd
from omegaconf import OmegaConf
from scipy.stats import fisher_exact

from analysis import paper_fig3 as fig3
from analysis.aggregate import TASK_ORDER, ok_trials, ordered
from analysis.inference import completion_test, smallest_u_p, wilson
from analysis.prose import seeds
from analysis.study import REPO, planned, sweep_params
from contactmpc.metrics import time_to_failure

TITLE = "Fig. 3 on the paper's data at the operating point that works"
EXPERIMENTS = [
    "python launch.py experiment=fig3_paper hydra.sweep.dir=studies/fig3_paper/records",
    "bash studies/fig3_paper/run_more_seeds.sh  # seeds 6-9 of the text's reading where completion differs",
    "python launch.py experiment=fig3_paper_hard hydra.sweep.dir=studies/fig3_paper/records/hard",
]
HARD = "fig3_paper_hard"
READINGS = {"paper": "the text's reading", "authors_code": "the authors' code's reading"}
ABLATIONS = {"no_contact": "the contact term", "joint_space": "sampling in the reference's PCA basis"}
ALPHA = fig3.ALPHA
#: More seeds (``run_more_seeds.sh``) for a cell of the text's reading whose completion differs from the
#: full method's (or the full method's from an ablation's) by at least this many trials at the planned seeds.
MORE_SEEDS_DIFFERENCE = 2
MORE_SEEDS = (6, 7, 8, 9)
PRESETS = REPO / "conf" / "preset"
CHALLENGES = REPO / "conf" / "challenge"


def report(study) -> str:
    f = study.fmt
    df = fig3.prepare(study.records())
    is_hard = (
        (df["experiment"] == HARD) | df["task"].str.contains("[", regex=False)
        if len(df)
        else pd.Series(dtype=bool)
    )
    main, hard = df[~is_hard], df[is_hard]
    rng = np.random.default_rng(fig3.BOOTSTRAP_SEED)
    # The tests first (the bootstrap's draws in the order main, then hard), so the verdicts can lead.
    ttf = fig3.ttf_tests(main, rng) if len(main) else None
    done = fig3.completion_tests(main) if len(main) else None
    hard_ttf = fig3.ttf_tests(hard, rng) if len(hard) else None
    hard_done = fig3.completion_tests(hard) if len(hard) else None
    verdicts = _verdicts(main, ttf, done) if len(main) else []
    hard_verdicts = _verdicts(hard, hard_ttf, hard_done, hard=True) if len(hard) else []
    out = [study.provenance(df), "", _intro(f), ""]
    if verdicts:
        out += [_in_short(verdicts, hard_verdicts, f), ""]
    out += [_status(main, "fig3_paper", f), ""]
    if len(main):
        out += ["### More seeds where completion differs", "", _more_seeds(main), ""]
        out += [_budget(main, f), ""]
        out += [study.draw("fig3_paper.png", lambda p: fig3.fig3(main, p), "Fig. 3 on the paper's data"), ""]
        out += ["### Per task, variant and reading", "", fig3.cell_table(main), _cell_note(), ""]
        out += _tests_section(ttf, done, main, f)
        out += ["## What it says", ""]
        for fid in ordered(main["fidelity"], fig3.FIDELITY_ORDER):
            out += [_findings(main, ttf, done, fid, f), ""]
        out += [_claims(verdicts, f), ""]
    out += ["## The cells where open-loop replay fails (`experiment=fig3_paper_hard`)", ""]
    out += [_hard_intro(), "", _status(hard, HARD, f), ""]
    if len(hard):
        out += [study.draw("fig3_paper_hard.png", lambda p: fig3.fig3(hard, p), "Fig. 3, the hard cells"), ""]
        out += [fig3.cell_table(hard), ""]
        out += _tests_section(hard_ttf, hard_done, hard, f)
        out += ["### What the hard cells say", ""]
        for fid in ordered(hard["fidelity"], fig3.FIDELITY_ORDER):
            out += [_findings(hard, hard_ttf, hard_done, fid, f), ""]
        out += [_claims(hard_verdicts, f, hard=True), ""]
    return "\n".join(out)


def _intro(f) -> str:
    params = sweep_params("fig3_paper")
    seeds = len(params.get("seed", [])) or 6
    m = len(params.get("task", [])) * (len(params.get("variant", [])) - 1) or 8  # tests per reading
    p_n, p_less = smallest_u_p(seeds, seeds), smallest_u_p(seeds - 1, seeds - 1)
    samples = _conf(REPO / "conf" / "operating_point" / "s32.yaml", "planner.num_samples")
    fewest = "the fewest" if m * p_n < ALPHA <= m * p_less else "a number of"
    return (
        "`experiment=fig3_paper` runs the paper's Fig. 3 at `preset=paper_32samples` (the paper's planner "
        f"with {samples} samples, the operating point at which the method does the real apple): the four "
        "paper tasks × `full` / `no_contact` / `joint_space` × both readings of the method "
        f"(`fidelity=paper`, the text's; `fidelity=authors_code`, the authors' code's) × {seeds} seeds = "
        f"{planned('fig3_paper')} trials. {seeds} is {fewest} seeds with which an exact two-sided "
        f"Mann–Whitney test can pass Holm's correction over the {m} tests of a reading at {ALPHA:g}: "
        f"{m} × {f.p(p_n)} = {f.p(m * p_n)} at {seeds} vs {seeds}, {m} × {f.p(p_less)} = {f.p(m * p_less)} "
        f"at {seeds - 1} vs {seeds - 1}. Seeds vary slowest, so a sweep stopped early "
        "holds "
        "every cell. Each reading is its own experiment: Holm's correction runs over the tests of one "
        "reading."
    )


def _status(df: pd.DataFrame, experiment: str, f) -> str:
    total = planned(experiment)
    of = f" of {total}" if total else ""
    cmd = next(e for e in EXPERIMENTS if f"experiment={experiment} " in e)
    if not len(df):
        return f"**`{experiment}`: none yet (0{of} trials).** Run `{cmd}`."
    seeds_planned = sweep_params(experiment).get("seed")
    extra = df[~df["seed"].isin([int(x) for x in seeds_planned])] if seeds_planned else df.iloc[:0]
    more = f"; and {len(extra)} trials at more seeds (below)" if len(extra) else ""
    df = df.drop(extra.index)
    parts = []
    counts = df.groupby(["fidelity", "task", "variant"]).size()
    cells_per_reading = _cells_planned(experiment) or len(df["task"].unique()) * len(df["variant"].unique())
    for fid in fig3.FIDELITY_ORDER:
        if fid not in counts.index.get_level_values(0):
            parts.append(f"`{fid}`: none yet")
            continue
        c = counts.loc[fid]
        cells = "every cell" if len(c) == cells_per_reading else f"{len(c)} of {cells_per_reading} cells"
        seeds = f"{c.min()}" if c.min() == c.max() else f"{c.min()}–{c.max()}"
        parts.append(f"`{fid}`: {c.sum()} trials, {cells}, {seeds} seed{'s' if c.max() > 1 else ''} each")
    cpu = pd.to_numeric(df["cpu_seconds"], errors="coerce").sum() / 3600
    left = f" Resume with `{cmd}`." if total and len(df) < total else ""
    return (
        f"**`{experiment}`: {len(df)}{of} trials** ({'; '.join(parts)}; {cpu:.2f} CPU-hours measured{more})."
        f"{left}"
    )


def _cells_planned(experiment: str) -> int | None:
    """How many cells (task or challenge x variant) a reading of ``experiment`` sweeps; ``None`` where
    its sweep does not say."""
    params = sweep_params(experiment)
    sizes = [len(v) for k, v in params.items() if k not in ("seed", "fidelity")]
    return int(np.prod(sizes)) if sizes else None


def _planned_seeds() -> list[int]:
    """The seeds ``experiment=fig3_paper`` sweeps (0-5)."""
    return [int(x) for x in sweep_params("fig3_paper").get("seed", range(6))]


def more_seeds_cells(df: pd.DataFrame) -> list[tuple[str, str]]:
    """The cells ``(task, variant)`` of the text's reading (``fidelity=paper``) that get seeds 6-9: those
    whose completion at the planned seeds differs by :data:`MORE_SEEDS_DIFFERENCE` trials or more from
    the full method's (for an ablation) or from an ablation's (for the full method), the pairs the tests
    compare; in the tables' order."""
    cells = _cells(df[df["seed"].isin(_planned_seeds())], "paper")
    out = set()
    for task in {t for t, _ in cells}:
        full = _count(cells.get((task, "full")))
        for ablation in ABLATIONS:
            other = _count(cells.get((task, ablation)))
            if full[1] and other[1] and abs(full[0] - other[0]) >= MORE_SEEDS_DIFFERENCE:
                out |= {(task, "full"), (task, ablation)}
    order = [*ordered({t for t, _ in out}, TASK_ORDER)]
    variants = ["full", *ABLATIONS]
    return sorted(out, key=lambda c: (order.index(c[0]), variants.index(c[1])))


def _more_seeds(df: pd.DataFrame) -> str:
    """Which cells the rule gives seeds 6-9, the command that runs them, and how many are kept."""
    cells = more_seeds_cells(df)
    if not cells:
        return "No cell of the text's reading differs in completion by enough to run more seeds."
    by_task: dict[str, list[str]] = {}
    for task, variant in cells:
        by_task.setdefault(task, []).append(variant)
    arg = " ".join(f"paper_{t}:{','.join(v)}" for t, v in by_task.items())
    kept = ok_trials(df[(df["fidelity"] == "paper") & df["seed"].isin(MORE_SEEDS)])
    have = {c: int(((kept["task"] == c[0]) & (kept["variant"] == c[1])).sum()) for c in cells}
    done = sum(have.values())
    planned_more = len(cells) * len(MORE_SEEDS)
    listed = "; ".join(f"the {t}: {', '.join(f'`{v}`' for v in vs)}" for t, vs in by_task.items())
    status = (
        "all of them kept"
        if done == planned_more
        else f"{done} of {planned_more} kept so far ("
        + ", ".join(f"{t} `{v}` {have[(t, v)]}" for t, v in cells)
        + f'); resume with `CELLS="{arg}" bash studies/fig3_paper/run_more_seeds.sh`'
    )
    planned = seeds(_planned_seeds())
    return (
        f"Under the text's reading, the cells whose completion at seeds {planned} differs by "
        f"{MORE_SEEDS_DIFFERENCE} or more from the cell the tests compare them with (the full method "
        f"against an ablation) get seeds {seeds(MORE_SEEDS)} too, so the tests of those tasks "
        f"run at up to {len(_planned_seeds()) + len(MORE_SEEDS)} trials a cell "
        "(`studies/fig3_paper/run_more_seeds.sh`, seeds "
        f"varying slowest): {listed}. {planned_more} trials: {status}. The tables, tests "
        f"and findings below count every kept seed; the authors' code's reading stays at seeds {planned}."
    )


def _budget(df: pd.DataFrame, f) -> str:
    cpu = pd.to_numeric(df["cpu_seconds"], errors="coerce")
    parts = []
    for fid in ordered(df["fidelity"], fig3.FIDELITY_ORDER):
        sel = df["fidelity"] == fid
        per_task = ", ".join(
            f"{t} {cpu[sel & (df['task'] == t)].mean():.0f}" for t in ordered(df.loc[sel, "task"], TASK_ORDER)
        )
        parts.append(
            f"`{fid}`: {cpu[sel].sum() / 3600:.2f} CPU-hours over {int(sel.sum())} trials, mean "
            f"{cpu[sel].mean():.0f} CPU-s per trial (median {cpu[sel].median():.0f}; mean per task: "
            f"{per_task})"
        )
    threads = ", ".join(str(t) for t in sorted(df["threads"].dropna().astype(int).unique()))
    return (
        "**What it cost** (the records' `cpu_seconds`, every trial counted, diverged ones too; planner "
        f"threads per trial: {threads}): " + "; ".join(parts) + ". A benchmark made on an idle machine "
        "prices such a sweep low: price with `python -m analysis.budget experiment=fig3_paper --benchmarks "
        "DIR` from benchmarks made under the sweep's own load."
    )


def _cell_note() -> str:
    return (
        "*completed*, *finished cleanly*: counts over the trials that count (status ok, or diverged with a "
        "TTF); *median (IQR) TTF %*: median and interquartile range over trials; object errors: **means** "
        "over trials of each trial's mean (— where the task has no free object: the doorknob); *errors*: "
        "records that do not count."
    )


def _tests_section(ttf: pd.DataFrame, done: pd.DataFrame, df: pd.DataFrame, f) -> list[str]:
    ttf = ttf.sort_values(
        "condition", key=lambda c: c.map({k: i for i, k in enumerate(fig3.FIDELITY_ORDER)}), kind="stable"
    )
    done = done.sort_values(
        "fidelity", key=lambda c: c.map({k: i for i, k in enumerate(fig3.FIDELITY_ORDER)}), kind="stable"
    )
    return [
        "### TTF: `full` against each ablation",
        "",
        "Mann–Whitney U (two-sided) per task and reading; Holm over the tests of each reading. *test*: "
        "exact where the samples have no ties, else the exact permutation distribution of U over every "
        "arrangement of the pooled values (one trial a side included; never the normal approximation at "
        "these sizes); p-values double the smaller tail. *smallest attainable p*: the least p any "
        "arrangement of these pooled values could give, i.e. what the test can detect at this n; where it "
        f"is not below {ALPHA:g} the test is **too few to test** and its p is starred. Effect sizes: "
        "P(full > ablation) = U / nm (the common-language effect size) and the Hodges–Lehmann shift (the "
        "median of the pairwise TTF differences), each with a percentile bootstrap 95 % interval over "
        f"trials ({fig3.BOOTSTRAP_RESAMPLES} resamples within each cell, generator seed "
        f"{fig3.BOOTSTRAP_SEED}, so the report is reproducible; at a few trials a cell the interval is "
        "rough).",
        "",
        fig3.ttf_tests_markdown(ttf),
        "### Completion: `full` against each ablation",
        "",
        _why_barnard(df, f),
        "",
        fig3.completion_tests_markdown(done),
    ]


def _why_barnard(df: pd.DataFrame, f) -> str:
    text = (
        "Barnard's exact unconditional test (two-sided, `scipy.stats.barnard_exact`), per task and reading, "
        "Holm over the same family as TTF's tests. Why Barnard's and not Fisher's: the design fixes how many "
        "trials each cell runs, not how many complete; Fisher's test conditions on the total completed as "
        "well, which makes it conservative at a few trials a cell, while Barnard's keeps the level without "
        "that condition and so has more power at this n. The difference in completion rate (full − "
        "ablation, percentage points) has Newcombe's hybrid score 95 % interval (from the two Wilson "
        f"intervals). A starred p: too few to test (the smallest attainable p is not below {ALPHA:g})."
    )
    good = ok_trials(df)
    good = good[good["completed"].notna() & (good["fidelity"] == "paper")]
    if not len(good):
        return text
    k = good.groupby(["task", "variant"])["completed"].agg(["sum", "size"])
    best = None
    for (task, variant), r in k.iterrows():
        if variant == "full" or (task, "full") not in k.index:
            continue
        ref = k.loc[(task, "full")]
        gap = r["size"] and ref["sum"] / ref["size"] - r["sum"] / r["size"]
        if best is None or gap > best[0]:
            best = (gap, task, variant, int(ref["sum"]), int(ref["size"]), int(r["sum"]), int(r["size"]))
    if best is None or best[0] <= 0:
        return text
    _, task, variant, k1, n1, k2, n2 = best
    fisher = fisher_exact([[k1, n1 - k1], [k2, n2 - k2]]).pvalue
    barnard, _ = completion_test(k1, n1, k2, n2)
    return text + (
        f" On the largest difference of the text's reading, the {task}'s {k1}/{n1} against {variant}'s "
        f"{k2}/{n2}, Fisher's test gives p = {f.p(fisher)} and Barnard's p = {f.p(barnard)}."
    )


def _cells(df: pd.DataFrame, fid: str) -> dict[tuple[str, str], pd.DataFrame]:
    good = ok_trials(df[df["fidelity"] == fid])
    return {(t, v): g for (t, v), g in good.groupby(["task", "variant"])}


def _count(g: pd.DataFrame | None, col: str = "completed") -> tuple[int, int]:
    if g is None:
        return 0, 0
    x = g[col].dropna().astype(bool)
    return int(x.sum()), len(x)


def _findings(df: pd.DataFrame, ttf: pd.DataFrame, done: pd.DataFrame, fid: str, f) -> str:
    cells = _cells(df, fid)
    sub = df[df["fidelity"] == fid]
    n = sub.groupby(["task", "variant"]).size()
    seeds = f"{n.min()}" if n.min() == n.max() else f"{n.min()}–{n.max()}"
    tasks = ordered(sub["task"], TASK_ORDER)
    lines = [f"**Under {READINGS.get(fid, fid)} (`fidelity={fid}`, {seeds} trials a cell).**"]
    per_task = []
    for t in tasks:
        k, m = _count(cells.get((t, "full")))
        c, _ = _count(cells.get((t, "full")), "finished_cleanly")
        abl = ", ".join(
            f"{v} {'/'.join(map(str, _count(cells.get((t, v)))))}" for v in ABLATIONS if (t, v) in cells
        )
        per_task.append(f"the {t}: full {k}/{m} completed ({c} finished cleanly), {abl}")
    lines.append("Completion: " + "; ".join(per_task) + ".")
    better, not_better, unpaired = [], [], []
    for t in tasks:
        k, m = _count(cells.get((t, "full")))
        rates = [_count(cells.get((t, v))) for v in ABLATIONS if (t, v) in cells]
        if not m or len(rates) < len(ABLATIONS) or not all(n for _, n in rates):
            unpaired.append(t)  # the full method or an ablation without trials yet
        elif all(k / m > km[0] / km[1] for km in rates):
            better.append(t)
        else:
            not_better.append(t)
    if better:
        lines.append(
            f"The full method completes more often than both ablations on {_the(better, f)}"
            + (f", not on {_the(not_better, f)}." if not_better else ".")
        )
    elif not_better:
        lines.append("On no task does the full method complete more often than both ablations.")
    if unpaired:
        lines.append(f"Not compared yet on {_the(unpaired, f)}: a cell without trials.")
    tt = ttf[(ttf["condition"] == fid) & ttf["p_holm"].notna()]
    dd = done[done["fidelity"] == fid]
    m_tests = int(tt["p"].notna().sum())
    untestable = int((~tt["testable"]).sum())
    passing = tt[tt["p_holm"] < ALPHA]
    if len(passing):
        lines.append(_holm(f"**TTF**: of the {m_tests} tests, {len(passing)}", passing, _ttf_test, f))
    else:
        lines.append(f"**TTF**: none of the {m_tests} tests passes Holm's correction.")
    if untestable:
        lines.append(
            f"{f.plural(untestable, 'test')} of TTF cannot reach p < {ALPHA:g} at their n (too few to test)."
        )
    cp = dd[dd["p_holm"] < ALPHA]
    if len(cp):
        lines.append(_holm(f"**Completion**: {len(cp)} of {len(dd)} tests", cp, _completion_test, f))
    elif len(dd):
        low = dd.loc[dd["p"].idxmin()]
        lines.append(
            f"**Completion**: none of the {len(dd)} tests passes Holm's correction; the smallest p is the "
            f"{low.task}'s, full {low.k_ref}/{low.n_ref} against {low.variant} {low.k_other}/{low.n_other}: "
            f"p = {f.p(low.p)}, Holm p = {f.p(low.p_holm)}, difference {100 * low.delta:+.0f} points "
            f"[{100 * low.delta_lo:+.0f}, {100 * low.delta_hi:+.0f}]"
            + ("." if low.testable else f" (too few to test: p cannot go below {f.p(low.p_min)} at this n).")
        )
    lines.append(_late_grasps(sub, f))
    lines.append(_power(dd, tt, f))
    return " ".join(x for x in lines if x)


def _late_grasps(sub: pd.DataFrame, f) -> str:
    """Full-method trials that the paper's failure rule declares failed and that then complete."""
    g = ok_trials(sub)
    late = g[(g["variant"] == "full") & g["completed"].fillna(False).astype(bool) & (g["ttf"] < 1)]
    if not len(late):
        return ""
    params = inspect.signature(time_to_failure).parameters
    gap, links = params["gap"].default, params["min_expected"].default
    items = []
    for task in ordered(late["task"], TASK_ORDER):
        rows = late[late["task"] == task].sort_values("seed")
        into = [
            f"seed {int(r.seed)} {r.failure_time - r.contact_span_start:.1f} s"
            for r in rows.itertuples(index=False)
        ]
        clean = int(rows["finished_cleanly"].fillna(False).astype(bool).sum())
        items.append(
            f"on the {task}, {f.listing(into)} into the contact span ({clean} of {len(rows)} then "
            "finished cleanly)"
        )
    return (
        "TTF and completion disagree because **the paper's failure rule declares failed trials that then "
        f"complete** (it fires when no link touches the object for {gap * 1000:.0f} ms while more than "
        f"{links} contacts are expected, e.g. while the fingers close on a late grasp): "
        f"{f.plural(len(late), 'full-method trial')} completed after being declared failed, "
        + "; ".join(items)
        + "."
    )


def _power(dd: pd.DataFrame, tt: pd.DataFrame, f) -> str:
    if not len(dd):
        return ""
    m = len(dd)
    sizes = pd.concat([dd["n_ref"], dd["n_other"]])
    n = int(sizes.mode().max())
    vary = f" (cells here hold {sizes.min()}–{sizes.max()})" if sizes.min() != sizes.max() else ""
    step = ALPHA / m
    need = None
    for k2 in range(n, -1, -1):
        p, _ = completion_test(n, n, k2, n)
        if p < step:
            need = n - k2
            break
    p_u = smallest_u_p(n, n)
    text = (
        f"**Power at {f.plural(n, 'trial')} a cell**{vary}: Holm's first step needs p < {ALPHA:g}/{m} = "
        f"{f.p(step)}; an exact Mann–Whitney test of {n} against {n} untied TTFs can reach p = {f.p(p_u)} at "
        "best, and has a higher floor where TTFs tie, as every completed trial's do (the smallest attainable "
        "p of each test is in the table)"
    )
    if need is not None:
        text += (
            f", and Barnard's test passes it only when completion differs by {need} of {n} or more "
            f"({n}/{n} against {n - need}/{n})."
        )
    else:
        text += f", and no completion difference at {n} a cell can pass it."
    return text


def _verdicts(df: pd.DataFrame, ttf: pd.DataFrame, done: pd.DataFrame, hard: bool = False) -> list[dict]:
    """Per reading and ablation, the paper's claim that the full method beats it: on the free-object
    tasks, or (``hard``) on every cell where open-loop replay fails. Each row: the tasks compared, those
    the full method completes more often on (``ahead``), those where a test in full's favour passes Holm
    and the full method completes some trials (``real``), and those where one passes but every full trial
    fails too (``failing``); none for an ablation with no task to compare."""
    rows = []
    for fid in ordered(df["fidelity"], fig3.FIDELITY_ORDER):
        cells = _cells(df, fid)
        for variant in ABLATIONS:
            tasks = [
                t
                for t in ordered(df["task"], TASK_ORDER)
                if (hard or t != "doorknob") and (t, variant) in cells
            ]
            if not tasks:
                continue
            ahead = [t for t in tasks if _rate(cells.get((t, "full"))) > _rate(cells.get((t, variant)))]
            sig = [
                r.task
                for r in ttf.itertuples(index=False)
                if r.condition == fid
                and r.variant == variant
                and r.p_holm < ALPHA
                and r.prob_superiority > 0.5
            ] + [
                r.task
                for r in done.itertuples(index=False)
                if r.fidelity == fid and r.variant == variant and r.p_holm < ALPHA and r.delta > 0
            ]
            sig = [t for t in ordered(sig, TASK_ORDER) if t in tasks]
            real = [t for t in sig if _rate(cells.get((t, "full"))) > 0]
            rows.append(
                {
                    "fidelity": fid,
                    "variant": variant,
                    "tasks": tasks,
                    "ahead": ahead,
                    "real": real,
                    "failing": [t for t in sig if t not in real],
                }
            )
    return rows


def _claims(rows: list[dict], f, hard: bool = False) -> str:
    """The paper's two claims (the contact term and the PCA sampling are needed), under each reading, in
    full (``rows`` from :func:`_verdicts`)."""
    if hard:
        head = (
            "**On the paper's two claims where replay fails** — the same two claims, on the cells where "
            "closed-loop control has to do the work (the doorknob counts here: with its servos weakened, "
            "replay fails it):"
        )
        kind = "hard cells"
    else:
        head = (
            "**On the paper's two claims** — that ablating the contact term, and sampling in joint space "
            "instead of the reference's PCA basis, make the method fail the harder tasks (the free-object "
            "ones; the paper itself finds the ablations competitive on the doorknob):"
        )
        kind = "free-object tasks"
    lines = [head]
    for r in rows:
        verdict = (
            f"**established** (Holm-corrected) on {_the(r['real'], f)}"
            if r["real"]
            else "**not established** at this n (no test passes Holm's correction in full's favour on a "
            "task the full method completes)"
        )
        if r["failing"]:
            verdict += (
                f"; on {_the(r['failing'], f)} a test passes, but there every trial of the full method fails "
                "too: a difference between two ways of failing"
            )
        direction = (
            f"the full method completes more often on {_the(r['ahead'], f)} (of {len(r['tasks'])} {kind})"
            if r["ahead"]
            else f"the full method completes more often on none of the {kind}"
        )
        reading, what = READINGS.get(r["fidelity"], r["fidelity"]), ABLATIONS[r["variant"]]
        lines.append(f"- {reading}, {what} (`{r['variant']}`): {direction}; {verdict}.")
    return "\n".join(lines)


def _in_short(main: list[dict], hard: list[dict], f) -> str:
    """One table of the paper's two claims: per reading and claim, whether it holds on the free-object
    tasks and on the cells where replay fails (the details under *What it says* and *What the hard cells
    say*)."""

    def cell(r: dict | None) -> str:
        if r is None:
            return "not run yet"
        if r["real"]:
            return f"**holds** on {_the(r['real'], f)}"
        ahead = f"full ahead on {_the(r['ahead'], f)}" if r["ahead"] else "full ahead on none"
        return f"not established ({ahead}, of {len(r['tasks'])})"

    key = {(r["fidelity"], r["variant"]): r for r in hard}
    lines = [
        "**In short**, whether the full method beats each ablation with a test that passes Holm's "
        "correction (TTF or completion, on a task the full method completes), on the free-object tasks and "
        "where open-loop replay fails:",
        "",
        "| reading | claim: the full method needs | free-object tasks | where replay fails |",
        "|---|---|---|---|",
    ]
    for r in main:
        h = key.get((r["fidelity"], r["variant"]))
        reading, what = READINGS.get(r["fidelity"], r["fidelity"]), ABLATIONS[r["variant"]]
        lines.append(f"| {reading} | {what} (`{r['variant']}`) | {cell(r)} | {cell(h)} |")
    return "\n".join(lines)


def _the(tasks: list[str], f) -> str:
    return f.listing([f"the {t}" for t in tasks])


def _pass(n: int) -> str:
    return "passes" if n == 1 else "pass"


def _holm(head: str, passing: pd.DataFrame, item, f) -> str:
    """``head`` (what is counted, up to the number that pass), then the tests that pass Holm's correction,
    each as ``item(row, f)`` words it."""
    items = "; ".join(item(r, f) for r in passing.itertuples(index=False))
    return f"{head} {_pass(len(passing))} Holm's correction: {items}."


def _ttf_test(r, f) -> str:
    """A TTF test that passes, in words."""
    return (
        f"the {r.task}, full against {r.variant} (medians {100 * r.median_ref:.1f} % against "
        f"{100 * r.median_other:.1f} %, Holm p = {f.p(r.p_holm)}, P(full > ablation) "
        f"{r.prob_superiority:.2f} [{r.ps_lo:.2f}, {r.ps_hi:.2f}], shift {100 * r.hl_shift:+.1f} points)"
    )


def _completion_test(r, f) -> str:
    """A completion test that passes, in words."""
    return (
        f"the {r.task}, full {r.k_ref}/{r.n_ref} against {r.variant} {r.k_other}/{r.n_other} "
        f"(Holm p = {f.p(r.p_holm)}, difference {100 * r.delta:+.0f} points [{100 * r.delta_lo:+.0f}, "
        f"{100 * r.delta_hi:+.0f}])"
    )


def _rate(g: pd.DataFrame | None) -> float:
    k, n = _count(g)
    return k / n if n else float("nan")


def _conf(path, key: str):
    """A value of a config file, ``None`` where the file or the key is not there."""
    return OmegaConf.select(OmegaConf.load(path), key, default=None) if path.is_file() else None


def _hard_intro() -> str:
    offset = _conf(CHALLENGES / "bottle_offset.yaml", "perturbation.object_offset")
    gain = _conf(CHALLENGES / "doorknob_weak.yaml", "perturbation.gain_scale")
    seeds = len(sweep_params(HARD).get("seed", [])) or "the experiment's"
    bottle = f"started {100 * offset:.0f} cm off" if offset is not None else "displaced"
    door = (
        f"the finger servos' gains at {1 - gain:.1f} of the planner's model"
        if gain is not None
        else ("weakened finger servos")
    )
    return (
        "Open-loop replay of the reference completes the paper bottle and doorknob, so those cells cannot "
        "show what closed-loop control adds. `experiment=fig3_paper_hard` runs the two cells where replay "
        "fails (`conf/challenge/`, chosen from a replay-only probe whose records were not kept): the bottle "
        f"{bottle} (`challenge=bottle_offset`) and the doorknob with {door} (`challenge=doorknob_weak`), "
        f"× the three variants × both readings × {seeds} seeds."
    )


def glance(study) -> list[dict]:
    """Per paper task, the full method under the text's reading (the glance table's, ``fidelity=paper``;
    the reading with the highest lower bound of the Wilson 95 % interval of its completion rate, then of
    finishing cleanly, where the records hold more than one)."""
    df = fig3.prepare(study.records())
    df = ok_trials(df[(df["experiment"] != HARD) & (df["variant"] == "full") & (df["fidelity"] == "paper")])
    rows = []
    for task in ordered(df["task"], TASK_ORDER):
        best = None
        for fid in ordered(df["fidelity"], fig3.FIDELITY_ORDER):
            g = df[(df["task"] == task) & (df["fidelity"] == fid)]
            k, n = _count(g)
            c, _ = _count(g, "finished_cleanly")
            key = (wilson(k, n)[0], wilson(c, n)[0]) if n else None
            if n and (best is None or key > best[0]):
                cpu = pd.to_numeric(g["cpu_seconds"], errors="coerce").median()
                best = (key, fid, cpu)
        if best is None:
            continue
        _, fid, cpu = best
        g = df[(df["task"] == task) & (df["fidelity"] == fid)]
        (k, n), (c, _) = _count(g), _count(g, "finished_cleanly")
        rows.append(
            {
                "task": f"paper {task}",
                "configuration": f"`preset=paper_32samples variant=full fidelity={fid}`",
                "completed": f"{k}/{n}",
                "finished cleanly": f"{c}/{n}",
                "median CPU-s per trial": f"{cpu:.0f}",
            }
        )
    return rows
