"""Fig. 3 under both fidelities (analysis.paper_fig3) and its notebook, on records written here."""

from __future__ import annotations

import copy
import json
import os
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

from analysis.paper_fig3 import fidelities, fidelity_of, load, markdown, write_fig3
from tests.test_analysis import make_record

REPO = Path(__file__).resolve().parent.parent
TTF = {  # fidelity -> variant -> TTF per seed
    "paper": {
        "full": [1.0, 0.9, 1.0, 0.8],
        "no_contact": [0.3, 0.2, 0.4, 0.3],
        "joint_space": [0.9, 1.0, 0.7, 1.0],
    },
    "authors_code": {
        "full": [0.6, 0.5, 0.7, 0.6],
        "no_contact": [0.5, 0.6, 0.4, 0.5],
        "joint_space": [0.1, 0.2, 0.1, 0.2],
    },
}


@pytest.fixture(scope="module")
def sweep(tmp_path_factory) -> Path:
    """Records of the four paper tasks x 3 variants x 2 fidelities x 4 seeds, each config holding its
    fidelity node as conf/fidelity/<name>.yaml sets it."""
    root = tmp_path_factory.mktemp("fig3") / "sweep"
    root.mkdir()
    (root / "multirun.yaml").write_text("hydra: {}\n")
    known = fidelities()
    job = 0
    for fid, variants in TTF.items():
        for task in ("paper_stapler", "paper_apple", "paper_bottle", "paper_doorknob"):
            for variant, ttfs in variants.items():
                for seed, ttf in enumerate(ttfs):
                    record = make_record(task, variant, seed, ttf)
                    record["config"]["fidelity"] = copy.deepcopy(known[fid])
                    (root / str(job)).mkdir()
                    (root / str(job) / "trial.json").write_text(json.dumps(record))
                    job += 1
    return root


def test_fidelity_is_read_from_the_config() -> None:
    known = fidelities()
    assert set(known) == {"paper", "authors_code"}
    assert fidelity_of({"fidelity": known["authors_code"]}, known) == "authors_code"
    assert fidelity_of({}, known) == "paper"  # a record from before the group existed
    assert fidelity_of({"fidelity": dict(known["paper"], pc_sigma2=0.5)}, known) == "custom"


def test_tables_keep_the_fidelities_apart(sweep: Path, tmp_path: Path) -> None:
    df = load(sweep)
    assert set(df["fidelity"]) == {"paper", "authors_code"}
    assert list(dict.fromkeys(df.sort_values("task", key=lambda s: s.map({"doorknob": 0, "apple": 1})).task))
    out = write_fig3(df, tmp_path / "out")
    assert (out / "fig3_fidelities.png").stat().st_size > 10_000
    tests = json.loads(
        json.dumps(
            list(
                map(
                    list,
                    __import__("pandas")
                    .read_csv(out / "fig3_tests.csv")[["task", "condition", "variant"]]
                    .itertuples(index=False),
                )
            )
        )
    )
    assert len(tests) == 4 * 2 * 2  # per task and fidelity: full vs no_contact, full vs joint_space
    assert all(cond in ("paper", "authors_code") for _, cond, _ in tests)
    text = markdown(df)
    first = [line for line in text.splitlines() if line.startswith("| doorknob")][0]
    assert "| doorknob | full | paper |" in first  # paper task order, prefix dropped


KEPT = REPO / "studies" / "fig3_paper" / "records"  # the kept records of experiment=fig3_paper


@pytest.mark.parametrize(
    "which",
    [
        "constructed",
        pytest.param(
            "kept",
            marks=pytest.mark.skipif(not list(KEPT.glob("*/trial.json")), reason="fig3_paper not kept"),
        ),
    ],
)
def test_notebook_runs_on_the_sweep(which: str, sweep: Path, tmp_path: Path) -> None:
    nb = nbformat.read(REPO / "analysis" / "paper_fig3.ipynb", as_version=4)
    data = sweep if which == "constructed" else KEPT
    env = {"CONTACTMPC_FIG3_SWEEP": str(data), "CONTACTMPC_FIG3_OUT": str(tmp_path / "nb")}
    old = {k: os.environ.get(k) for k in env}
    os.environ.update(env)
    try:
        NotebookClient(
            nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(REPO / "analysis")}}
        ).execute()
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
    assert (tmp_path / "nb" / "fig3_fidelities.png").exists()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert any(o.get("output_type") == "display_data" and "image/png" in o.get("data", {}) for o in outputs)
    assert not [o for o in outputs if o.get("output_type") == "error"]


def test_each_reading_is_its_own_family_and_never_tested_against_the_other(sweep: Path) -> None:
    from analysis.report import holm, significance_tests

    df = load(sweep)
    tests = significance_tests(df, family="condition", same_condition=True)
    for fid, group in tests.groupby("condition"):
        assert len(group) == 8, fid  # 4 tasks x 2 ablations
        assert list(group["p_holm"]) == list(holm(group["p"].to_numpy()))
    # a reading missing a cell (authors_code apple no_contact) is not tested against the other reading
    gone = (df["fidelity"] == "authors_code") & (df["task"] == "apple") & (df["variant"] == "no_contact")
    partial = df[~gone]
    tests = significance_tests(partial, family="condition", same_condition=True)
    assert (tests["reference_condition"] == tests["condition"]).all() and len(tests) == 15
