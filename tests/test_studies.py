"""The studies (``studies/<name>/``): each report is what its records make, and the framework's pieces
(``analysis.summarize``, ``analysis.study``) do what they say."""

from __future__ import annotations

import math

import pandas as pd
import pytest

from analysis import study as study_mod
from analysis.study import README, STUDIES, Study, glance_table, index, names, with_glance
from analysis.summarize import Fmt, Stat, markdown, summarize
from contactmpc.records import write_json

NAMES = names()


@pytest.mark.parametrize("name", NAMES)
def test_report_is_what_its_records_make(name: str) -> None:
    """The committed ``studies/<name>/README.md`` is what ``python -m analysis.study <name>`` makes."""
    study = Study(name)
    committed = (study.dir / "README.md").read_text()
    assert study.render() == committed, f"stale report: run python -m analysis.study {name}"


def test_index_lists_every_study() -> None:
    assert (STUDIES / "README.md").read_text() == index(), "stale index: run python -m analysis.study"


def test_readme_glance_table_is_current() -> None:
    text = README.read_text()
    if study_mod.GLANCE_BEGIN not in text:
        pytest.skip("README.md has no results-at-a-glance block")
    assert with_glance(text, glance_table()) == text, "stale glance table: python -m analysis.study --readme"


def test_a_readme_without_the_glance_block_is_refused() -> None:
    with pytest.raises(ValueError, match="glance"):
        with_glance("# README\n", "| t |\n")


def test_an_unknown_study_is_one_line_and_exit_2(capsys) -> None:
    assert study_mod.main(["no_such_study"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no such study: no_such_study" in err


def _records() -> pd.DataFrame:
    return pd.DataFrame(
        {
            "task": ["b", "a", "a", "a", "b"],
            "variant": ["x", "y", "x", "x", "x"],
            "completed": [True, False, True, None, False],
            "ttf": [0.5, 0.2, 1.0, 0.4, 0.1],
        }
    )


def test_summarize_groups_in_the_given_order_and_labels_the_statistic() -> None:
    table = summarize(
        _records(),
        by=["task", "variant"],
        stats=[
            Stat("completed", "count", name="completed"),
            Stat("ttf", "median", name="TTF %", scale=100),
            Stat("ttf", "mean", name="TTF %", scale=100),
            Stat("ttf", "median_iqr", name="TTF %", scale=100),
            Stat("ttf", "n"),
            Stat("ttf", "values", name="TTF", digits=2),
        ],
        order={"task": ["b"]},
    )
    assert list(table.columns) == [
        "task",
        "variant",
        "completed",
        "median TTF %",
        "mean TTF %",
        "median (IQR) TTF %",
        "ttf",
        "TTF",
    ]
    assert list(zip(table["task"], table["variant"], strict=True)) == [("b", "x"), ("a", "x"), ("a", "y")]
    ax = table.iloc[1]
    assert ax["completed"] == "1/1"  # the unrecorded completion is not counted
    assert ax["median TTF %"] == pytest.approx(70.0) and ax["mean TTF %"] == pytest.approx(70.0)
    assert ax["ttf"] == 2
    bx = table.iloc[0]
    assert bx["completed"] == "1/2" and bx["median TTF %"] == pytest.approx(30.0)
    md = markdown(table).splitlines()
    assert md[0].startswith("| task | variant | completed | median TTF % | mean TTF %")
    assert md[3] == "| a | x | 1/1 | 70.0 | 70.0 | 70.0 (55.0–85.0) | 2 | 1.00, 0.40 |"


def test_a_stat_where_filters_and_an_empty_group_is_blank() -> None:
    stat = Stat("ttf", "median", where=lambda g: g[g["ttf"] > 0.9])
    table = summarize(_records(), by=["task"], stats=[stat])
    assert table["median ttf"].iloc[0] == 1.0 and math.isnan(table["median ttf"].iloc[1])
    assert markdown(table).splitlines()[-1] == "| b | — |"


def test_an_unknown_statistic_or_column_is_refused() -> None:
    with pytest.raises(ValueError, match="unknown statistic"):
        Stat("ttf", "mode")
    with pytest.raises(ValueError, match="no column seed"):
        summarize(_records(), by=["seed"], stats=[Stat("ttf")])


def test_prose_formats() -> None:
    assert Fmt.listing(["a", "b", "c"]) == "a, b and c" and Fmt.plural(1, "trial") == "1 trial"
    assert Fmt.pct(0.123) == "12.3" and Fmt.p(0.000123456) == "0.000123" and Fmt.span(1.02, 0.98) == "1"


def test_provenance_warns_when_records_span_revisions(tmp_path) -> None:
    (tmp_path / "s").mkdir()
    (tmp_path / "s" / "report.py").write_text(
        'TITLE = "t"\nEXPERIMENTS = []\ndef report(study):\n  return ""\n'
    )
    s = Study("s", tmp_path)
    one = pd.DataFrame({"git_revision": ["a" * 40] * 2, "cpu": ["X"] * 2, "logical_cpus": [2, 2]})
    assert "span" not in s.provenance(one) and s.provenance(one).startswith("2 records from 1 code revision")
    two = one.assign(git_revision=["a" * 40, "b" * 40])
    assert "**The records span 2 code revisions**" in s.provenance(two)
    assert s.records().empty and s.render().startswith("# t\n")


def test_a_study_tables_its_records_anew_when_they_change(tmp_path) -> None:
    """:meth:`Study.records` is the table of the files there now, and each caller's own copy."""
    (tmp_path / "s" / "records" / "a").mkdir(parents=True)
    report = 'TITLE = "t"\nEXPERIMENTS = []\ndef report(study):\n  return ""\n'
    (tmp_path / "s" / "report.py").write_text(report)
    record = {"task": "apple", "seed": 0, "status": "ok", "ttf": 1.0, "variant": "full"}
    write_json(tmp_path / "s" / "records" / "a" / "trial.json", record)
    s = Study("s", tmp_path)
    first = s.records()
    first.loc[:, "ttf"] = -1.0
    assert s.records()["ttf"].tolist() == [1.0]
    write_json(tmp_path / "s" / "records" / "a" / "trial.json", {**record, "ttf": 0.5})
    write_json(tmp_path / "s" / "records" / "b" / "trial.json", {**record, "seed": 1})
    assert sorted(s.records()["ttf"].tolist()) == [0.5, 1.0]


def test_glance_keeps_the_best_row_per_task(tmp_path) -> None:
    """9 of 10 beats 1 of 1 (the Wilson interval's lower bound), whichever study gives it."""
    for name, done in (("a", "1/1"), ("b", "9/10")):
        (tmp_path / name).mkdir()
        (tmp_path / name / "report.py").write_text(
            'TITLE = "t"\nEXPERIMENTS = []\ndef report(study):\n  return ""\n'
            'def glance(study):\n  return [{"task": "apple", '
            f'"configuration": "{name}", "completed": "{done}"}}]\n'
        )
    lines = glance_table(tmp_path).splitlines()
    assert len(lines) == 3 and "| apple | b | 9/10 |" in lines[2] and "[b](studies/b/README.md)" in lines[2]
    readme = f"x\n{study_mod.GLANCE_BEGIN}\nold\n{study_mod.GLANCE_END}\ny\n"
    assert with_glance(readme, "T\n") == f"x\n{study_mod.GLANCE_BEGIN}\nT\n{study_mod.GLANCE_END}\ny\n"


def test_glance_shows_the_default_below_the_best_where_it_is_another(tmp_path) -> None:
    """A row whose configuration says ``(the default)`` follows the task's best row where another row is
    the best, and is the only row where it is the best itself."""
    rows = {"a": ("x (the default)", "7/10"), "b": ("y", "9/10"), "c": ("z (the default)", "10/10")}
    for name, (configuration, done) in rows.items():
        task = "bottle" if name == "c" else "apple"
        (tmp_path / name).mkdir()
        (tmp_path / name / "report.py").write_text(
            'TITLE = "t"\nEXPERIMENTS = []\ndef report(study):\n  return ""\n'
            f'def glance(study):\n  return [{{"task": "{task}", "configuration": "{configuration}", '
            f'"completed": "{done}"}}]\n'
        )
    lines = glance_table(tmp_path).splitlines()[2:]
    assert [line.split(" | ")[1] for line in lines] == ["y", "x (the default)", "z (the default)"]


def test_glance_shows_the_one_method_for_every_task_where_it_is_neither_best_nor_default(tmp_path) -> None:
    """A row whose configuration says ALL_TASKS follows the best and the default rows of its task, and is
    not repeated where it is one of them."""
    every = study_mod.ALL_TASKS
    rows = [("apple", "x (the default)", "8/10"), ("apple", "y", "10/10"), ("apple", f"z {every}", "9/10"),
            ("bottle", f"z {every}", "10/10"), ("bottle", "x (the default)", "9/10")]  # fmt: skip
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "report.py").write_text(
        'TITLE = "t"\nEXPERIMENTS = []\ndef report(study):\n  return ""\n'
        "def glance(study):\n  return ["
        + ", ".join(f'{{"task": "{t}", "configuration": "{c}", "completed": "{k}"}}' for t, c, k in rows)
        + "]\n"
    )
    lines = glance_table(tmp_path).splitlines()[2:]
    assert [line.split(" | ")[1] for line in lines] == [
        "y", "x (the default)", f"z {every}", f"z {every}", "x (the default)"
    ]


def test_old_labels_go_through_the_projects_label_map() -> None:
    """Records' variants are renamed by ``contactmpc.labels.method_name``: an old record's variant and a
    new record's groups of the same method get one name, and a name read again stays the same."""
    df = pd.DataFrame(
        {
            "variant": ["release_flat", "full", "full", "wrist_acquire"],
            "release": [None, "flat", "none", None],
            "wrist": [None, None, None, "acquire"],
        }
    )
    names = list(study_mod._relabel(df)["variant"])
    assert names == ["release_flat", "release_flat", "full", "wrist_acquire"]


def test_a_figure_of_local_only_data_is_drawn_where_the_data_is_and_kept_elsewhere(tmp_path) -> None:
    """``Study.draw(data=...)``: drawn (and linked) where the data file exists; where it does not, the kept
    figure is linked without drawing, and with no kept figure there is no link (``None``)."""
    (tmp_path / "s").mkdir()
    (tmp_path / "s" / "report.py").write_text(
        'TITLE = "t"\nEXPERIMENTS = []\ndef report(study):\n  return ""\n'
    )
    s = Study("s", tmp_path, drawing=True)
    drawn = []

    def make(path):
        drawn.append(path)
        path.write_bytes(b"png")

    data = tmp_path / "series.npz"
    assert s.draw("f.png", make, "alt", data=data) is None and not drawn
    data.write_bytes(b"x")
    assert s.draw("f.png", make, "alt", data=data) == "![alt](figures/f.png)" and len(drawn) == 1
    data.unlink()
    assert s.draw("f.png", make, "alt", data=data) == "![alt](figures/f.png)" and len(drawn) == 1
