"""The doorknob's release replayed from each of the method's trials: how fast the knob leaves the hand
when the hand lets go in other ways (the method study's "Where the method falls short").

From each kept doorknob trial of the method that has its time series, the plant is put in the trial's
recorded configuration 0.5 s before the contact span ends (velocities zeroed: the series keep no
velocities, so a replay is near the trial, not the trial), the trial's recorded hand targets are replayed
to the span's end, and then each release of :data:`RELEASES` is applied open-loop for 12 s. The knob's
speed is read as the report's ``leaving_speed`` reads it (the mean speed from 0.2 to 1.2 s after the last
sample at which a hand link touches it). The trial's own release is replayed once more on a slide with
:data:`FRICTION` N of dry friction (``task.slide_friction``, not the authors'). Writes
``figures/release_replay.csv``, which the report reads (so a clone without the time series makes the same
report):

    CONTACTMPC_PAPER_DATA=... python studies/method/release_replay.py
"""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np
import pandas as pd
from hydra.utils import instantiate
from omegaconf import OmegaConf

from contactmpc.labels import method_name

HERE = Path(__file__).resolve().parent
OUT = HERE / "figures" / "release_replay.csv"
BEFORE = 0.5  # s before the contact span ends that a replay starts
AFTER = 12.0  # s of release replayed
PLAN = 0.01  # s between the samples a replay reads the knob at (the planner's step)
METHOD = "grasp_release_ahead_acquire"
FRICTION = 0.5  # N of dry friction on the slide for the last replay (task.slide_friction)

#: A release: the hand targets (J,) at ``s`` seconds after the span's end, given the targets the trial
#: applied at the span's end (``held``), the measured hand configuration then (``q``), the flat hand's
#: finger targets (``flat``) and the trial's own targets after the span's end (``recorded(s)``).
Release = Callable[[float, dict], np.ndarray]


def relax_open(relax: float, opening: float, wrist: bool) -> Release:
    """Targets that go linearly over ``relax`` s to where the fingers (and with ``wrist`` the wrist)
    measured at the span's end, then the fingers' linearly over ``opening`` s to the flat hand."""

    def release(s: float, at: dict) -> np.ndarray:
        goal = at["held"].copy()
        goal[6:] = at["q"][6:]
        if wrist:
            goal[:6] = at["q"][:6]
        out = at["held"] + min(s / relax, 1.0) * (goal - at["held"])
        w = float(np.clip((s - relax) / opening, 0.0, 1.0))
        out[6:] += w * (at["flat"] - out[6:])
        return out

    return release


#: The releases replayed, by the name the report gives them.
RELEASES: dict[str, Release] = {
    "recorded": lambda s, at: at["recorded"](s),
    "grip held": lambda s, at: at["held"],
    "fingers relaxed 1 s, opened over 4 s": relax_open(1.0, 4.0, wrist=False),
    "fingers and wrist relaxed 1 s, opened over 4 s": relax_open(1.0, 4.0, wrist=True),
    "fingers and wrist relaxed 2 s, opened over 8 s": relax_open(2.0, 8.0, wrist=True),
}


def scene_of(
    record: dict, paper_data: str, slide_friction: float = 0.0, planner_timestep: float | None = None
):
    """The trial's scene, built from its recorded config with the authors' data at ``paper_data`` (and
    ``slide_friction`` N of dry friction on the slide where it is not 0; the planning model stepped at
    ``planner_timestep`` where it is given)."""
    cfg = OmegaConf.create(record["config"])
    cfg.task.paper_data = paper_data
    if slide_friction:
        cfg.task.slide_friction = slide_friction
    if planner_timestep is not None:
        cfg.scene.planner_timestep = planner_timestep
    return instantiate(cfg.scene)(hand=instantiate(cfg.hand), task=instantiate(cfg.task))


def series_rows(name: str, here: Path, folders, row, path: Path) -> int:
    """A per-trial script's main: ``row(run)`` (a dict, or None to skip) of every kept trial under
    ``here``'s ``folders`` whose time series is there, written to ``path`` (:func:`write_rows`); its exit
    status (1 without a row, saying so as ``name``)."""
    runs = sorted(p.parent for folder in folders for p in (here / folder).glob("*/timeseries.npz"))
    rows = [r for run in runs if (run / "trial.json").is_file() and (r := row(run))]
    if not rows:
        print(f"{name}: no kept trial with its time series under {here}", file=sys.stderr)
        return 1
    write_rows(rows, path)
    print(f"{name}: {len(rows)} trials -> {path}")
    return 0


def write_rows(rows: list[dict], path: Path) -> None:
    """Write a script's rows to its CSV (``path``, its folder made where missing), as the report reads it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    pd.DataFrame(rows).to_csv(path, index=False, float_format="%.6g")


def recorded_target(series, at_time: float) -> np.ndarray:
    """The hand targets a trial's time series (``time``, ``hand_target``) had applied at ``at_time``: the
    last sample at or before it."""
    t = series["time"]
    return series["hand_target"][min(int(np.searchsorted(t, at_time, side="right")) - 1, len(t) - 1)]


def replay(scene, series, span_end: float, release: Release) -> tuple[float, float, float, float] | None:
    """``(let_go, speed, bound, off)``: when the hand last touches the knob (s after the span's end), the
    knob's mean speed from 0.2 to 1.2 s after that (m/s), the most it could keep and end within the task's
    tolerance (m/s), and how far from the reference's final position it is when the replay ends (m);
    ``None`` where the hand still holds it 1.2 s before the replay ends."""
    m = scene.plant_model
    t = series["time"]
    i0 = int(np.searchsorted(t, span_end - BEFORE))
    d = mujoco.MjData(m)
    scene.reset(d, hand_qpos=series["hand_qpos"][i0], object_qpos=series["object_qpos"][i0])

    def recorded(at_time: float) -> np.ndarray:
        return recorded_target(series, at_time)

    at = {
        "held": recorded(span_end - 1e-9).copy(),
        "flat": np.clip(0.0, *m.actuator_ctrlrange[scene.index.actuators][6:].T),
        "recorded": lambda s: recorded(span_end + s),
    }
    steps = int(round((span_end - t[i0] + AFTER) / m.opt.timestep))
    every = int(round(PLAN / m.opt.timestep))
    times, knob, last = [], [], None
    for k in range(steps):
        now = t[i0] + k * m.opt.timestep
        if now < span_end:
            u = recorded(now)
        else:
            if "q" not in at:
                at["q"] = d.qpos[scene.index.hand_qpos].copy()
            u = release(now - span_end, at)
        d.ctrl[scene.index.actuators] = u
        mujoco.mj_step(m, d)
        if k % every == 0:
            times.append(now)
            knob.append(float(d.qpos[scene.index.object_qpos][0]))
            if scene.link_contacts(d).any():
                last = now
    times_a, knob_a = np.array(times), np.array(knob)
    if last is None or times_a[-1] < last + 1.2:
        return None
    speed = abs(np.interp(last + 1.2, times_a, knob_a) - np.interp(last + 0.2, times_a, knob_a))
    settle = scene.task.SETTLE_ARTICULATION
    off = abs(knob_a[-1] - float(series["expected_object_qpos"][-1, 0]))
    return last - span_end, float(speed), settle / float(t[-1] - last), float(off)


def main() -> int:
    paper_data = os.environ.get("CONTACTMPC_PAPER_DATA")
    if not paper_data:
        print("release_replay: error: set CONTACTMPC_PAPER_DATA to the authors' mjpc/tasks", file=sys.stderr)
        return 2
    rows = []
    for path in sorted((HERE / "records").glob("*task=paper_doorknob*/trial.json")):
        record = json.loads(path.read_text())
        series_path = path.parent / "timeseries.npz"
        if not series_path.is_file() or method_name(record) != METHOD:
            continue
        series = np.load(series_path)
        runs = [(0.0, name, release) for name, release in RELEASES.items()] + [
            (FRICTION, "recorded", RELEASES["recorded"])
        ]
        scenes = {f: scene_of(record, paper_data, f) for f in {f for f, _, _ in runs}}
        for friction, name, release in runs:
            found = replay(scenes[friction], series, record["contact_span_end"], release)
            let_go, speed, bound, off = found if found is not None else (np.nan,) * 4
            rows.append({"record": path.parent.name, "seed": record["seed"], "release": name,
                         "friction": friction, "let_go": let_go, "speed": speed, "bound": bound,
                         "off": off, "before": BEFORE})  # fmt: skip
            print(
                f"seed {record['seed']} {name} (slide friction {friction:g} N): let go {let_go:+.2f} s, "
                f"{1e3 * speed:.1f} mm/s, {1e3 * off:.0f} mm from the final position at the end"
            )
    if not rows:
        print("release_replay: error: no doorknob trial of the method with its time series", file=sys.stderr)
        return 1
    write_rows(rows, OUT)
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
