"""The paper's time-to-failure rule on synthetic contact logs."""

from __future__ import annotations

import numpy as np
import pytest

from contactmpc.metrics import time_to_failure, time_to_failure_cut_short
from contactmpc.tasks import BottleTask
from contactmpc.tasks.base import sustained

DT = 0.001


def log(duration=2.0, expected_links=8, n_links=12):
    t = np.arange(int(round(duration / DT)) + 1) * DT
    expected = np.zeros((len(t), n_links), bool)
    expected[:, :expected_links] = True
    contacts = np.zeros_like(expected)
    contacts[:, 0] = True
    return t, contacts, expected


def test_no_failure_when_always_touching():
    t, c, e = log()
    r = time_to_failure(t, c, e)
    assert (r.ttf, r.failed, r.failure_time) == (1.0, False, None)
    assert r.span == (0.0, pytest.approx(2.0))


def test_gap_of_299_ms_is_not_a_failure_but_300_ms_is():
    t, c, e = log()
    start = 1000  # t = 1.0 s
    c299 = c.copy()
    c299[start : start + 299, :] = False  # samples 1.000 .. 1.298: 298 ms between first and last
    assert not time_to_failure(t, c299, e).failed
    c299b = c.copy()
    c299b[start : start + 300, :] = False  # 1.000 .. 1.299: a 299 ms gap
    assert not time_to_failure(t, c299b, e).failed
    c300 = c.copy()
    c300[start : start + 301, :] = False  # 1.000 .. 1.300: a 300 ms gap
    r = time_to_failure(t, c300, e)
    assert r.failed
    assert r.failure_time == pytest.approx(1.0)
    assert r.ttf == pytest.approx(0.5)


def test_no_failure_while_six_or_fewer_contacts_are_expected():
    t, c, e = log(expected_links=6)
    c[500:1500] = False
    assert not time_to_failure(t, c, e).failed
    t, c, e = log(expected_links=7)
    c[500:1500] = False
    assert time_to_failure(t, c, e).failed


def test_the_rule_needs_more_than_six_throughout_the_gap():
    t, c, e = log(expected_links=8)
    c[1000:1400] = False
    e[1200:1210, 2:] = False  # only 2 expected for 10 ms in the middle of the gap
    r = time_to_failure(t, c, e)
    # 1.000-1.199 (199 ms) and 1.210-1.399 (189 ms) are each shorter than 300 ms.
    assert not r.failed


def test_ttf_is_the_fraction_of_the_contact_span():
    t, c, e = log(duration=3.0)
    e[:500] = False  # contact expected from 0.5 s ...
    e[2501:] = False  # ... to 2.5 s: a 2 s span
    c[1000:1400] = False  # contact lost at 1.0 s
    r = time_to_failure(t, c, e)
    assert r.span == (pytest.approx(0.5), pytest.approx(2.5))
    assert r.ttf == pytest.approx((1.0 - 0.5) / 2.0)


def test_custom_thresholds():
    t, c, e = log()
    c[1000:1150] = False
    assert not time_to_failure(t, c, e).failed
    assert time_to_failure(t, c, e, gap=0.1).failed
    assert not time_to_failure(t, c, e, gap=0.1, min_expected=8).failed


def test_no_expected_contacts_means_no_ttf():
    """A trial that ends before the contact span starts has no TTF (not 1.0), and says why."""
    t, c, e = log(expected_links=0)
    r = time_to_failure(t, c, e)
    assert (r.ttf, r.failed, r.span) == (None, False, None)
    assert "no contact was expected during the trial" in r.note


# ------------------------------------------------------------------------------------- milestones
def test_sustained_needs_a_run_of_the_given_duration():
    t = np.arange(10) * 0.05
    mask = np.zeros(10, bool)
    mask[[1, 3, 4, 5]] = True  # an instant, then 0.10 s in a row
    assert sustained(mask, t, 0.0)
    assert sustained(mask, t, 0.10)
    assert not sustained(mask, t, 0.11)
    assert not sustained(np.zeros(10, bool), t, 0.0)


def _bottle_log(held: bool, dwell: int):
    """A bottle lifted 10 cm and tilted to pour in place for ``dwell`` samples of 50 ms."""
    task = BottleTask(hand_home=[0.0] * 22)
    n = 40
    t = np.arange(n) * 0.05
    qo = np.tile([0.0, 0.0, 0.1, 1.0, 0.0, 0.0, 0.0], (n, 1))
    qo[0, 2] = 0.0  # resting on the table at the start
    poured = np.array([np.cos(0.75), np.sin(0.75), 0.0, 0.0])  # 86 deg about x
    qo[10 : 10 + dwell, 3:7] = poured
    contacts = np.full(n, held)
    return task, qo, qo.copy(), contacts, t


def test_a_milestone_counts_only_while_held_and_for_the_hold_time():
    """Seen before the fix: a bottle falling through the pour pose counted as poured."""
    task, qo, expected, held, t = _bottle_log(held=True, dwell=8)  # 0.35 s in the pose, held
    assert task.milestones(qo, expected, held, t, hold=0.3) == {"lifted": True, "poured": True}
    task, qo, expected, held, t = _bottle_log(held=False, dwell=8)  # the same motion, not touched
    assert task.milestones(qo, expected, held, t, hold=0.3) == {"lifted": False, "poured": False}
    task, qo, expected, held, t = _bottle_log(held=True, dwell=2)  # passes through in 0.05 s
    assert task.milestones(qo, expected, held, t, hold=0.3)["poured"] is False
    assert task.milestones(qo, expected, held, t, hold=0.0)["poured"] is True


def test_a_trial_cut_short_fails_where_it_stopped_inside_the_span_only():
    t, c, e = log(duration=2.0)  # touching throughout, 8 expected from 0 to 2 s
    cut = t <= 1.2
    r = time_to_failure_cut_short(t[cut], c[cut], e[cut], t, e, 1.2)
    assert (r.failed, r.failure_time, r.span) == (True, 1.2, (0.0, pytest.approx(2.0)))
    assert r.ttf == pytest.approx(0.6)
    e_after = e.copy()
    e_after[t > 1.0] = False  # the span ends at 1 s: a cut at 1.2 s comes after it
    r = time_to_failure_cut_short(t[cut], c[cut], e_after[cut], t, e_after, 1.2)
    assert (r.ttf, r.failed, r.failure_time) == (1.0, False, None)
    c_lost = c.copy()
    c_lost[500:] = False  # contact lost at 0.5 s: the rule fires before the cut, its time stands
    r = time_to_failure_cut_short(t[cut], c_lost[cut], e[cut], t, e, 1.2)
    assert (r.failed, r.failure_time) == (True, pytest.approx(0.5)) and r.ttf == pytest.approx(0.25)
    early = t <= 0.1  # cut before any contact is expected: TTF 0
    late = e.copy()
    late[t < 0.5] = False
    r = time_to_failure_cut_short(t[early], c[early], late[early], t, late, 0.1)
    assert (r.ttf, r.failed, r.failure_time) == (0.0, True, 0.1)
    none = np.zeros_like(e)
    assert time_to_failure_cut_short(t[cut], c[cut], none[cut], t, none, 1.2).ttf is None
