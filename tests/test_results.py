"""The kept sweep records (``results/``): every record is whole, says where it ran, and the README's tables
on the paper's data are what the analysis makes of them."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from analysis import readme_blocks
from analysis.paper_fig3 import load, markdown
from contactmpc.records import RECORD_NAME

REPO = Path(__file__).resolve().parent.parent
RESULTS = REPO / "results"
RECORDS = sorted(RESULTS.glob(f"*/*/{RECORD_NAME}"))
FIG3 = RESULTS / "fig3_paper"


def _ids(paths: list[Path]) -> list[str]:
    return [str(p.parent.relative_to(RESULTS)) for p in paths]


@pytest.mark.skipif(not RECORDS, reason="no kept records in results/")
@pytest.mark.parametrize("path", RECORDS, ids=_ids(RECORDS))
def test_kept_record_is_whole(path: Path) -> None:
    record = json.loads(path.read_text())
    assert record["status"] in ("ok", "diverged", "error"), record["status"]
    assert isinstance(record["config"], dict) and record["seed"] == record["config"]["seed"]
    assert record["cpu"] and record["logical_cpus"] >= 1  # where it ran
    if record["status"] == "ok":
        assert 0.0 <= record["ttf"] <= 1.0 and record["cpu_seconds"] > 0
        assert record["threads"] == record["config"]["planner"]["nthread"]


@pytest.mark.skipif(not list(FIG3.glob(f"*/{RECORD_NAME}")), reason="results/fig3_paper is not kept here")
def test_readme_fig3_table_is_made_from_the_kept_records() -> None:
    """Each line of the analysis' table on ``results/fig3_paper`` is in the README, as the README says
    (``python -m analysis.paper_fig3 results/fig3_paper``)."""
    readme = (REPO / "README.md").read_text()
    table = markdown(load(FIG3)).splitlines()
    lines = [line for line in table if line.startswith("| ") and "---" not in line]
    missing = [line for line in lines if line not in readme]
    assert not missing, f"{len(missing)} of {len(lines)} lines not in README, first: {missing[0]}"


@pytest.mark.skipif(not RECORDS, reason="no kept records in results/")
def test_readme_blocks_are_what_the_analysis_makes_of_the_kept_records() -> None:
    """Every README block made from ``results/`` (Fig. 3, the operating-point map, the end of the paper
    tasks) is exactly what ``python -m analysis.readme_blocks`` makes of the kept records now, and none
    is left as it is because it cannot be made (a missing directory, a filter naming no record)."""
    readme = (REPO / "README.md").read_text()
    for name in readme_blocks.BLOCKS:
        assert f"<!-- {name}:begin" in readme and f"<!-- {name}:end -->" in readme, name
    skipped: list[str] = []
    remade = readme_blocks.made(readme, skipped=skipped)
    assert not skipped, f"README blocks not made from the kept records: {skipped}"
    assert remade == readme, "stale README block: run python -m analysis.readme_blocks"


def test_a_readme_without_a_block_is_refused() -> None:
    with pytest.raises(ValueError, match="no block operating_point"):
        readme_blocks.rewrite("# README\n", "operating_point", "")
