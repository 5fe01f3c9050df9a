"""The kept sweep records (``studies/<name>/records/``): every record is whole and
says where it ran. That each study's report is what its records make is ``tests/test_studies.py``."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from contactmpc.records import RECORD_NAME

REPO = Path(__file__).resolve().parent.parent
RECORDS = sorted([*(REPO / "studies").glob(f"*/records/**/{RECORD_NAME}")])


def _ids(paths: list[Path]) -> list[str]:
    return [str(p.parent.relative_to(REPO)) for p in paths]


@pytest.mark.skipif(not RECORDS, reason="no kept records")
@pytest.mark.parametrize("path", RECORDS, ids=_ids(RECORDS))
def test_kept_record_is_whole(path: Path) -> None:
    record = json.loads(path.read_text())
    assert record["status"] in ("ok", "diverged", "error"), record["status"]
    assert isinstance(record["config"], dict) and record["seed"] == record["config"]["seed"]
    assert record["cpu"] and record["logical_cpus"] >= 1  # where it ran
    if record["status"] == "ok":
        assert 0.0 <= record["ttf"] <= 1.0
        online = record["config"]["job"]["_target_"].endswith("run_online")
        assert online or record["cpu_seconds"] > 0  # an online run is timed by the wall clock
        if record["planner"] != "replay":  # replay plans nothing: it records no planner threads
            threads = record["planner_threads"] if online else record["threads"]
            assert threads == record["config"]["planner"]["nthread"]
