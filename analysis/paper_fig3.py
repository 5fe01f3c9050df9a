"""Fig. 3 on the paper's tasks under both readings: the paper's text and the authors' code, side by side.

Reads the records of a sweep such as ``experiment=fig3_paper_lite`` and tells each trial's *fidelity*
from its config (the ``fidelity`` node, matched against the members of ``conf/fidelity/``); the fidelity
becomes the trials' ``condition``, so the tables and tests of :mod:`analysis.report` keep the two readings
apart (a variant is compared with ``full`` under the same fidelity; Holm's correction runs over the tests
of each fidelity: each reading is its own experiment). Task names lose their ``paper_`` prefix so that
they sort as in the paper (doorknob, apple, bottle, stapler).

Outputs (:func:`write_fig3`): ``fig3_fidelities.png`` (one panel per fidelity, same axes, the paper's
colours, each box labelled with its completion count), ``fig3_summary.csv`` and ``fig3_tests.csv``
(:func:`analysis.report.summary_table` and :func:`analysis.report.significance_tests`), ``fig3.md``.

Command line::

    python -m analysis.paper_fig3 SWEEP_DIR [SWEEP_DIR ...] --out-dir DIR
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Patch
from omegaconf import OmegaConf

from analysis._cli import run, sweep_parser
from analysis.aggregate import TASK_ORDER, VARIANT_ORDER, load_records, ok_trials, ordered
from analysis.figures import VARIANT_COLORS, VARIANT_LABELS
from analysis.report import significance_tests, summary_table
from analysis.summarize import pipe_table
from contactmpc.records import RECORD_NAME

FIDELITY_DIR = Path(__file__).resolve().parent.parent / "conf" / "fidelity"
#: Order of the fidelities in tables and figures.
FIDELITY_ORDER: tuple[str, ...] = ("paper", "authors_code")
FIDELITY_TITLES = {"paper": "as the paper states it", "authors_code": "as the authors' code runs it"}


def fidelities(directory: Path = FIDELITY_DIR) -> dict[str, dict]:
    """The members of the ``fidelity`` config group: name -> values."""
    return {p.stem: OmegaConf.to_container(OmegaConf.load(p)) for p in sorted(directory.glob("*.yaml"))}


def fidelity_of(config: dict | None, known: dict[str, dict]) -> str:
    """The name of the fidelity whose values a record's config holds (``custom`` if none matches, ``paper``
    for a record from before the group existed)."""
    node = (config or {}).get("fidelity")
    if node is None:
        return "paper"
    for name, values in known.items():
        if all(json.dumps(node.get(k)) == json.dumps(v) for k, v in values.items()):
            return name
    return "custom"


def load(*dirs: str | Path) -> pd.DataFrame:
    """The records of ``dirs`` (:func:`analysis.aggregate.load_records`) with a ``fidelity`` column, the
    fidelity as each trial's ``condition`` and the ``paper_`` prefix dropped from task names."""
    df = load_records(*dirs)
    known = fidelities()
    df["fidelity"] = [
        fidelity_of(json.loads(Path(p).read_text()).get("config"), known) for p in df["record_path"]
    ]
    df["condition"] = df["fidelity"]
    df["task"] = df["task"].str.removeprefix("paper_")
    return df


def fig3(df: pd.DataFrame, path: str | Path | None = None) -> Figure:
    """TTF box plots per task and variant, one panel per fidelity on the same axes (paper Fig. 3 layout:
    tasks top to bottom in the paper's order, the paper's colours), each box labelled ``completed/n``."""
    good = ok_trials(df)
    tasks = ordered(df["task"], TASK_ORDER)
    variants = ordered(df["variant"], VARIANT_ORDER)
    fids = ordered(df["fidelity"], FIDELITY_ORDER)
    fig = Figure(figsize=(5.2 * len(fids), 1.1 + 1.2 * len(tasks)), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, len(fids), sharex=True, sharey=True, squeeze=False)[0]
    width = 0.8 / max(1, len(variants))
    for ax, fid in zip(axes, fids, strict=True):
        for i, task in enumerate(tasks):
            for j, variant in enumerate(variants):
                sel = (good["task"] == task) & (good["variant"] == variant) & (good["fidelity"] == fid)
                ttf = 100.0 * good.loc[sel, "ttf"].dropna().to_numpy(float)
                if not len(ttf):
                    continue
                y = i + (j - (len(variants) - 1) / 2) * width
                color = VARIANT_COLORS.get(variant, "0.5")
                box = ax.boxplot(
                    ttf,
                    positions=[y],
                    widths=width * 0.85,
                    orientation="horizontal",
                    patch_artist=True,
                    manage_ticks=False,
                )
                for patch in box["boxes"]:
                    patch.set(facecolor=color, alpha=0.55, edgecolor=color)
                for key in ("whiskers", "caps"):
                    for line in box[key]:
                        line.set(color=color)
                for line in box["medians"]:
                    line.set(color="orange", linewidth=2.5)
                ax.scatter(ttf, np.full(len(ttf), y), s=10, color=color, zorder=3)
                done = good.loc[sel, "completed"].dropna()
                ax.text(
                    103,
                    y,
                    f"{int(done.sum())}/{len(done)}",
                    va="center",
                    fontsize=7,
                    color=color,
                    clip_on=False,
                )
        ax.set_title(f"fidelity={fid}: {FIDELITY_TITLES.get(fid, fid)}", fontsize=9)
        ax.set_xlim(-3, 112)
        ax.set_xlabel("time to failure, % of the contact span (text: trials completed)")
        ax.set_yticks(range(len(tasks)), tasks)
        ax.grid(axis="x", alpha=0.3)
    axes[0].invert_yaxis()  # shared: once for all panels; tasks top to bottom
    handles = [
        Patch(color=VARIANT_COLORS.get(v, "0.5"), alpha=0.55, label=VARIANT_LABELS.get(v, v))
        for v in variants
    ]
    fig.legend(handles=handles, loc="outside lower center", ncols=len(variants), fontsize=8)
    if path is not None:
        fig.savefig(path, dpi=130)
    return fig


def markdown(df: pd.DataFrame) -> str:
    """The table per task x variant x fidelity (completion, finished cleanly, median TTF and IQR, the
    object's position error over the contact span, after it and over the whole trial, errors) and the
    tests."""
    summary = _in_order(summary_table(df), "condition")
    tests = _in_order(significance_tests(df, family="condition", same_condition=True), "condition")
    lines = [
        "| task | variant | fidelity | completed | finished cleanly | median TTF % (IQR) "
        "| mean object error in span / after span / whole trial (mm) | errors |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in summary.itertuples(index=False):
        done = f"{round(r.completion_rate * r.n)}/{r.n}" if r.n else "0/0"
        done += f" ({r.diverged} diverged)" if r.diverged else ""
        rate = r.finished_cleanly_rate
        clean = f"{round(rate * r.n)}/{r.n}" if np.isfinite(rate) else "—"
        ttf = f"{100 * r.ttf_median:.1f} ({100 * r.ttf_q25:.1f}–{100 * r.ttf_q75:.1f})" if r.n else "—"
        errors = (r.object_position_error_span_mean, r.object_position_error_after_mean)
        err = " / ".join(_mm(e) for e in (*errors, r.object_position_error_mean))
        lines.append(
            f"| {r.task} | {r.variant} | {r.condition} | {done} | {clean} | {ttf} | {err} | {r.errors} |"
        )
    lines += [
        "",
        "Mann–Whitney U (two-sided) of TTF, `full` against each ablation, per task and fidelity (Holm over "
        "the tests of each fidelity, each reading its own experiment; *test*: exact where the samples "
        "have no ties, else the exact permutation distribution, else the normal approximation; effect "
        "sizes: P(full > ablation) = U / nm, the common-language effect "
        "size, and the Hodges–Lehmann shift, the median of the pairwise TTF differences):",
        "",
        "| task | fidelity | ablation | n | median full / ablation % | U | p | Holm p "
        "| P(full > ablation) | HL shift (TTF %) | test |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in tests.itertuples(index=False):
        lines.append(
            f"| {r.task} | {r.condition} | {r.variant} | {r.n_ref} / {r.n_other} | "
            f"{100 * r.median_ref:.1f} / {100 * r.median_other:.1f} | "
            f"{r.U:.1f} | {r.p:.3g} | {r.p_holm:.3g} | {r.prob_superiority:.2f} | "
            f"{100 * r.hl_shift:+.1f} | {r.method} |"
        )
    return "\n".join(lines) + "\n"


def _mm(err: float) -> str:
    """A position error in mm; "—" where none was recorded, or where the task has no free object body
    (the doorknob's slide: its position error is 0)."""
    return f"{1000 * err:.0f}" if np.isfinite(err) and err > 1e-9 else "—"


def _in_order(table: pd.DataFrame, fidelity: str) -> pd.DataFrame:
    """Rows in the paper's task order, then variant order, then :data:`FIDELITY_ORDER`."""
    keys = {
        "task": ordered(table["task"], TASK_ORDER),
        "variant": ordered(table["variant"], VARIANT_ORDER),
        fidelity: ordered(table[fidelity], FIDELITY_ORDER),
    }
    rank = {k: {v: i for i, v in enumerate(vals)} for k, vals in keys.items()}
    return table.sort_values(list(keys), key=lambda col: col.map(rank[col.name]), kind="stable")


def write_fig3(df: pd.DataFrame, out_dir: str | Path) -> Path:
    """Write the figure, the two CSV tables and the markdown report into ``out_dir``; returns it."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    fig3(df, out / "fig3_fidelities.png")
    _in_order(summary_table(df), "condition").to_csv(out / "fig3_summary.csv", index=False)
    _in_order(significance_tests(df, family="condition", same_condition=True), "condition").to_csv(
        out / "fig3_tests.csv", index=False
    )
    (out / "fig3.md").write_text(markdown(df))
    return out


def build_parser() -> argparse.ArgumentParser:
    parser = sweep_parser("python -m analysis.paper_fig3", "Fig. 3 of a sweep under both fidelities.")
    parser.add_argument("--out-dir", required=True, help="where to write the figure and tables")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)

    def action(df: pd.DataFrame) -> str:
        out = write_fig3(df, args.out_dir)
        return f"wrote {out / 'fig3_fidelities.png'}, fig3_summary.csv, fig3_tests.csv, fig3.md"

    return run(args.sweep_dirs, action, (ValueError, OSError), load=load, record_name=RECORD_NAME)


if __name__ == "__main__":
    raise SystemExit(main())


# --- the study's tables (studies/fig3_paper, studies/fig3_lite): labelled statistics, completion tested ---

#: The seed of the bootstrap's generator: a report re-made from the same records gives the same intervals.
BOOTSTRAP_SEED = 20261126
#: Resamples of each bootstrap interval.
BOOTSTRAP_RESAMPLES = 4000
#: Significance level of the tests' readings.
ALPHA = 0.05


def prepare(df: pd.DataFrame) -> pd.DataFrame:
    """Records as :func:`load` tables them, from a table that already has a ``fidelity`` column (e.g.
    :meth:`analysis.study.Study.records`): the fidelity as the ``condition``, the ``paper_`` prefix
    dropped, and a trial run under a ``challenge`` (``conf/challenge``) named ``task [challenge]``."""
    df = df.copy()
    df["condition"] = df["fidelity"]
    df["task"] = df["task"].astype(str).str.removeprefix("paper_")
    if "challenge" in df:
        hard = df["challenge"].notna() & (df["challenge"].astype(str) != "")
        df.loc[hard, "task"] = df.loc[hard, "task"] + " [" + df.loc[hard, "challenge"].astype(str) + "]"
    return df


def cell_table(df: pd.DataFrame) -> str:
    """Per task, variant and fidelity, with each header naming its statistic: completed and finished
    cleanly (counts), median TTF % (IQR), the mean over trials of the object's position error over the
    contact span, after it and over the whole trial (mm), and the records that do not count (errors)."""
    from analysis.summarize import Stat, markdown, summarize

    ok = ok_trials
    stats = [
        Stat("completed", "count", name="completed", where=ok),
        Stat("status", "n", label="diverged", where=lambda g: ok(g)[ok(g)["status"] == "diverged"]),
        Stat("finished_cleanly", "count", name="finished cleanly", where=ok),
        Stat("ttf", "median_iqr", name="TTF %", scale=100, where=ok),
        *[
            Stat(col, "mean", name=col, scale=1000, digits=0, where=ok)
            for col in (
                "object_position_error_span_mean",
                "object_position_error_after_mean",
                "object_position_error_mean",
            )
        ],
        Stat("status", "n", label="errors", where=lambda g: g.drop(ok(g).index)),
    ]
    t = summarize(
        df,
        by=["task", "variant", "fidelity"],
        stats=stats,
        order={"task": TASK_ORDER, "variant": VARIANT_ORDER, "fidelity": FIDELITY_ORDER},
    )
    t["completed"] = [
        f"{c} ({d} diverged)" if d else c for c, d in zip(t["completed"], t["diverged"], strict=True)
    ]
    errs = [s for s in stats if s.column.startswith("object_")]
    t["mean object error in span / after span / whole trial (mm)"] = [
        " / ".join(_mm(v / 1000) for v in vals) for vals in zip(*(t[s.header] for s in errs), strict=True)
    ]
    stats_by = t.attrs["stats"]
    t = t[
        [
            "task",
            "variant",
            "fidelity",
            "completed",
            "finished cleanly",
            "median (IQR) TTF %",
            "mean object error in span / after span / whole trial (mm)",
            "errors",
        ]
    ]
    t.attrs["stats"] = {k: v for k, v in stats_by.items() if k in t.columns and k != "completed"}
    return markdown(t, align="lll" + "rrrrr")


def ttf_tests(df: pd.DataFrame, rng: np.random.Generator, alpha: float = ALPHA) -> pd.DataFrame:
    """:func:`analysis.report.significance_tests` of TTF per fidelity (Holm within each), with percentile
    bootstrap 95 % intervals over trials of P(full > ablation) and of the Hodges–Lehmann shift
    (``ps_lo``, ``ps_hi``, ``hl_lo``, ``hl_hi``), drawn from ``rng`` in the table's order, and
    ``testable`` (the smallest attainable p is below ``alpha``)."""
    from analysis.inference import bootstrap_effects

    tests = _in_order(significance_tests(df, family="condition", same_condition=True), "condition")
    good = ok_trials(df)
    cis = []
    for r in tests.itertuples(index=False):
        a, b = (
            good.loc[
                (good["task"] == r.task) & (good["variant"] == v) & (good["fidelity"] == r.condition), "ttf"
            ].to_numpy(float)
            for v in (r.reference, r.variant)
        )
        (p_lo, p_hi), (s_lo, s_hi) = bootstrap_effects(a, b, rng, BOOTSTRAP_RESAMPLES)
        cis.append((p_lo, p_hi, s_lo, s_hi))
    tests[["ps_lo", "ps_hi", "hl_lo", "hl_hi"]] = pd.DataFrame(cis, index=tests.index, dtype=float)
    tests["testable"] = tests["p_min"] < alpha
    return tests


def completion_tests(df: pd.DataFrame, reference: str = "full", alpha: float = ALPHA) -> pd.DataFrame:
    """Completion of ``reference`` against each other variant, per task and fidelity: the counts, the
    difference in completion rate with Newcombe's 95 % interval, Barnard's exact two-sided p, its
    smallest attainable p at these n, and Holm's adjustment within each fidelity."""
    from analysis.inference import completion_test, newcombe
    from analysis.report import holm

    good = ok_trials(df)
    done = good[good["completed"].notna()]
    rows = []
    for fid in ordered(df["fidelity"], FIDELITY_ORDER):
        for task in ordered(df["task"], TASK_ORDER):
            cell = done[(done["task"] == task) & (done["fidelity"] == fid)]
            if reference not in set(cell["variant"]):
                continue
            ref = cell.loc[cell["variant"] == reference, "completed"].astype(bool)
            for variant in ordered(cell["variant"], VARIANT_ORDER):
                if variant == reference:
                    continue
                other = cell.loc[cell["variant"] == variant, "completed"].astype(bool)
                k1, n1, k2, n2 = int(ref.sum()), len(ref), int(other.sum()), len(other)
                p, p_min = completion_test(k1, n1, k2, n2)
                d, lo, hi = newcombe(k1, n1, k2, n2)
                rows.append(
                    dict(
                        task=task,
                        fidelity=fid,
                        variant=variant,
                        k_ref=k1,
                        n_ref=n1,
                        k_other=k2,
                        n_other=n2,
                        delta=d,
                        delta_lo=lo,
                        delta_hi=hi,
                        p=p,
                        p_min=p_min,
                    )
                )
    cols = [
        "task",
        "fidelity",
        "variant",
        "k_ref",
        "n_ref",
        "k_other",
        "n_other",
        "delta",
        "delta_lo",
        "delta_hi",
        "p",
        "p_min",
    ]
    out = pd.DataFrame(rows, columns=cols)
    out["p_holm"] = (
        out.groupby("fidelity", sort=False)["p"].transform(lambda p: holm(p.to_numpy())) if len(out) else []
    )
    out["testable"] = out["p_min"] < alpha
    return _in_order(out.rename(columns={"fidelity": "condition"}), "condition").rename(
        columns={"condition": "fidelity"}
    )


def _pv(p: float, testable: bool = True) -> str:
    if not np.isfinite(p):
        return "—"
    return f"{p:.3g}" if testable else f"{p:.3g}*"


#: The columns of :func:`ttf_tests_markdown`.
TTF_TEST_COLUMNS = (
    "task", "fidelity", "ablation", "n full / ablation", "median TTF % full / ablation", "U", "p", "Holm p",
    "smallest attainable p", "P(full > ablation) [95 % CI]", "HL shift, TTF % [95 % CI]", "test",
)  # fmt: skip


def ttf_tests_markdown(tests: pd.DataFrame) -> str:
    """The TTF tests as a pipe table (medians labelled; intervals 95 % bootstrap; ``*``: too few to test)."""
    return pipe_table(TTF_TEST_COLUMNS, "lllrrrrrrrrl", map(_ttf_test_row, tests.itertuples(index=False)))


def _ttf_test_row(r) -> str:
    if not (r.n_ref and r.n_other):
        return (
            f"| {r.task} | {r.condition} | {r.variant} | {r.n_ref} / {r.n_other} | — | — | — | — "
            "| — | — | — | not tested |"
        )
    t = r.testable
    return (
        f"| {r.task} | {r.condition} | {r.variant} | {r.n_ref} / {r.n_other} | "
        f"{100 * r.median_ref:.1f} / {100 * r.median_other:.1f} | {r.U:.1f} | {_pv(r.p, t)} | "
        f"{_pv(r.p_holm, t)} | {_pv(r.p_min)} | "
        f"{r.prob_superiority:.2f} [{r.ps_lo:.2f}, {r.ps_hi:.2f}] | "
        f"{100 * r.hl_shift:+.1f} [{100 * r.hl_lo:+.1f}, {100 * r.hl_hi:+.1f}] | "
        f"{r.method if t else 'too few to test'} |"
    )


#: The columns of :func:`completion_tests_markdown`.
COMPLETION_TEST_COLUMNS = (
    "task", "fidelity", "ablation", "completed full / ablation",
    "difference in completion rate, points [95 % CI]", "Barnard p", "Holm p", "smallest attainable p",
)  # fmt: skip


def completion_tests_markdown(tests: pd.DataFrame) -> str:
    """The completion tests as a pipe table (``*``: too few to test)."""
    rows = map(_completion_test_row, tests.itertuples(index=False))
    return pipe_table(COMPLETION_TEST_COLUMNS, "lllrrrrr", rows)


def _completion_test_row(r) -> str:
    t = r.testable
    return (
        f"| {r.task} | {r.fidelity} | {r.variant} | {r.k_ref}/{r.n_ref} / {r.k_other}/{r.n_other} | "
        f"{100 * r.delta:+.0f} [{100 * r.delta_lo:+.0f}, {100 * r.delta_hi:+.0f}] | {_pv(r.p, t)} | "
        f"{_pv(r.p_holm, t)} | {_pv(r.p_min)} |"
    )
