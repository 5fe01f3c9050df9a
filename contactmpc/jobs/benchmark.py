"""The benchmark job (``conf/job/benchmark.yaml``): one planning iteration against the bare
``mujoco.rollout`` of the same batch.

    python launch.py job=benchmark preset=paper task=apple

Prints and writes ``benchmark.json``: per thread count, the median wall time of a planning iteration
(sampling, spline -> controls, rollout, cost, update), of the bare rollout of the same controls, their
ratio (the planner's overhead), and the speed-up from 1 thread to N threads.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Annotated

import mujoco
import numpy as np

from contactmpc.control.cost import TrackingCost
from contactmpc.control.planners.base import Planner
from contactmpc.control.samplers import SplineSpace
from contactmpc.records import write_json
from contactmpc.reference.source import get_reference
from contactmpc.scene import Scene
from contactmpc.trial import Trial
from contactmpc.validate import Ge, Le, checked


def _median_time(fn: Callable[[], object], repeats: int) -> float:
    fn()  # warm-up (compiles, allocates)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return float(np.median(times))


@checked
def benchmark_planner(
    make_scene: Callable[[], Scene],
    output_dir: str | Path,
    seed: Annotated[int, Ge(0)],
    sampler: SplineSpace,
    cost: TrackingCost,
    planner: Planner,
    threads: list[Annotated[int, Ge(1)]] | None = None,
    repeats: Annotated[int, Ge(1)] = 10,
    at_fraction: Annotated[float, Ge(0), Le(1)] = 0.5,
    reference_cache: str | None = "outputs/cache/references",
    **_,
) -> Path:
    """Time planning iterations and bare rollouts at the middle of the task (contacts expected).

    Args:
        make_scene: builds the scene.
        output_dir: where ``benchmark.json`` goes.
        seed: seed of the sampling noise.
        sampler, cost, planner: as for a trial (the planner's ``nthread`` is overridden).
        threads: thread counts to measure (default ``[1, 2]``).
        repeats: timed repetitions per measurement (the median is reported).
        at_fraction: where in the slowed reference to plan (fraction of its duration).
        reference_cache: cache directory of synthesised references.

    Returns:
        Path of ``benchmark.json``.
    """
    scene = make_scene()
    reference = get_reference(scene, reference_cache)
    rows = []
    for nthread in threads or [1, 2]:
        planner.close()
        planner.nthread = nthread
        trial = Trial(scene, reference, sampler, cost, planner, seed, progress=False)
        t = round(at_fraction * trial.track.duration / planner.dt) * planner.dt
        m = scene.plant_model
        data = mujoco.MjData(m)
        i = min(int(np.searchsorted(reference.time * scene.task.time_scale, t)), len(reference.time) - 1)
        scene.reset(data, reference.hand_qpos[i], reference.object_qpos[i])
        state = np.empty(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS))
        mujoco.mj_getState(m, data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        state[0] = t
        # The same candidates in both measurements: re-seed and restore the nominal every time.
        theta0 = planner.theta.copy()

        def plan_once(theta0=theta0, t=t, state=state) -> None:
            planner.theta[:] = theta0
            planner.plan(t, state, np.random.default_rng(seed))

        _, _, thetas = planner.candidates(np.random.default_rng(seed), t)
        ctrl = planner.controls(thetas, planner.basis(t))
        plan = _median_time(plan_once, repeats)
        bare = _median_time(lambda state=state, ctrl=ctrl: planner.engine.run(state, ctrl), repeats)
        rows.append(
            {"nthread": nthread, "plan_seconds": plan, "rollout_seconds": bare, "overhead": plan / bare}
        )
    planner.close()
    base = rows[0]["plan_seconds"]
    for row in rows:
        row["speedup"] = base / row["plan_seconds"]
    result = {
        "task": scene.task.name,
        "num_samples": planner.num_samples,
        "horizon_steps": planner.steps,
        "planner": type(planner).__name__,
        "rows": rows,
    }
    name = type(planner).__name__
    print(f"{scene.task.name}: {planner.num_samples} samples x {planner.steps} steps ({name})")
    print(f"{'threads':>8} {'plan [s]':>10} {'rollout [s]':>12} {'overhead':>9} {'speed-up':>9}")
    for r in rows:
        print(
            f"{r['nthread']:>8} {r['plan_seconds']:>10.4f} {r['rollout_seconds']:>12.4f} "
            f"{r['overhead']:>9.3f} {r['speedup']:>9.2f}"
        )
    return write_json(Path(output_dir) / "benchmark.json", result)
