"""``python -m analysis.frames``: a finished trial at chosen instants above its reference, from its series."""

from __future__ import annotations

import json
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest

from analysis.frames import AROUND_CONTACT, instants, main
from tests.test_trial import TINY, run_job

LABEL = 24  # pixels: the time label's band at the top of each panel


def test_the_default_instants_run_around_the_first_expected_contact_with_the_failure_among_them() -> None:
    time = np.arange(0.0, 10.0, 0.17)
    record = {"contact_span_start": 4.0, "failure_time": 5.3}
    assert instants(record, time) == pytest.approx(sorted([4.0 + d for d in AROUND_CONTACT] + [5.3]))
    # one within 50 ms of another is left out; those outside the series too
    assert instants({"contact_span_start": 8.0, "failure_time": 8.52}, time) == pytest.approx(
        [7.5, 8.0, 8.5, 9.0, 9.5]
    )
    assert instants(record, time, at=[2.0, 1.0, 1.02, 42.0]) == [1.0, 2.0]  # as asked, in order
    assert instants({"contact_span_start": None}, time) == pytest.approx(np.linspace(0.0, time[-1], 7))


@pytest.fixture(scope="module")
def finished_run(reference_files, tmp_path_factory) -> Path:
    """A tiny finished trial of the synthetic doorknob, its record and series kept."""
    run = tmp_path_factory.mktemp("doorknob")
    overrides = ["task=doorknob", f"task.reference_path={reference_files['doorknob']}", *TINY]
    record = json.loads(run_job(overrides + ["duration=0.2", "job.progress=false"], run).read_text())
    assert record["status"] == "ok", record.get("error")
    return run


def test_a_finished_trial_is_drawn_above_its_reference(finished_run: Path, tmp_path: Path, capsys) -> None:
    assert main([str(finished_run), "--at", "0.0", "0.1", "--out-dir", str(tmp_path)]) == 0
    png = tmp_path / f"{finished_run.name}_frames.png"
    img = iio.imread(png)
    assert img.shape == (2 * 240 + 4, 2 * 320 + 4, 3)  # the trial above its reference, two instants
    below = slice(LABEL, 240)  # each panel's picture under its label (the labels differ by row)
    top, bottom = img[below].astype(int), img[244:][below].astype(int)
    start, later = slice(0, 320), slice(324, 644)
    # at 0 s the plant is where the reference starts (within 1e-16 rad: the same picture); by 0.1 s it has
    # moved. Measured here: no pixel differs at 0 s, half of them at 0.1 s; bounds far from both
    assert (top[:, start] != bottom[:, start]).any(axis=-1).mean() < 0.01
    assert (top[:, later] != bottom[:, later]).any(axis=-1).mean() > 0.1
    assert "2 instants" in capsys.readouterr().out


def test_a_run_that_cannot_be_drawn_gets_one_line_and_status_2(
    finished_run: Path, tmp_path: Path, capsys
) -> None:
    assert main([str(finished_run), "--at", "42.0", "--out-dir", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and "none of the instants" in err[0]
    (tmp_path / "empty").mkdir()
    assert main([str(tmp_path / "empty")]) == 2
    assert "no trial.json here" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main([str(finished_run), "--zoom", "0"])
