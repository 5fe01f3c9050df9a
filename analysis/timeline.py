"""Why a trial failed, as a picture: ``python -m analysis.timeline RUN_DIR [RUN_DIR ...] [--out-dir DIR]``.

Per trial (``trial.json`` + ``timeseries.npz``), one figure on a shared time axis (the object's position
and rotation error against the reference, the links expected in contact and touching, as counts and as a
raster per hand link, the cost terms of the committed sample, log scale; lines at the contact span, the
TTF failure and each milestone) and the text of :func:`diagnose`: ``RUN_DIR/timeline.png`` and
``timeline.txt`` (``--out-dir``: ``DIR/<run name>.png`` and ``.txt``).
The record says whether a milestone was reached, not when: the instant is the start of the first hold of
the task's condition (:meth:`contactmpc.tasks.base.Task.conditions`, the task built from the record's
config, nothing compiled) under the record's rule (``job.milestone_hold`` s, while touched).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from analysis._cli import fail
from contactmpc.labels import method_name
from contactmpc.records import RECORD_NAME, SERIES_NAME, one_line

POSITION_THRESHOLD = 0.04  # m: position error that counts as losing the object (sustained for `gap`)
ROTATION_THRESHOLD = np.radians(30.0)  # rad: the same for the rotation error
LIFT_MIN = 0.02  # m: an object raised this far above its start was lifted (a drop, not a miss)
#: Raster cell colours: neither, expected only (missed), touching unexpected, touching as expected.
RASTER_COLORS = ("white", "#f4c08a", "#6baed6", "#238b45")
GREEN = "#2ca02c"  # milestones
LEGEND = {"fontsize": 8, "loc": "lower right", "bbox_to_anchor": (1.0, 1.0), "frameon": False}  # above


class TimelineError(ValueError):
    """A run directory that cannot be drawn; the message is one line."""


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``(start, stop)`` index pairs (stop exclusive) of the runs of true samples of ``mask`` (N,)."""
    edges = np.diff(np.concatenate([[0], np.asarray(mask, bool).astype(int), [0]]))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist(), strict=True))


def first_run(mask: np.ndarray, time: np.ndarray, duration: float) -> int | None:
    """Index of the first sample starting a run of true samples of ``mask`` (N,) that spans at least
    ``duration`` seconds of ``time`` (N,) (the rule of :func:`contactmpc.tasks.base.sustained`), or None."""
    for a, b in runs(mask):
        if time[b - 1] - time[a] >= duration - 1e-9:
            return a
    return None


def diagnose(
    time: np.ndarray,
    contacts: np.ndarray,
    expected_contacts: np.ndarray,
    position_error: np.ndarray | None = None,
    *,
    rotation_error: np.ndarray | None = None,
    heights: tuple[np.ndarray, np.ndarray] | None = None,
    failure_time: float | None = None,
    milestones: dict[str, float | bool] | None = None,
    completed: bool | None = None,
    names: Sequence[str] | None = None,
    gap: float = 0.3,
    min_expected: int = 6,
    position_threshold: float = POSITION_THRESHOLD,
    rotation_threshold: float = ROTATION_THRESHOLD,
) -> list[str]:
    """What went wrong in a trial, first thing first.

    Problems, each at an instant: no contact ever; a first touch ``gap`` or more after the first expected;
    links touching the object for ``gap`` or more before the reference first expects them (an early
    touch, e.g. a finger tapping the object over before its grasp; one line for all such links, at the
    first); the TTF failure (the hand lost its last contact); a contact gap of ``gap`` or more the
    failure rule let pass (too few links expected); the position or rotation error over its threshold
    for ``gap`` (by the heights: a drop, an object not lifted, or one off the reference). The earliest is
    the first line (``first: ...``), the others follow (``then: ...``), or all are ``note: ...`` under
    ``completed``.

    Args:
        time: (N,) sample times (s).
        contacts: (N, L) bool, links touching the object.
        expected_contacts: (N, L) bool, links the reference expects in contact.
        position_error: (N,) object position error (m); all zeros for an object without a free body.
        rotation_error: (N,) object rotation error (rad).
        heights: (N,) heights of the object's free body and of the reference's (m), to tell a drop.
        failure_time: the TTF failure instant (s), None when the rule did not fire.
        milestones: name -> instant it was reached (s), True (reached, instant unknown) or False.
        completed: whether the task was completed; None leaves the outcome line out.
        names: (L,) the links' names for the early-touch line; None: ``link <index>``.
        gap, min_expected: the failure rule's (``job.failure_gap``, ``job.failure_min_expected``).
        position_threshold: position error (m) that counts as losing the object.
        rotation_threshold: rotation error (rad) that counts as losing the object's orientation.

    Returns:
        Lines of text, without newlines.
    """
    t = np.asarray(time, float)
    touch, exp = np.asarray(contacts, bool), np.asarray(expected_contacts, bool)
    touching, n_exp, hits = touch.any(-1), exp.sum(-1), (touch & exp).sum(-1)
    problems: list[tuple[float, str]] = []  # (instant, text)
    if not n_exp.any():
        problems.append((t[-1], f"no contact expected during the trial (it ended at {_at(t[-1])})"))
    elif not touching.any():
        i0 = int(np.argmax(n_exp > 0))
        text = f"never reached contact (expected from {_at(t[i0])}, up to {_links(n_exp.max())})"
        problems.append((t[i0], text))
    else:
        i0, i1 = int(np.argmax(n_exp > 0)), int(np.argmax(touching))
        if (late := t[i1] - t[i0]) >= gap - 1e-9:
            text = f"reached contact late: first touch at {_at(t[i1])}, {late:.2f} s after expected"
            problems.append((t[i0], text))
        if failure_time is not None:
            i = min(int(np.searchsorted(t, failure_time - 1e-9)), len(t) - 1)
            j = np.flatnonzero(touching[:i])
            had = f"; {touch[j[-1]].sum()} at {_at(t[j[-1]])}" if len(j) else ""
            text = f"lost contact at {_at(failure_time)} (expected {_links(n_exp[i])}, touching 0{had})"
            problems.append((failure_time, text))
        for a, b in runs(~touching & (n_exp > 0)):  # a contact gap the failure rule let pass
            if failure_time is not None and t[a] >= failure_time - 1e-9:
                break
            if a > i1 and t[b - 1] - t[a] >= gap - 1e-9:
                until = "to the end" if b == len(t) else f"until {_at(t[b])}"
                text = f"no contact from {_at(t[a])} {until} while up to {_links(n_exp[a:b].max())} expected"
                few = bool(n_exp[a:b].min() <= min_expected)  # else the rule would have fired
                problems.append((t[a], text + f" (the failure rule needs > {min_expected})" * few))
                break
    early = []  # (start, link, seconds touching before its first expected contact)
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    for k in range(touch.shape[1]):
        first = int(np.argmax(exp[:, k])) if exp[:, k].any() else len(t)
        if (i := first_run(touch[:first, k], t[:first], gap)) is not None:
            early.append((i, k, touch[:first, k].sum() * dt))
    if early:
        early.sort()
        label = (lambda k: names[k]) if names is not None else (lambda k: f"link {k}")
        parts = ", ".join(f"{label(k)} from {_at(t[i])} ({sec:.1f} s)" for i, k, sec in early)
        problems.append((t[early[0][0]], f"touched before expected: {parts}"))
    checks = {"position": (position_error, position_threshold)}
    checks["rotation"] = (rotation_error, rotation_threshold)
    for name, (error, limit) in checks.items():
        if error is None or (i := first_run(np.asarray(error) > limit, t, gap)) is None:
            continue
        what = "object off the reference" if name == "position" else "object orientation off the reference"
        if name == "position" and heights is not None and (dz := heights[0][i] - heights[1][i]) < -limit / 2:
            lifted = np.max(heights[0][: i + 1] - heights[0][0]) > LIFT_MIN
            what = f"object {'dropped' if lifted else 'not lifted'} ({-1000 * dz:.0f} mm below reference)"
        past = f"{1000 * limit:.0f} mm" if name == "position" else f"{np.degrees(limit):.0f} deg"
        held = f"touching {hits[i]} of {_links(n_exp[i])} expected" if n_exp[i] else "no contact expected"
        problems.append((t[i], f"{what} at {_at(t[i])}: {name} error past {past} while {held}"))
    problems.sort(key=lambda p: p[0])
    if completed or not problems:
        outcome = (
            "completed" if completed else "no failure detected" + "; not completed" * (completed is False)
        )
        lines = [outcome] + ["note: " + text for _, text in problems]
    else:
        lines = [("first: " if k == 0 else "then: ") + text for k, (_, text) in enumerate(problems)]
    if milestones:
        lines.append("milestones: " + ", ".join(f"{n} {_at(v, 'at ')}" for n, v in milestones.items()))
    return lines + ["not completed"] * bool(problems and completed is False)


def _at(x: float | bool, prefix: str = "") -> str:
    """``t=1.23 s`` after ``prefix``; a milestone's flag: ``reached`` (instant unknown) or ``not reached``."""
    return ("reached" if x else "not reached") if isinstance(x, bool) else f"{prefix}t={x:.2f} s"


def _links(n: int) -> str:
    return f"{n} link" + "s" * bool(n != 1)


def load_run(run_dir: str | Path) -> tuple[dict, dict[str, np.ndarray], list[str]]:
    """The record, the series (name -> (N, ...) array) and warnings of a run directory; raises
    :class:`TimelineError` for no record, an unreadable one, or no series (saying why a trial that did
    not finish left none)."""
    run = Path(run_dir)
    if not (run / RECORD_NAME).is_file():
        raise TimelineError(f"{run}: " + (f"no {RECORD_NAME} here" if run.is_dir() else "no such directory"))
    try:
        record = json.loads((run / RECORD_NAME).read_text())
        status = record.get("status")
    except (OSError, ValueError, AttributeError) as err:
        raise TimelineError(f"{run / RECORD_NAME}: unreadable record ({one_line(err)})") from err
    why = f"trial status {status!r}" + (f" ({record['error']})" if record.get("error") else "")
    if not (run / SERIES_NAME).is_file():
        why = f"{why}; it left no {SERIES_NAME}, nothing to draw" if status != "ok" else f"no {SERIES_NAME}"
        raise TimelineError(f"{run}: {why}")
    try:
        with np.load(run / SERIES_NAME) as z:
            series = {k: z[k] for k in z.files}
        if missing := [k for k in ("time", "contacts", "expected_contacts") if k not in series]:
            raise ValueError(f"no column {', '.join(missing)}")
    except (OSError, ValueError) as err:
        raise TimelineError(f"{run / SERIES_NAME}: unreadable series ({one_line(err)})") from err
    return record, series, [] if status == "ok" else [f"{run}: {why}; drawing the series it left"]


def _build(node: dict | None):
    """The object a record's config node describes (``_target_``), its nested nodes left as dicts."""
    from hydra.utils import instantiate

    if not isinstance(node, dict) or "_target_" not in node:
        raise TypeError("not in the record's config")
    return instantiate(node, _recursive_=False)


def link_names(record: dict, num_links: int) -> tuple[list[str], str | None]:
    """(L,) names of the hand's contact links: the record's ``link_names``, else those of the hand of
    its config (no model compiled); else the indices, with a note saying why."""
    try:
        names = record.get("link_names") or _build((record.get("config") or {}).get("hand")).link_names
        if len(names) != num_links:
            raise ValueError(f"the hand has {len(names)} links, the series {num_links}")
        return [str(n) for n in names], None
    except Exception as err:  # any failure costs only the labels
        note = f"link names unknown ({one_line(err)}): rows labelled by index"
    return [str(i) for i in range(num_links)], note


def milestone_times(record: dict, series: dict) -> tuple[dict[str, float | bool], str | None]:
    """Milestone name -> instant reached (s) or False, from the task of the record's config; without
    it, the record's ``milestone_*`` flags (True: reached, instant unknown) and a note saying why."""
    config = record.get("config") or {}
    hold, t = float((config.get("job") or {}).get("milestone_hold", 0.3)), series["time"]
    try:
        task = _build(config.get("task"))
        conditions = task.conditions(series["object_qpos"], series["expected_object_qpos"])
    except Exception as err:  # the record's flags remain
        flags = {k[len("milestone_") :]: bool(v) for k, v in record.items() if k.startswith("milestone_")}
        return flags, f"milestone instants unknown ({one_line(err)})" if flags else None
    found = {name: first_run(ok & series["contacts"].any(-1), t, hold) for name, ok in conditions.items()}
    return {name: False if i is None else float(t[i]) for name, i in found.items()}, None


def evidence(record: dict, series: dict[str, np.ndarray]) -> dict:
    """:func:`diagnose`'s keywords but the milestones, from the record (the failure facts recomputed if it
    has none) and the series, plus ``span``: (first, last) instant of expected contact (s) or None."""
    from hydra.utils import get_class

    from contactmpc.metrics import time_to_failure
    from contactmpc.tasks.base import ObjectLayout

    job = (record.get("config") or {}).get("job") or {}
    gap, min_expected = float(job.get("failure_gap", 0.3)), int(job.get("failure_min_expected", 6))
    ttf = time_to_failure(series["time"], series["contacts"], series["expected_contacts"], gap, min_expected)
    failure, span = ttf.failure_time, ttf.span
    if "failed" in record:
        failure, start = record.get("failure_time"), record.get("contact_span_start")
        span = None if start is None else (start, record.get("contact_span_end"))
    facts = {"failure_time": failure, "span": span, "gap": gap, "min_expected": min_expected}
    facts["completed"] = record.get("completed") if record.get("status") == "ok" else None
    facts["rotation_error"] = series.get("object_rotation_error")
    try:
        layout = ObjectLayout(get_class(record["config"]["task"]["_target_"]).object_joints)
        qo, qe = series["object_qpos"], series["expected_object_qpos"]
        if layout.quat_index is not None:
            facts["heights"] = (layout.position(qo)[:, 2], layout.position(qe)[:, 2])
    except Exception:  # no heights: a position error is not classified
        pass
    return facts


def _markers(ax, failure: float | None, span, milestones: dict, label: bool = False) -> None:
    for k, x in enumerate(span or ()):  # contact span, failure, milestones
        ax.axvline(x, color="0.4", ls=":", lw=1.2, label="contact span" if label and k == 0 else None)
    if failure is not None:
        ax.axvline(failure, color="#d62728", lw=1.6, label="TTF failure" if label else None)
    for k, (name, x) in enumerate((n, v) for n, v in milestones.items() if not isinstance(v, bool)):
        ax.axvline(x, color=GREEN, ls="--", lw=1.2, label="milestone" if label and k == 0 else None)
        if label:
            ax.text(x, 0.97, f" {name}", transform=ax.get_xaxis_transform(), va="top", size=8, color=GREEN)


def draw(
    series: dict, names: list[str], marks: tuple, title: str, path=None, threshold: float | None = None
) -> Figure:
    """The timeline figure of one trial: object errors, contact counts, contact raster, cost terms.

    Args:
        series: ``time`` (N,), ``contacts``, ``expected_contacts`` (N, L), object errors, ``cost_*`` (N,).
        names: (L,) the raster's row labels.
        marks: the TTF failure instant (s) or None; the span (first, last instant of expected contact,
            s) or None; milestone name -> instant reached (s) or a flag (:func:`milestone_times`).
        title: the figure's title (may hold two lines).
        path: where to save it (PNG), or None.
        threshold: the diagnosis's position threshold (m), drawn dotted; None draws none.
    """
    t = series["time"]
    touch, exp = series["contacts"].astype(bool), series["expected_contacts"].astype(bool)
    fig = Figure(figsize=(11, 7.5 + 0.14 * len(names)), layout="constrained")
    FigureCanvasAgg(fig)
    grid = fig.add_gridspec(4, 1, height_ratios=[2.2, 1.2, 1.2 + 0.16 * len(names), 1.6])
    ax = fig.add_subplot(grid[0])
    axes = [ax] + [fig.add_subplot(grid[k], sharex=ax) for k in (1, 2, 3)]
    zero = np.zeros(len(t))  # object errors: mm (position, articulation x 1000) and deg (rotation)
    pos, art = series.get("object_position_error", zero), series.get("object_articulation_error", zero)
    if np.any(pos):
        ax.plot(t, 1000 * pos, color="#1f77b4", label="position (mm)")
        if threshold is not None:
            ax.axhline(1000 * threshold, color="#1f77b4", ls=":", lw=0.8, label="threshold")
    if np.any(art):
        ax.plot(t, 1000 * art, color="#9467bd", label="articulation (mrad, mm)")
    ax.set(ylabel="mm (mrad)", ylim=(0, None))
    handles, labels = [], []
    if np.any(rot := series.get("object_rotation_error", zero)):
        twin = ax.twinx()
        twin.plot(t, np.degrees(rot), color="#ff7f0e", label="rotation (deg)")
        twin.set(ylabel="rotation error (deg)", ylim=(0, None))
        handles, labels = twin.get_legend_handles_labels()
    _markers(ax, *marks, label=True)
    h, lab = ax.get_legend_handles_labels()
    ax.legend(h + handles, lab + labels, ncol=len(h + handles), **LEGEND)
    axes[1].step(t, exp.sum(-1), where="mid", color="#e6550d", label="expected")
    axes[1].step(t, touch.sum(-1), where="mid", color="0.2", label="touching")
    axes[1].step(t, (touch & exp).sum(-1), where="mid", color="#238b45", ls="--", label="touching, expected")
    axes[1].set_ylabel("links")
    axes[1].legend(ncol=3, **LEGEND)
    code = (exp.astype(int) + 2 * touch.astype(int)).T  # 0 neither, 1 expected, 2 touching, 3 both
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.05
    box, cmap = (t[0] - dt / 2, t[-1] + dt / 2, len(names) - 0.5, -0.5), ListedColormap(RASTER_COLORS)
    axes[2].imshow(code, aspect="auto", interpolation="nearest", cmap=cmap, vmin=0, vmax=3, extent=box)
    axes[2].set_yticks(range(len(names)), names, fontsize=7)
    patches = [Patch(color=c, ec="0.5") for c in RASTER_COLORS[1:]]
    legend = ["expected, not touching", "touching, not expected", "touching as expected"]
    axes[2].legend(patches, legend, ncol=3, **LEGEND)
    costs = {k: v for k, v in series.items() if k.startswith("cost_") and np.any(np.asarray(v) > 0)}
    for k, v in costs.items():
        axes[3].plot(t, np.where(v > 0, v, np.nan), label=k[len("cost_") :])
    if costs:
        axes[3].set_yscale("log")
        axes[3].legend(ncol=len(costs), **LEGEND)
    else:
        axes[3].text(0.5, 0.5, "no cost terms (open-loop replay)", transform=axes[3].transAxes, ha="center")
        axes[3].set_yticks([])
    axes[3].set(ylabel="cost", xlabel="time (s)", xlim=(box[0], box[1]))
    titles = ["object error vs the reference", "links in contact", "contact per hand link"]
    for a, name in zip(axes, [*titles, "cost terms of the committed sample (log)"], strict=True):
        a.set_title(name, fontsize=10, loc="left")
        a.grid(alpha=0.25)
        a.tick_params(labelbottom=a is axes[-1])
        if a is not ax:
            _markers(a, *marks)
    fig.suptitle(title, fontsize=10)
    if path is not None:
        fig.savefig(path, dpi=100)
    return fig


def timeline(run_dir: str | Path, png: str | Path, **thresholds: float) -> tuple[list[str], list[str]]:
    """Draw one run's timeline to ``png`` and write its text next to it (``.txt``).

    ``thresholds``: ``position_threshold`` (m) and ``rotation_threshold`` (rad) of :func:`diagnose`.
    Returns the text's lines and warnings (a trial that did not finish, link names or milestone instants
    unknown); raises :class:`TimelineError` (:func:`load_run`).
    """
    record, series, warnings = load_run(run_dir)
    names, note = link_names(record, series["contacts"].shape[-1])
    milestones, note2 = milestone_times(record, series)
    facts = evidence(record, series)
    span = facts.pop("span")
    columns = [series.get(k) for k in ("time", "contacts", "expected_contacts", "object_position_error")]
    lines = diagnose(*columns, milestones=milestones, names=names, **facts, **thresholds)
    ttf, label = record.get("ttf"), method_name(record) or record.get("planner")  # (the groups' name)
    head = f"{record.get('task')} / {label} / seed {record.get('seed')}: status {record.get('status')}, "
    head += f"TTF {'n/a' if ttf is None else f'{ttf:.2f}'}, completed {facts['completed']}"
    notes = [n for n in (note, note2) if n]
    title = f"{Path(run_dir).resolve().name}: {head}\n{lines[0]}"
    marks = (facts["failure_time"], span, milestones)
    draw(series, names, marks, title, png, thresholds.get("position_threshold", POSITION_THRESHOLD))
    Path(png).with_suffix(".txt").write_text("\n".join([head, *lines, *notes]) + "\n")
    return [head, *lines], warnings + [f"{run_dir}: {n}" for n in notes]


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``python -m analysis.timeline``; returns 0, or 2 when a run could not be drawn."""
    parser = argparse.ArgumentParser(prog="python -m analysis.timeline", description=__doc__.split("\n\n")[0])
    parser.add_argument("run_dirs", nargs="+", metavar="RUN_DIR", help="trial run directories (trial.json)")
    parser.add_argument("--out-dir", help="write DIR/<run name>.png and .txt instead of RUN_DIR/timeline.*")
    what = "error that counts as losing the object"
    parser.add_argument("--position-threshold", type=float, default=40.0, help=f"position {what}, mm (40)")
    parser.add_argument("--rotation-threshold", type=float, default=30.0, help=f"rotation {what}, deg (30)")
    args = parser.parse_args(argv)
    thresholds = {"position_threshold": args.position_threshold / 1000}
    thresholds["rotation_threshold"] = np.radians(args.rotation_threshold)
    status, used = 0, set()
    for run in args.run_dirs:
        png = Path(run) / "timeline.png"
        if args.out_dir:
            where = Path(run).resolve()
            name = (
                f"{where.parent.name}_{where.name}" if where.name in used else where.name
            )  # runs named alike
            used.add(name)
            png = Path(args.out_dir) / f"{name}.png"
            png.parent.mkdir(parents=True, exist_ok=True)
        try:
            lines, warnings = timeline(run, png, **thresholds)
        except (TimelineError, OSError) as err:
            status = fail(err)
            continue
        for w in warnings:
            print("warning: " + w, file=sys.stderr)
        print(f"{run}: " + lines[0] + "".join("\n  " + line for line in lines[1:]))
        print(f"  wrote {png}, {png.with_suffix('.txt')}")
    return status


if __name__ == "__main__":
    raise SystemExit(main())
