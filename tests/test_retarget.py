"""retarget=wrist (contactmpc.reference.retarget): the paper reference's grasp corrected by one wrist
translation. Off (the default), the demonstration is the authors' motion as imported, bit for bit; on, only
the wrist's slides move, only around the contact span, and the links the reference expects in contact end
nearer the object's surface. The real-data tests skip without ``CONTACTMPC_PAPER_DATA``."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from contactmpc.reference.consistency import FAILURE_MIN_EXPECTED
from contactmpc.reference.data import Reference
from contactmpc.reference.paper.demonstration import PaperDemonstration
from contactmpc.reference.retarget import contact_distances, offset_wrist
from contactmpc.reference.synthetic.kinematics import Kinematics

PAPER_DATA = os.environ.get("CONTACTMPC_PAPER_DATA", "")
needs_data = pytest.mark.skipif(
    not (PAPER_DATA and Path(PAPER_DATA, "allegro").is_dir()),
    reason="CONTACTMPC_PAPER_DATA does not name the authors' mjpc/tasks directory",
)


def _toy_reference() -> Reference:
    n, links = 11, 2
    active = np.zeros((n, links), bool)
    active[4:7] = True  # contact from t = 0.4 to 0.6
    return Reference(
        time=np.linspace(0.0, 1.0, n),
        hand_qpos=np.zeros((n, 8)),
        object_qpos=np.zeros((n, 1)),
        contact_active=active,
        contact_link_point=np.zeros((n, links, 3)),
        contact_object_point=np.zeros((n, links, 3)),
        contact_object_body=np.zeros((n, links), int),
        link_names=np.array(["a", "b"]),
        joint_names=np.array([f"j{i}" for i in range(8)]),
        object_bodies=np.array(["o"]),
        task="toy",
    )


def test_offset_eases_in_and_out_around_the_contact_span() -> None:
    ref = _toy_reference()
    out = offset_wrist(ref, np.array([0.01, -0.02, 0.03]), ramp=0.2)
    weight = out.hand_qpos[:, 0] / 0.01
    # 0 until ramp before the first contact, 1 over the span, 0 from ramp after the last
    np.testing.assert_allclose(weight, [0, 0, 0, 0.5, 1, 1, 1, 0.5, 0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(out.hand_qpos[:, 1], -2 * out.hand_qpos[:, 0])
    np.testing.assert_array_equal(out.hand_qpos[:, 3:], ref.hand_qpos[:, 3:])  # only the slides move
    assert out.meta["wrist_offset"] == pytest.approx([0.01, -0.02, 0.03])
    assert "wrist_offset" not in ref.meta  # the input is not changed


def test_ramp_must_be_positive() -> None:
    with pytest.raises(ValueError, match="wrist_fit_ramp"):
        PaperDemonstration(wrist_fit=True, wrist_fit_ramp=0.0)


def test_off_composes_the_same_config(compose) -> None:
    """retarget=none adds nothing: the config (and so the trial) of a paper task without the group."""
    base = compose(["task=paper_apple"])
    off = compose(["task=paper_apple", "retarget=none"])
    assert off == base
    on = compose(["task=paper_apple", "retarget=wrist"])
    assert on.task.demonstration.wrist_fit is True
    assert "wrist_fit" not in base.task.demonstration


def test_synthetic_task_refuses_it_in_one_line(repo_root: Path, tmp_path: Path) -> None:
    proc = subprocess.run(
        [sys.executable, "launch.py", "task=apple", "retarget=wrist", "duration=0.05",
         f"hydra.run.dir={tmp_path}"],
        cwd=repo_root, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    lines = [ln for ln in proc.stderr.splitlines() if "error" in ln]
    assert proc.returncode != 0 and lines and "retarget=wrist" in lines[-1] and "paper" in lines[-1], (
        proc.stderr[-2000:]
    )
    assert "task 'AppleTask'" in lines[-1], lines[-1]  # the task named, not '?'


@needs_data
@pytest.mark.parametrize("task", ["paper_apple", "paper_stapler"])
def test_real_fit_puts_the_expected_links_nearer_the_surface(task: str, scene_for) -> None:
    from contactmpc.reference.source import get_reference

    off = get_reference(scene_for(task))
    scene = scene_for(task, "retarget=wrist")
    on = get_reference(scene)  # validated: names, widths, joint limits
    np.testing.assert_array_equal(on.hand_qpos[:, 3:], off.hand_qpos[:, 3:])
    np.testing.assert_array_equal(on.object_qpos, off.object_qpos)
    moved = np.flatnonzero(np.any(on.hand_qpos[:, :3] != off.hand_qpos[:, :3], axis=1))
    contact = np.flatnonzero(off.contact_active.any(axis=1))
    ramp = 1.0 / scene.task.time_scale  # wrist_fit_ramp (1 s of the trial) in the reference's time
    assert on.time[moved[0]] >= on.time[contact[0]] - ramp - 1e-9
    assert on.time[moved[-1]] <= on.time[contact[-1]] + ramp + 1e-9
    offset = np.asarray(on.meta["wrist_offset"])
    assert 0.005 < np.linalg.norm(offset) < 0.05  # measured 18 mm (apple), 22 mm (stapler)

    kin = Kinematics(scene)
    pairs = kin.collision_pairs(kin.link_geoms, kin.object_geoms)
    grasp = np.flatnonzero(off.contact_active.sum(axis=1) > FAILURE_MIN_EXPECTED)[::7]

    def mean_miss(ref: Reference) -> float:
        return float(
            np.mean(
                np.concatenate(
                    [np.abs(contact_distances(kin, pairs, ref.hand_qpos[t], ref.object_qpos[t]))[
                        ref.contact_active[t]] for t in grasp]
                )
            )
        )  # fmt: skip

    before, after = mean_miss(off), mean_miss(on)
    print(
        f"\n{task}: offset {np.round(1e3 * offset, 1)} mm; "
        f"mean |distance| {1e3 * before:.1f} -> {1e3 * after:.1f} mm"
    )
    assert after < 0.85 * before  # measured 0.59-0.63 of it
