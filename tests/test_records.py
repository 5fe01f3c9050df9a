"""Atomic record writes: an interrupted write leaves the previous file intact and no temp files."""

from __future__ import annotations

import json
import os
import signal
import socket
import stat
import subprocess
import sys
import time
from pathlib import Path

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


def test_running_trials_counts_live_processes_and_ignores_stale_files(tmp_path):
    """The machine-wide registry: each running trial's file counts while its process lives; a file left
    by a dead process (or by a process whose pid was given to another) is ignored and removed."""
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    (tmp_path / f"{dead.pid}-00000000").write_text("")  # a dead process's file
    (tmp_path / f"{os.getpid()}-11111111").write_text("1")  # this pid, but another start time: reused
    (tmp_path / "not-a-trial").write_text("")
    other = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        (tmp_path / f"{other.pid}-22222222").write_text(records._start_time(other.pid) or "")
        with records.RunningTrials(tmp_path, interval=0.05) as running:
            assert running.count() == 2  # this trial and the other process's
            time.sleep(0.2)
        assert running.max == 2
        assert sorted(p.name for p in tmp_path.iterdir()) == [f"{other.pid}-22222222", "not-a-trial"]
    finally:
        other.kill()
        other.wait()
    assert records.RunningTrials(tmp_path).count() == 0


@pytest.mark.skipif(not Path("/proc/self/stat").is_file(), reason="needs /proc")
def test_running_trials_do_not_count_a_stopped_process(tmp_path):
    """A trial paused with SIGSTOP (another job's, stopped while an online run measures wall-clock time)
    holds no core: it counts again once continued."""
    other = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        (tmp_path / f"{other.pid}-33333333").write_text(records._start_time(other.pid) or "")
        running = records.RunningTrials(tmp_path)
        assert running.count() == 1
        other.send_signal(signal.SIGSTOP)
        deadline = time.monotonic() + 5.0
        while running.count() and time.monotonic() < deadline:  # the state changes asynchronously
            time.sleep(0.01)
        assert running.count() == 0 and (tmp_path / f"{other.pid}-33333333").exists()  # kept, not stale
        other.send_signal(signal.SIGCONT)
        while not running.count() and time.monotonic() < deadline:
            time.sleep(0.01)
        assert running.count() == 1
    finally:
        other.kill()
        other.wait()


def test_host_names_the_machine_its_processor_and_cores():
    host = records.host()
    assert host["name"] == socket.gethostname() and host["logical_cpus"] == os.cpu_count()
    assert host["cpu"].startswith(records.cpu_model())
    assert host["physical_cores"] is None or 1 <= host["physical_cores"] <= os.cpu_count()
