"""A finished trial as pictures, from its kept series: ``python -m analysis.frames RUN_DIR [RUN_DIR ...]``.

Per trial (``trial.json`` + ``timeseries.npz``), one PNG: the plant as logged at chosen control instants
(touching links tinted orange, the expected contacts drawn as green and red points joined by a line) above
the reference at the same instants. Nothing is simulated again: the scene is built from the record's config
(a paper task reads the authors' data from ``--paper-data`` or ``CONTACTMPC_PAPER_DATA``, else from where
the record says) and the reference from the task, as the trial built them (a ``retarget`` the trial applied
to its reference is not shown in the reference's row). By default the instants run from 0.5 s before the
reference's first expected contact to 3 s after it, with the TTF failure among them; ``--at`` names others.
Writes ``RUN_DIR/frames.png`` (``--out-dir``: ``DIR/<run name>_frames.png``).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

from analysis._cli import fail
from analysis.timeline import TimelineError, load_run

#: Default instants, seconds after the reference's first expected contact.
AROUND_CONTACT = (-0.5, 0.0, 0.5, 1.0, 1.5, 2.0, 3.0)
#: The task camera's distance times this, looking at the object.
ZOOM = 0.4


def instants(record: dict, time: np.ndarray, at: list[float] | None = None) -> list[float]:
    """The panels' control times: ``at``, else :data:`AROUND_CONTACT` after the record's first expected
    contact with its TTF failure instant among them (7 evenly spaced over the series without a contact
    span); only those inside the series, in order, none within 50 ms of another."""
    lo, hi = float(time[0]), float(time[-1])
    if at:
        picks = list(at)
    elif (start := record.get("contact_span_start")) is not None:
        picks = [start + d for d in AROUND_CONTACT]
        if record.get("failure_time") is not None:
            picks.append(float(record["failure_time"]))
    else:
        picks = list(np.linspace(lo, hi, 7))
    out: list[float] = []
    for t in sorted(t for t in picks if lo - 1e-9 <= t <= hi + 1e-9):
        if not out or t - out[-1] > 0.05:
            out.append(t)
    return out


def scene_and_reference(record: dict, paper_data: str | None = None):
    """The trial's scene and reference, built from the record's config (``paper_data``: the authors'
    ``mjpc/tasks`` for a paper task, else the record's own)."""
    from omegaconf import OmegaConf

    import launch
    from contactmpc.reference.source import get_reference

    cfg = OmegaConf.create(record.get("config") or {})
    if "scene" not in cfg or "task" not in cfg or "hand" not in cfg:
        raise TimelineError("the record has no config to build its scene from")
    if paper_data and "paper_data" in cfg.task:
        cfg.task.paper_data = paper_data
    scene = launch.build_scene(cfg)
    cache = OmegaConf.select(cfg, "job.reference_cache", default=None)
    return scene, get_reference(scene, cache)


def frames(
    run_dir: str | Path,
    png: str | Path,
    at: list[float] | None = None,
    paper_data: str | None = None,
    zoom: float = ZOOM,
    size: tuple[int, int] = (240, 320),
) -> tuple[Path, list[float], list[str]]:
    """Render one run's frames to ``png``; the path, the instants shown and warnings (a trial that did not
    finish). Raises :class:`TimelineError` for a run that cannot be drawn."""
    from contactmpc.render import render_trial_frames

    record, series, warnings = load_run(run_dir)
    if "qpos" not in series:
        raise TimelineError(f"{run_dir}: its series has no qpos to show")
    times = instants(record, series["time"], at)
    if not times:
        raise TimelineError(f"{run_dir}: none of the instants {at} is inside the trial's series")
    scene, reference = scene_and_reference(record, paper_data)
    path = render_trial_frames(scene, series, reference, png, times, size=size, zoom=zoom)
    return path, times, warnings


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``python -m analysis.frames``; returns 0, or 2 when a run could not be drawn."""
    parser = argparse.ArgumentParser(prog="python -m analysis.frames", description=__doc__.split("\n\n")[0])
    parser.add_argument("run_dirs", nargs="+", metavar="RUN_DIR", help="trial run directories (trial.json)")
    parser.add_argument("--at", type=float, nargs="+", metavar="T", help="control times to show (s)")
    parser.add_argument("--out-dir", help="write DIR/<run name>_frames.png instead of RUN_DIR/frames.png")
    parser.add_argument("--paper-data", default=os.environ.get("CONTACTMPC_PAPER_DATA"),
                        help="the authors' mjpc/tasks (default: $CONTACTMPC_PAPER_DATA)")  # fmt: skip
    parser.add_argument(
        "--zoom", type=float, default=ZOOM, help=f"camera distance x this, on the object ({ZOOM})"
    )
    parser.add_argument("--size", type=int, nargs=2, default=(240, 320), metavar=("H", "W"),
                        help="one panel's height and width in pixels (240 320)")  # fmt: skip
    args = parser.parse_args(argv)
    if args.zoom <= 0 or min(args.size) < 16:
        parser.error(f"--zoom must be > 0 and --size at least 16 x 16, got {args.zoom} and {args.size}")
    status = 0
    for run in args.run_dirs:
        png = Path(run) / "frames.png"
        if args.out_dir:
            png = Path(args.out_dir) / f"{Path(run).resolve().name}_frames.png"
        try:
            path, times, warnings = frames(run, png, args.at, args.paper_data, args.zoom, tuple(args.size))
        except (TimelineError, OSError) as err:
            status = fail(err)
            continue
        except Exception as err:  # the scene or reference could not be built from the record
            status = fail(TimelineError(f"{run}: cannot rebuild its scene ({type(err).__name__}: {err})"))
            continue
        for w in warnings:
            print("warning: " + w, file=sys.stderr)
        print(f"{run}: wrote {path} ({len(times)} instants, {times[0]:.2f}-{times[-1]:.2f} s)")
    return status


if __name__ == "__main__":
    raise SystemExit(main())
