"""Atomic record writes: an interrupted write leaves the previous file intact and no temp files."""

from __future__ import annotations

import json
import os
import stat

import numpy as np
import pytest

from contactmpc import records


def test_write_json_is_atomic_and_replaces_nan(tmp_path):
    path = records.write_json(
        tmp_path / "trial.json", {"ttf": float("nan"), "x": np.float32(1.5), "a": np.arange(3)}
    )
    assert json.loads(path.read_text()) == {"ttf": None, "x": 1.5, "a": [0, 1, 2]}


def test_interrupted_write_leaves_old_record_and_no_temp_file(tmp_path, monkeypatch):
    path = records.write_json(tmp_path / "trial.json", {"status": "ok"})

    def boom(*args, **kwargs):
        raise KeyboardInterrupt  # as if Ctrl-C arrived in the middle of the write

    monkeypatch.setattr(records.os, "fsync", boom)
    with pytest.raises(KeyboardInterrupt):
        records.write_json(path, {"status": "half"})
    assert json.loads(path.read_text()) == {"status": "ok"}
    assert [p.name for p in tmp_path.iterdir()] == ["trial.json"]


def test_series_round_trip(tmp_path):
    arrays = {"time": np.arange(4) * 0.01, "contacts": np.eye(4, dtype=bool)}
    path = records.write_series(tmp_path / "timeseries.npz", arrays)
    loaded = np.load(path)
    for key, value in arrays.items():
        np.testing.assert_array_equal(loaded[key], value)


@pytest.mark.parametrize(("umask", "mode"), [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_records_get_the_permissions_of_a_new_file(tmp_path, umask, mode):
    """Records and series are written 0666 less the umask, like any new file (not mkstemp's 0600)."""
    old = os.umask(umask)
    try:
        paths = [
            records.write_json(tmp_path / "trial.json", {"status": "ok"}),
            records.write_series(tmp_path / "timeseries.npz", {"time": np.zeros(2)}),
            records.write_json(tmp_path / "trial.json", {"status": "ok"}),  # a replaced record too
        ]
    finally:
        os.umask(old)
    assert [stat.S_IMODE(p.stat().st_mode) for p in paths] == [mode] * 3
