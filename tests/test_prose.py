"""analysis.prose: the words a study's findings print, computed from values taken from its records."""

from __future__ import annotations

import sys
import types

import pandas as pd

from analysis.prose import as_recorded, median, of, ratio, seeds, seeds_n, span


def test_ranges_medians_and_counts() -> None:
    assert span([0.0174, 0.0178, float("nan")], "{:.1f}", 1e3) == "17.4-17.8"
    assert span([0.5, 0.5]) == "0" and span([]) == "-"
    assert median([1.0, 3.0, None, 2.0]) == "2" and median([]) == "-"
    assert of(5, 6) == "5 of 6" and ratio(3.0, 2.0) == "1.5" and ratio(1.0, 0.0) == "-"


def test_seeds_as_prose() -> None:
    assert seeds([2, 0, 1]) == "0-2"
    assert seeds([0, 1]) == "0 and 1"
    assert seeds([0, 3, 4, 5]) == "0 and 3-5"
    assert seeds([1, 3, 5]) == "1, 3 and 5"
    assert seeds([]) == "none"
    assert seeds_n([2]) == "seed 2" and seeds_n([3, 4, 5]) == "seeds 3-5"


def test_as_recorded_undoes_the_label_map(monkeypatch) -> None:
    df = pd.DataFrame({"variant": ["flat", "full", "both"]})
    labels = types.ModuleType("contactmpc.labels")
    labels.VARIANT_LABELS = {"release_flat": "flat", "a": "both", "b": "both"}  # "both" is ambiguous: kept
    monkeypatch.setitem(sys.modules, "contactmpc.labels", labels)
    import contactmpc

    monkeypatch.setattr(contactmpc, "labels", labels, raising=False)
    assert list(as_recorded(df)["variant"]) == ["release_flat", "full", "both"]


def test_unchallenged_leaves_out_the_trials_run_under_a_challenge() -> None:
    import pandas as pd

    from analysis.prose import unchallenged

    df = pd.DataFrame({"task": ["bottle", "bottle"], "challenge": [None, "bottle_offset"]})
    assert list(unchallenged(df)["challenge"].isna()) == [True]
    assert len(unchallenged(df.drop(columns="challenge"))) == 2  # records without the field: all kept
