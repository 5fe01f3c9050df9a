"""Trial metrics: the paper's time-to-failure (TTF) and tracking summaries.

TTF (paper §III-A): a trial fails when the hand touches the object nowhere for ``gap`` seconds
(300 ms) while more than ``min_expected`` (six) expected contacts exist at every instant of that
time. TTF is the fraction of the span between the first and the last instants with any expected
contact that passed before the failure, 1.0 if it never fails. A trial during which no contact is
expected at all (it ended before the reference's first expected contact) has no TTF (``None``): it
says nothing about keeping contact, and 1.0 would overstate it. The failure time reported is the
instant the hand lost its last contact, i.e. the start of the failing gap (the trial is *declared*
failed ``gap`` seconds later).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class TTFResult:
    """Outcome of the contact monitor.

    Attributes:
        ttf: fraction in [0, 1] of the contact span that passed before failure (1.0: no failure);
            ``None`` when no contact was expected during the trial.
        failed: whether the failure rule fired.
        failure_time: start of the failing gap (s), or ``None``.
        span: (first, last) instants with any expected contact (s), or ``None`` if there are none.
        note: why ``ttf`` is ``None``, else ``None``.
    """

    ttf: float | None
    failed: bool
    failure_time: float | None
    span: tuple[float, float] | None
    note: str | None = None


def time_to_failure(
    time: np.ndarray,
    contacts: np.ndarray,
    expected: np.ndarray,
    gap: float = 0.3,
    min_expected: int = 6,
) -> TTFResult:
    """Apply the paper's failure rule to a contact log.

    Args:
        time: (N,) increasing sample times (s), uniformly or non-uniformly spaced.
        contacts: (N, L) bool, links actually touching the object.
        expected: (N, L) bool, links expected in contact by the reference.
        gap: how long the hand must touch nothing (s); the paper's 300 ms.
        min_expected: the rule needs strictly more than this many expected contacts throughout.

    Returns:
        The :class:`TTFResult`.
    """
    time = np.asarray(time, float)
    touching = np.asarray(contacts, bool).any(axis=-1)
    n_expected = np.asarray(expected, bool).sum(axis=-1)
    span = contact_span(time, expected)
    if span is None:
        return _nothing_expected(time)
    first, last = span
    eligible = ~touching & (n_expected > min_expected)
    start = None
    failure = None
    for i in range(len(time)):
        if eligible[i]:
            if start is None:
                start = i
            # Samples are instants: a gap starting at start is at least time[i] - time[start] long.
            if time[i] - time[start] >= gap - 1e-9:
                failure = float(time[start])
                break
        else:
            start = None
    if failure is None:
        return TTFResult(1.0, False, None, span)
    ttf = 1.0 if last <= first else float(np.clip((failure - first) / (last - first), 0.0, 1.0))
    return TTFResult(ttf, True, failure, span)


def contact_span(time: np.ndarray, expected: np.ndarray) -> tuple[float, float] | None:
    """The first and the last of ``time`` (N,) at which ``expected`` (N, L) has any contact, or ``None``."""
    any_expected = np.asarray(expected, bool).any(axis=-1)
    if not any_expected.any():
        return None
    return float(time[np.argmax(any_expected)]), float(time[len(time) - 1 - np.argmax(any_expected[::-1])])


def _nothing_expected(time: np.ndarray) -> TTFResult:
    """The TTF of a log ending at ``time[-1]`` during which no contact was expected: none, and why."""
    end = float(time[-1]) if len(time) else 0.0
    note = f"no contact was expected during the trial (0 to {end:.3f} s): it ended before the span starts"
    return TTFResult(None, False, None, None, note)


def time_to_failure_cut_short(
    time: np.ndarray,
    contacts: np.ndarray,
    expected: np.ndarray,
    trial_time: np.ndarray,
    trial_expected: np.ndarray,
    end: float,
    gap: float = 0.3,
    min_expected: int = 6,
) -> TTFResult:
    """TTF of a trial cut short at ``end`` (its plant diverged): the failure rule on what was logged,
    against the contact span of the **whole** trial; a trial cut short inside that span fails at ``end``
    unless the rule fired earlier, one cut short after the span keeps what its log says.

    Args:
        time, contacts, expected: the log up to ``end`` ((N,), (N, L), (N, L)), as :func:`time_to_failure`.
        trial_time: (M,) the instants the whole trial would have logged (M >= N).
        trial_expected: (M, L) bool, the links expected in contact at those instants.
        end: the instant the trial was cut short (s).
        gap, min_expected: the failure rule, as :func:`time_to_failure`.

    Returns:
        The :class:`TTFResult`, its span the whole trial's.
    """
    span = contact_span(trial_time, trial_expected)
    if span is None:  # no contact expected in the whole trial
        return _nothing_expected(np.asarray(trial_time, float))
    first, last = span
    logged = time_to_failure(time, contacts, expected, gap, min_expected) if len(time) else None
    failure = logged.failure_time if logged and logged.failed else (float(end) if end < last else None)
    if failure is None:
        return TTFResult(1.0, False, None, span)
    ttf = 1.0 if last <= first else float(np.clip((failure - first) / (last - first), 0.0, 1.0))
    return TTFResult(ttf, True, failure, span)


def errors_by_window(
    time: np.ndarray, errors: dict[str, np.ndarray], span: tuple[float, float] | None
) -> dict[str, float | None]:
    """Mean and final value of each error over the contact span and after it.

    The *span* is the samples from the first to the last instant with any expected contact (both
    included, :attr:`TTFResult.span`): where the reference asks the hand to do the task. *After* is
    the samples past its end: the reference's release and retreat, where an object set down and then
    knocked off or carried away shows up.

    Args:
        time: (N,) sample times (s).
        errors: name -> (N,) error per sample (e.g. ``"object_position_error"``).
        span: (first, last) instants of the contact span (s), or ``None`` when there is none.

    Returns:
        ``<name>_span_mean``, ``<name>_span_final``, ``<name>_after_mean``, ``<name>_after_final`` for
        each name: floats, or ``None`` where the window holds no sample (no span, nothing after it).
    """
    t = np.asarray(time, float)
    if span is None:
        windows = {"span": np.zeros(len(t), bool), "after": np.zeros(len(t), bool)}
    else:
        windows = {"span": (t >= span[0] - 1e-9) & (t <= span[1] + 1e-9), "after": t > span[1] + 1e-9}
    out: dict[str, float | None] = {}
    for name, values in errors.items():
        values = np.asarray(values, float)
        for window, sel in windows.items():
            inside = values[sel]
            out[f"{name}_{window}_mean"] = float(np.mean(inside)) if len(inside) else None
            out[f"{name}_{window}_final"] = float(inside[-1]) if len(inside) else None
    return out
