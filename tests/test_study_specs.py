"""The study specs of the operating point, the stapler and the release: what they read, how they label it."""

from __future__ import annotations

from pathlib import Path

import pytest

from analysis.study import Study

RELEASE = Path(__file__).resolve().parent.parent / "studies" / "release" / "records"


@pytest.mark.skipif(not (RELEASE / "release_flat").is_dir(), reason="no release records here")
def test_release_flat_records_are_shown_as_release_flat_and_no_others() -> None:
    """Design 8's records say ``release_backoff`` (made with ``sampler.release_backoff=0``): the report shows
    exactly those records, and no design-7 record, as ``release_flat``."""
    study = Study("release")
    df = study.spec.relabel(study.records())
    flat = {Path(p).parent.parent.name for p in df.loc[df["variant"] == "release_flat", "record_path"]}
    assert flat == {"release_flat", "release_flat_lite"}
    made_flat = df["record_path"].str.contains("/release_flat")
    assert (df.loc[made_flat, "variant"] == "release_flat").all()


def test_the_glance_rows_name_a_configuration_and_its_counts() -> None:
    for name in ("operating_point", "stapler", "release"):
        for row in Study(name).glance():
            assert row["configuration"] and row["task"].startswith("paper ")
            done, n = map(int, row["completed"].split("/"))
            clean, n2 = map(int, row["finished cleanly"].split("/"))
            assert n == n2 > 0 and clean <= done <= n
            assert float(row["median CPU-s per trial"]) > 0
