"""The analysis package on synthetic records laid out like a Hydra multirun sweep (fast, no simulation)."""

from __future__ import annotations

import copy
import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from matplotlib.image import imread

from analysis import aggregate, figures, report
from analysis.aggregate import RecordWarning, load_records, variant_name
from analysis.figures import ttf_boxplot
from analysis.report import holm, markdown_report, significance_tests, summary_table
from contactmpc.records import write_json

REPO_ROOT = Path(__file__).resolve().parents[1]
TASKS = ("apple", "bottle", "stapler", "doorknob")
# variant -> (cost, sampler, planner, TTF of the trials)
VARIANTS = {
    "full": ("contact", "pca_spline", "predictive_sampling", [1.0, 1.0, 0.95, 1.0, 0.9, 1.0]),
    "no_contact": ("object_only", "pca_spline", "predictive_sampling", [0.3, 0.4, 0.2, 0.5, 0.35, 0.25]),
    "joint_space": ("contact", "joint_spline", "predictive_sampling", [0.1, 0.05, 0.2, 0.15, 0.0, 0.1]),
}
SEEDS = range(6)


def make_record(task: str, variant: str, seed: int, ttf: float, **extra) -> dict:
    cost, sampler, planner, _ = VARIANTS.get(variant, ("contact", "pca_spline", variant, None))
    record = {
        "schema": 1,
        "task": task,
        "hand": "allegro",
        "cost": cost,
        "sampler": sampler,
        "planner": planner,
        "preset": "lite",
        "experiment": "ablation",
        "seed": seed,
        "status": "ok",
        "ttf": ttf,
        "failed": ttf < 1.0,
        "failure_time": None if ttf >= 1.0 else 1.0 + ttf,
        "contact_span_start": 0.5,
        "contact_span_end": 3.5,
        "completed": ttf >= 0.95,
        "object_position_error_mean": 0.01 + 0.02 * (1.0 - ttf),
        "object_rotation_error_mean": 0.1,
        "object_articulation_error_mean": 0.0,
        "final_object_position_error": float("nan"),  # stored as null
        "final_object_rotation_error": 0.2,
        "final_object_articulation_error": 0.0,
        "contact_fraction": 0.8,
        "plan_seconds_mean": 0.01,
        "plan_seconds_p95": 0.02,
        "simulated_seconds": 4.0,
        "wall_seconds": 40.0,
        "real_time_factor": 0.1,
        "num_control_points": 10,
        "num_plans": 400,
        "diverged_rollouts": 0,
        "versions": {"contactmpc": "0.1.0", "numpy": "2.0"},
        "git_revision": "abc123",
        "config": {
            "seed": seed,
            "duration": None,
            "planner": {"num_samples": 128, "horizon": 2.5, "replan_period": 0.01, "nthread": 2},
            "cost": {"lambda_o": 1.0, "lambda_c": 0.0 if cost == "object_only" else 1.0, "lambda_v": 0.01},
            "job": {"progress": False, "duration": None, "failure_gap": 0.3},
            "output_dir": f"outputs/sweeps/x/task={task},variant={variant},seed={seed}",
        },
    }
    record.update(extra)
    return record


def with_config(record: dict, **values) -> dict:
    """``record`` with config values set by dotted key (``**{"cost.lambda_v": 0.001}``)."""
    record = copy.deepcopy(record)
    for key, value in values.items():
        *path, last = key.split(".")
        node = record["config"]
        for part in path:
            node = node[part]
        node[last] = value
    return record


@pytest.fixture(scope="module")
def sweep(tmp_path_factory) -> Path:
    """``sweep/<job>/trial.json`` for 4 tasks × 3 variants × 6 seeds, plus: one error record, one
    unreadable file, an older duplicate of a trial, and a non-paper variant (mppi)."""
    root = tmp_path_factory.mktemp("analysis") / "sweep"
    root.mkdir()
    (root / "multirun.yaml").write_text("hydra: {}\n")
    job = 0
    for task in TASKS:
        for variant, (*_, ttfs) in VARIANTS.items():
            for seed in SEEDS:
                write_json(root / str(job) / "trial.json", make_record(task, variant, seed, ttfs[seed]))
                job += 1
    # a trial that crashed: counts as an error, not for TTF
    error = make_record("stapler", "joint_space", 6, 0.0, status="error", error="PlantDiverged: nan")
    for key in ("ttf", "failed", "failure_time", "completed", "object_position_error_mean"):
        error.pop(key)
    write_json(root / str(job) / "trial.json", error)
    job += 1
    # a record without "completed" (older schema) of another planner
    mppi = make_record("apple", "mppi", 0, 0.5)
    mppi.pop("completed")
    write_json(root / str(job) / "trial.json", mppi)
    job += 1
    # a second run of apple/full seed 0 (another output_dir and thread count: the same trial) with a
    # newer modification time: it wins
    rerun = make_record("apple", "full", 0, 0.77)
    newer = root / "rerun" / "trial.json"
    write_json(newer, with_config(rerun, output_dir="elsewhere", **{"planner.nthread": 1}))
    old = root / "0" / "trial.json"
    os.utime(old, (1_000_000_000, 1_000_000_000))
    # an unreadable (truncated) record
    (root / "broken").mkdir()
    (root / "broken" / "trial.json").write_text('{"task": "apple", "ttf": 0.')
    return root


@pytest.fixture(scope="module")
def table(sweep) -> pd.DataFrame:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        df = load_records(sweep)
    messages = sorted(str(w.message) for w in caught if issubclass(w.category, RecordWarning))
    assert len(messages) == 2, messages
    assert re.search(r"broken.trial\.json", messages[0])
    assert re.search(
        r"same trial .* 2 times: keeping the newest, .*rerun.trial\.json; dropping .*0.trial", messages[1]
    )
    return df


def test_variant_name():
    assert variant_name("predictive_sampling", "contact", "pca_spline") == "full"
    assert variant_name("predictive_sampling", "object_only", "pca_spline") == "no_contact"
    assert variant_name("predictive_sampling", "contact", "joint_spline") == "joint_space"
    assert variant_name("predictive_sampling", "object_only", "joint_spline") == (
        "predictive_sampling/object_only/joint_spline"
    )
    assert variant_name("mppi", "contact", "pca_spline") == "mppi/contact/pca_spline"
    assert variant_name(None, "contact", "pca_spline") == "?/contact/pca_spline"


def test_load_records_rows_and_columns(table, sweep):
    # 72 trials + error + mppi; the older duplicate and the broken file are gone
    assert len(table) == 4 * 3 * 6 + 2
    for col in (
        "variant",
        "record_path",
        "sweep_dir",
        "num_samples",
        "horizon",
        "replan_period",
        "ttf",
        "seed",
    ):
        assert col in table
    assert "config" not in table and "versions" not in table
    assert set(table["variant"]) == {"full", "no_contact", "joint_space", "mppi/contact/pca_spline"}
    assert set(table["sweep_dir"]) == {str(sweep.resolve())}
    assert table["num_samples"].eq(128).all() and table["horizon"].eq(2.5).all()
    assert table["final_object_position_error"].isna().all()  # NaN written as null, read as NaN
    # paper task order, then variant order
    assert list(dict.fromkeys(table["task"])) == ["doorknob", "apple", "bottle", "stapler"]
    assert list(dict.fromkeys(table.loc[table["task"] == "apple", "variant"]))[:3] == list(VARIANTS)
    # the newest duplicate is kept
    dup = table[(table["task"] == "apple") & (table["variant"] == "full") & (table["seed"] == 0)]
    assert len(dup) == 1 and dup["ttf"].iloc[0] == pytest.approx(0.77)
    assert dup["record_path"].iloc[0].endswith(os.path.join("rerun", "trial.json"))
    # the error record is there, without TTF
    err = table[table["status"] == "error"]
    assert len(err) == 1 and err["task"].iloc[0] == "stapler" and np.isnan(err["ttf"].iloc[0])
    assert table.loc[table["variant"] == "mppi/contact/pca_spline", "completed"].isna().all()


def test_load_records_keeps_duplicates_on_request(sweep):
    with pytest.warns(RecordWarning):
        assert len(load_records(sweep, dedupe=False)) == 4 * 3 * 6 + 3


def test_overlapping_dirs_and_sweep_root(sweep):
    # the parent of the sweep and the sweep itself: each file counted once, sweep_dir is the sweep root
    with pytest.warns(RecordWarning):
        df = load_records(sweep.parent, sweep)
    assert len(df) == 4 * 3 * 6 + 2
    assert set(df["sweep_dir"]) == {str(sweep.resolve())}


def test_a_record_read_again_is_a_copy_of_its_texts_row(tmp_path):
    """:func:`read_record` makes a text's row once: a caller's change to it stays its own, and a record
    rewritten in place is read anew."""
    path = tmp_path / "trial.json"
    write_json(path, make_record("apple", "full", 0, 1.0))
    first = aggregate.read_record(path)
    first["ttf"] = -1.0
    first["_config"]["seed"] = -1
    again = aggregate.read_record(path)
    assert again["ttf"] == 1.0 and again["_config"]["seed"] == 0 and again["trial_id"] == first["trial_id"]
    write_json(path, make_record("apple", "full", 0, 0.5))
    assert aggregate.read_record(path)["ttf"] == 0.5


def test_missing_directory(tmp_path):
    with pytest.raises(FileNotFoundError):
        load_records(tmp_path / "nope")
    empty = load_records(tmp_path)
    assert len(empty) == 0 and "variant" in empty


def test_summary_and_tests(table):
    summary = summary_table(table)
    row = summary[(summary["task"] == "stapler") & (summary["variant"] == "joint_space")].iloc[0]
    assert row["n"] == 6 and row["errors"] == 1 and row["trials"] == 7
    full = summary[(summary["task"] == "bottle") & (summary["variant"] == "full")].iloc[0]
    assert full["completion_rate"] == pytest.approx(5 / 6)
    assert full["ttf_median"] == pytest.approx(1.0)
    mppi = summary[summary["variant"] == "mppi/contact/pca_spline"].iloc[0]
    assert np.isnan(mppi["completion_rate"])

    tests = significance_tests(table)
    # every task: full vs no_contact and joint_space; apple also vs mppi
    assert len(tests) == 4 * 2 + 1
    sig = tests[tests["variant"] != "mppi/contact/pca_spline"]
    assert (sig["p"] < 0.01).all() and (sig["prob_superiority"] > 0.9).all()
    assert sig["reading"].str.contains("full lasts longer").all()
    assert (tests["p_holm"] >= tests["p"]).all()


def test_holm():
    np.testing.assert_allclose(holm([0.01, 0.04, 0.03, np.nan]), [0.03, 0.06, 0.06, np.nan])


def test_ttf_boxplot(table, tmp_path):
    path = tmp_path / "fig3.png"
    fig = ttf_boxplot(table, path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    img = imread(path)
    assert img.shape[0] > 300 and img.shape[1] > 600
    assert len(np.unique(img.reshape(-1, img.shape[-1]), axis=0)) > 50  # not a blank canvas
    ax = fig.axes[0]
    assert [t.get_text() for t in ax.get_xticklabels()] == ["doorknob", "apple", "bottle", "stapler"]
    assert ax.get_ylim() == pytest.approx((-3, 103))
    texts = [t.get_text() for t in ax.texts]
    assert texts.count("n=6") == 4 * 3 and "n=1" in texts
    note = " ".join(fig.get_supxlabel().split())  # trials that do not count for TTF are named there
    assert "stapler/joint_space: 1 error" in note


def test_markdown_report(table):
    md = markdown_report(table, figure="fig3.png")
    for task in TASKS:
        assert f"| {task} | full |" in md
    for p in significance_tests(table)["p"]:
        assert f"{p:.3g}" in md
    assert "Mann–Whitney" in md and "![" in md and "full vs no_contact" in md


def test_module_clis_in_process(sweep, tmp_path, capsys):
    out = tmp_path / "cli"
    assert aggregate.main([str(sweep), "--out", str(out / "results.csv")]) == 0
    csv = pd.read_csv(out / "results.csv")
    assert len(csv) == 4 * 3 * 6 + 2 and "variant" in csv
    assert figures.main([str(sweep), "--out", str(out / "fig.png")]) == 0
    assert (out / "fig.png").stat().st_size > 10_000
    args = [
        str(sweep),
        "--out",
        str(out / "r.md"),
        "--csv",
        str(out / "r.csv"),
        "--figure",
        str(out / "f.png"),
    ]
    assert report.main(args) == 0
    assert "](f.png)" in (out / "r.md").read_text() and (out / "r.csv").exists() and (out / "f.png").exists()
    err = capsys.readouterr().err
    assert "warning: skipping unreadable record" in err and "broken" in err


def test_parquet_needs_pyarrow(sweep, tmp_path, capsys):
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        assert aggregate.main([str(sweep), "--out", str(tmp_path / "r.parquet")]) == 2
        assert "pyarrow" in capsys.readouterr().err
    else:
        assert aggregate.main([str(sweep), "--out", str(tmp_path / "r.parquet")]) == 0
        assert len(pd.read_parquet(tmp_path / "r.parquet")) == 4 * 3 * 6 + 2


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, *args], cwd=REPO_ROOT, capture_output=True, text=True, timeout=120, check=False
    )


def test_umbrella_cli(sweep, tmp_path):
    out = tmp_path / "results"
    proc = _run("-m", "analysis", str(sweep), "--out-dir", str(out))
    assert proc.returncode == 0, proc.stderr
    assert {p.name for p in out.iterdir()} == {"results.csv", "fig3.png", "results.md"}
    md = (out / "results.md").read_text()
    assert all(task in md for task in TASKS) and "](fig3.png)" in md


def test_cli_bad_directory(tmp_path):
    proc = _run("-m", "analysis", str(tmp_path / "missing"), "--out-dir", str(tmp_path / "out"))
    assert proc.returncode != 0
    assert proc.stderr.startswith("error:") and len(proc.stderr.strip().splitlines()) == 1
    assert "missing" in proc.stderr and not (tmp_path / "out").exists()
    (tmp_path / "empty").mkdir()
    proc = _run("-m", "analysis.report", str(tmp_path / "empty"), "--out", str(tmp_path / "r.md"))
    assert proc.returncode != 0 and proc.stderr.startswith("error: no readable trial.json")


def test_import_is_cheap():
    proc = _run("-c", "import sys, analysis; assert 'matplotlib' not in sys.modules; analysis.load_records")
    assert proc.returncode == 0, proc.stderr


# ------------------------------------------------------------------- distinct trials are kept apart


def _load_quietly(*dirs) -> pd.DataFrame:
    """``load_records`` that fails on any warning: no record here is a duplicate."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return load_records(*dirs)


@pytest.fixture
def conditions_sweep(tmp_path) -> Path:
    """apple: full under three conditions (two durations, two velocity weights), no_contact under one."""
    root = tmp_path / "sweep"
    full, no_contact = VARIANTS["full"][-1], VARIANTS["no_contact"][-1]
    for seed in range(3):
        base = make_record("apple", "full", seed, full[seed])
        write_json(root / f"base{seed}" / "trial.json", base)
        longer = with_config(make_record("apple", "full", seed, 0.5), duration=2.0, **{"job.duration": 2.0})
        write_json(root / f"long{seed}" / "trial.json", longer)
        slow = with_config(make_record("apple", "full", seed, 0.6), **{"cost.lambda_v": 0.001})
        write_json(root / f"lv{seed}" / "trial.json", slow)
        write_json(
            root / f"nc{seed}" / "trial.json", make_record("apple", "no_contact", seed, no_contact[seed])
        )
    return root


def test_trials_that_differ_in_config_are_kept_apart(conditions_sweep):
    """Records that differ in ``duration`` or a cost weight are different trials: none is dropped, the
    differing values become columns and the condition, and no duplicate is reported."""
    df = _load_quietly(conditions_sweep)
    assert len(df) == 12
    assert {"duration", "cost.lambda_v"} <= set(df.columns)
    assert "job.duration" not in df and "output_dir" not in df and "seed" in df
    full = df[df["variant"] == "full"]
    assert sorted(set(full["condition"])) == [
        "cost.lambda_v=0.001, duration=null",
        "cost.lambda_v=0.01, duration=2.0",
        "cost.lambda_v=0.01, duration=null",
    ]
    assert full.groupby("condition").size().eq(3).all()
    assert set(df.loc[df["variant"] == "no_contact", "condition"]) == {""}  # one condition: no label
    assert set(df["duration"].dropna()) == {2.0} and set(df["cost.lambda_v"]) == {0.01, 0.001}
    assert df["trial_id"].nunique() == 12


def test_tables_figures_and_tests_group_by_condition(conditions_sweep, tmp_path):
    df = _load_quietly(conditions_sweep)
    summary = summary_table(df)
    assert list(zip(summary["variant"], summary["n"], strict=True)) == [("full", 3)] * 3 + [("no_contact", 3)]
    longer = summary[summary["condition"] == "cost.lambda_v=0.01, duration=2.0"].iloc[0]
    assert longer["ttf_median"] == pytest.approx(0.5)
    tests = significance_tests(df)
    # each condition of full against no_contact's only one; never pooled
    assert len(tests) == 3 and set(tests["condition"]) == {""} and tests["n_ref"].eq(3).all()
    md = markdown_report(df)
    assert "| apple | full | cost.lambda_v=0.01, duration=2.0 | 3 |" in md
    assert "full [cost.lambda_v=0.001, duration=null] vs no_contact" in md
    fig = ttf_boxplot(df, tmp_path / "fig.png")
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert len(labels) == 4 and sum("duration=2.0" in label for label in labels) == 1
    assert [t.get_text() for t in fig.axes[0].texts].count("n=3") == 4


def test_the_same_trial_in_two_sweeps_is_one_row_and_a_warning(tmp_path):
    """Only the paths and timings differ (output_dir, planner.nthread, job.progress, the sweep): the
    same trial, kept once (the newest), with a warning naming both records."""
    record = make_record("bottle", "full", 3, 0.9)
    old = write_json(tmp_path / "a" / "0" / "trial.json", record)
    os.utime(old, (1_000_000_000, 1_000_000_000))
    again = with_config(
        make_record("bottle", "full", 3, 0.8, wall_seconds=12.0),
        output_dir="b/0",
        **{"planner.nthread": 16, "job.progress": True},
    )
    new = write_json(tmp_path / "b" / "0" / "trial.json", again)
    for d in ("a", "b"):
        (tmp_path / d / "multirun.yaml").write_text("hydra: {}\n")
    with pytest.warns(RecordWarning, match="same trial") as caught:
        df = load_records(tmp_path)
    assert len(df) == 1 and df["ttf"].iloc[0] == pytest.approx(0.8)
    assert str(new.resolve()) in str(caught[0].message) and str(old.resolve()) in str(caught[0].message)
    assert set(df["condition"]) == {""}


def test_a_records_variant_label_names_its_variant(tmp_path):
    """variant=wrist_acquire has full's cost and sampler choices: its label, not the choices, names it."""
    for seed in (1, 2):  # (real records differ in their sampler config too; here, in the seed)
        record = make_record("apple", "full", seed, 1.0) | {"variant": "wrist_acquire"}
        write_json(tmp_path / f"w{seed}" / "trial.json", record)
    write_json(tmp_path / "f0" / "trial.json", make_record("apple", "full", 0, 1.0))
    df = load_records(tmp_path)
    assert sorted(df["variant"]) == ["full", "wrist_acquire", "wrist_acquire"]


def test_a_records_processor_is_its_host_s_family_and_model_where_it_has_one(tmp_path):
    """processor: the host's name for the processor (brand, family, model), which tells apart two of one
    brand string; a record without a host keeps its brand string."""
    for seed, model in ((1, "family 25, model 1"), (2, "family 26, model 2")):
        record = make_record("apple", "full", seed, 1.0) | {"cpu": "AMD EPYC"}
        write_json(tmp_path / f"r{seed}" / "trial.json", record | {"host": {"cpu": f"AMD EPYC ({model})"}})
    write_json(tmp_path / "r0" / "trial.json", make_record("apple", "full", 0, 1.0) | {"cpu": "AMD EPYC"})
    df = load_records(tmp_path).set_index("seed")
    assert df.loc[1, "processor"] != df.loc[2, "processor"] and (df["cpu"] == "AMD EPYC").all()
    assert df.loc[2, "processor"] == "AMD EPYC (family 26, model 2)" and df.loc[0, "processor"] == "AMD EPYC"


def test_mann_whitney_is_exact_with_and_without_ties_and_six_seeds_can_pass_holm_over_eight():
    """No ties: scipy's exact U distribution; ties (every completed trial has TTF 1), one trial a side
    included: the exact permutation distribution, which for fully separated 6 vs 6 samples is
    2 / C(12, 6) either way; 6 seeds per cell can then pass Holm over 8 tests at 0.05 and 5 cannot. The
    Hodges-Lehmann shift is the median pairwise difference."""
    from math import comb

    from analysis.report import hodges_lehmann, mann_whitney

    low = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    u, p, method = mann_whitney(low + 0.55, low)
    assert method == "exact" and u == 36 and p == pytest.approx(2 / comb(12, 6))
    u, p, method = mann_whitney(np.ones(6), low)
    assert method == "exact permutation" and u == 36 and p == pytest.approx(2 / comb(12, 6))
    assert 8 * p < 0.05 and 8 * mann_whitney(np.ones(5), low[:5])[1] > 0.05
    _, p_same, _ = mann_whitney(np.ones(6), np.ones(6))
    assert p_same == pytest.approx(1.0)
    tied = np.append(low, 1.0)
    # ties and one trial a side: still the exact permutation distribution (8 arrangements, the observed
    # U = 6.5 and one other as large: p = 2 x 2/8), never the normal approximation on small samples
    assert mann_whitney(np.ones(1), tied)[1:] == (pytest.approx(0.5), "exact permutation")
    assert mann_whitney(np.ones(6), np.array([0.152]))[1:] == (pytest.approx(2 / 7), "exact permutation")
    assert hodges_lehmann(np.ones(6), low) == pytest.approx(np.median(1 - low))
    assert hodges_lehmann(low, low) == pytest.approx(0.0)
