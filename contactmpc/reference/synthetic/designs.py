"""One synthetic demonstration per task: object keyframes, grasp targets and phase timings.

Each design is a :class:`~contactmpc.reference.synthetic.demonstration.Demonstration` with the same
interface; :func:`contactmpc.reference.synthetic.demonstration.synthesize` builds, gates and returns
the reference of a scene's task from one. A task's config names its design (``demonstration:`` with a
``_target_`` in ``conf/task/<task>.yaml``), so the task holds it as ``task.demonstration``. Times are
the demonstration's own (before the task's ``time_scale``).

Grasps are whole-hand power grasps (palm and phalanges), so that more than six links touch the object
while it is held: the time-to-failure rule of the paper only fires when more than six contacts are
expected.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy.spatial.transform import Rotation

from contactmpc.reference.synthetic.demonstration import Demonstration
from contactmpc.reference.synthetic.grasp import ContactTarget, GraspProblem
from contactmpc.reference.synthetic.kinematics import Kinematics
from contactmpc.reference.synthetic.phases import Approach, Close, Move, Open, Phase, Reach, Retreat

if TYPE_CHECKING:
    from contactmpc.scene import Scene

__all__ = ["AppleDemo", "BottleDemo", "DoorknobDemo", "StaplerDemo"]

_T = ContactTarget


def _free_pose(qo: np.ndarray, offset=(0.0, 0.0, 0.0), rotation: Rotation | None = None) -> tuple:
    """A free-body configuration moved by a world ``offset`` and turned by a world ``rotation`` about
    the body's origin (other columns of ``qo`` unchanged)."""
    out = np.asarray(qo, float).copy()
    out[:3] += np.asarray(offset, float)
    if rotation is not None:
        quat = (rotation * Rotation.from_quat(out[3:7], scalar_first=True)).as_quat(scalar_first=True)
        out[3:7] = quat if np.dot(quat, qo[3:7]) >= 0 else -quat
    return tuple(float(v) for v in out)


def _initial(scene: Scene, kin: Kinematics, position, offset, curl, thumb=(1.2, 0.3, 0.5, 0.5)) -> np.ndarray:
    """Initial guess of a grasp: the task's home wrist orientation, the wrist root at ``position +
    offset`` (world), the three long fingers curled alike (joints 0-3 = ``curl``) and the thumb."""
    init = scene.task.hand_home.copy()
    init[:3] = position + np.asarray(offset, float) - kin.root_offset
    init[kin.num_root :] = np.concatenate([curl, curl, curl, thumb]).astype(float)
    return init


def _power_grasp(body: str, qo: np.ndarray, init: np.ndarray, palm_toward: tuple) -> GraspProblem:
    """Palm, proximal, medial and tip links of the long fingers and medial, distal and tip of the thumb
    onto ``body``; the palm drawn to ``palm_toward`` (in the body's frame)."""
    targets = (
        _T("palm", toward=palm_toward),
        *(_T(f"{f}_{p}") for f in ("ff", "mf", "rf") for p in ("proximal", "medial", "tip")),
        *(_T(f"th_{p}") for p in ("medial", "distal", "tip")),
    )
    return GraspProblem(
        body=body,
        object_qpos=qo,
        initial=init,
        targets=targets,
        natural_weight=0.1,
        wrist_weight=3.0,
        clearance=0.004,
    )


class AppleDemo(Demonstration):
    """Apple: rest → lifted 15 cm → carried 12 cm forward and 15 cm sideways, turned 30° → held.

    Grasp: from above, palm on the apple's top, the three fingers wrapping its far side and the thumb
    its near side.
    """

    approach_offset = (0.0, 0.0, 0.06)

    def grasp_problem(self, scene: Scene, kin: Kinematics) -> GraspProblem:
        qo = scene.task.initial_object_qpos(kin.model)
        init = _initial(scene, kin, qo[:3], [0.05, 0.0, 0.053], [0, 1.0, 0.6, 0.3])
        return _power_grasp("apple", qo, init, palm_toward=(0.0, 0.0, 0.037))

    def phases(self, scene: Scene) -> list[Phase]:
        qo = scene.task.initial_object_qpos(scene.plant_model)
        lifted = _free_pose(qo, (0.0, 0.0, 0.15))
        handoff = _free_pose(qo, (0.12, 0.15, 0.17), Rotation.from_euler("z", 0.5))
        return [
            Approach(duration=1.5),
            Reach(duration=1.0),
            Close(duration=1.0),
            Move("lift", 1.5, lifted),
            Move("carry", 2.0, handoff),
            Move("hold", 1.0),
        ]


class BottleDemo(Demonstration):
    """Bottle: rest → lifted 12 cm → tilted 100° about the world x axis to pour (top away from the
    hand) → held pouring → back upright → held.

    Grasp: from the side (the hand on the -y side, fingers along +x), palm on the bottle's body, the
    fingers wrapping around its far side and the thumb around the near side.
    """

    approach_offset = (0.0, -0.06, 0.0)

    def grasp_problem(self, scene: Scene, kin: Kinematics) -> GraspProblem:
        qo = scene.task.initial_object_qpos(kin.model)
        init = _initial(scene, kin, qo[:3], [0.04, -0.045, -0.01], [0, 1.3, 1.0, 0.3])
        return _power_grasp("bottle", qo, init, palm_toward=(0.0, -0.0325, -0.01))

    def phases(self, scene: Scene) -> list[Phase]:
        qo = scene.task.initial_object_qpos(scene.plant_model)
        lifted = _free_pose(qo, (0.0, 0.0, 0.12))
        poured = _free_pose(lifted, rotation=Rotation.from_euler("x", -np.deg2rad(100.0)))
        return [
            Approach(duration=1.5),
            Reach(duration=1.0),
            Close(duration=1.0),
            Move("lift", 1.5, lifted),
            Move("pour", 2.0, poured),
            Move("hold_pour", 1.0),
            Move("upright", 2.0, lifted),
            Move("hold", 0.5),
        ]


class StaplerDemo(Demonstration):
    """Stapler: rest → lifted 10 cm → turned 90° about the vertical and pitched 25° front-down →
    arm pressed shut (hinge 0.22 → 0 rad) → press released → held.

    Grasp: from above with the fingers across the stapler (towards -y), palm on the top arm, fingers
    over the arm and down its far side, the thumb on the base's near side. The grasp is expressed in
    the *arm*'s frame (``stapler_top``): while the arm rests open that is the whole stapler, so lift
    and turn are a wrist motion (no in-hand regrasp: the "reorientation" is of hand and stapler
    together). For the press the grasp is re-solved at five hinge angles from open to shut (and in
    between where interpolation would penetrate), each warm-started from and regularised towards the
    previous one: the palm follows the arm down while fingers and thumb keep holding the sides.
    """

    approach_offset = (0.0, 0.0, 0.06)
    hinge_column = 7

    def grasp_problem(self, scene: Scene, kin: Kinematics) -> GraspProblem:
        qo = scene.task.initial_object_qpos(kin.model)
        init = _initial(scene, kin, qo[:3], [0.0, -0.03, 0.065], [0, 1.3, 0.3, 0.1])
        init[4:6] = [scene.task.open_angle, np.pi / 2]  # wrist ry, rz: palm along the open arm, fingers to -y
        targets = (
            _T("palm", weight=3.0, geoms=("stapler_top_col",), toward=(0.07, 0.0, 0.01)),
            *(_T(f"{f}_{p}") for f in ("ff", "mf", "rf") for p in ("proximal", "medial")),
            *(_T(f"{f}_distal", weight=0.5) for f in ("ff", "mf", "rf")),
            *(_T(f"th_{p}") for p in ("medial", "distal")),
        )
        return GraspProblem(
            body="stapler_top",
            object_qpos=qo,
            initial=init,
            targets=targets,
            target_geoms=("stapler_base_col", "stapler_post_col", "stapler_top_col"),
            natural_weight=0.1,
            clearance=0.004,
        )

    def regrasp_values(self, scene: Scene) -> tuple[int, tuple[float, ...], None]:
        # Re-solved with the stapler at rest on the table: the table then keeps the fingers from
        # reaching under the base, which keeps consecutive grasps alike (no jumps of the thumb).
        values = tuple(float(v) for v in np.linspace(scene.task.open_angle, 0.0, 5))
        return self.hinge_column, values, None

    def phases(self, scene: Scene) -> list[Phase]:
        qo = scene.task.initial_object_qpos(scene.plant_model)
        lifted = _free_pose(qo, (0.0, 0.0, 0.10))
        turned = _free_pose(lifted, rotation=Rotation.from_euler("yz", [np.deg2rad(25.0), np.pi / 2]))
        pressed = np.array(turned)
        pressed[self.hinge_column] = 0.0
        return [
            Approach(duration=1.5),
            Reach(duration=1.0),
            Close(duration=1.0),
            Move("lift", 1.5, lifted),
            Move("turn", 2.0, turned),
            Move("press", 1.5, tuple(pressed)),
            Move("hold_press", 0.5),
            Move("release_press", 1.5, turned),
            Move("hold", 0.5),
        ]


class DoorknobDemo(Demonstration):
    """Doorknob: knob twisted to 0.9 rad (past ``unlock_angle``) → door pulled open to -0.6 rad with the
    knob held → knob let back to 0 → fingers open → hand backs off.

    Grasp: palm on the knob's face, the fingers around its side and behind it, the thumb opposite; the
    hand rides with the knob body (its twist and the door's swing).
    """

    approach_offset = (0.0, -0.07, 0.0)
    twist = 0.9
    door_open = -0.6

    def grasp_problem(self, scene: Scene, kin: Kinematics) -> GraspProblem:
        qo = scene.task.initial_object_qpos(kin.model)
        kin.set(scene.task.hand_home, qo)
        knob = kin.body_pose(kin.body_id("knob")).pos
        init = _initial(scene, kin, knob, [0.035, -0.032, 0.0], [0, 1.5, 1.2, 0.5])
        targets = (
            _T("palm", weight=2.0, toward=(0.0, -0.02, 0.0)),
            *(_T(f"{f}_{p}") for f in ("ff", "mf", "rf") for p in ("medial", "tip")),
            *(_T(f"{f}_proximal", weight=0.5) for f in ("ff", "mf", "rf")),
            *(_T(f"th_{p}") for p in ("distal", "tip")),
        )
        return GraspProblem(
            body="knob",
            object_qpos=qo,
            initial=init,
            targets=targets,
            target_geoms=("knob_col", "knob_shaft"),
            natural_weight=0.1,
            clearance=0.004,
        )

    def phases(self, scene: Scene) -> list[Phase]:
        qo = np.asarray(scene.task.initial_object_qpos(scene.plant_model), float)  # (door, knob)
        twisted = qo + [0.0, self.twist]
        pulled = qo + [self.door_open, self.twist]
        released = qo + [self.door_open, 0.0]
        return [
            Approach(duration=1.5),
            Reach(duration=1.0),
            Close(duration=1.0),
            Move("twist", 1.5, tuple(twisted)),
            Move("pull", 2.5, tuple(pulled)),
            Move("hold", 0.5),
            Move("untwist", 1.0, tuple(released)),
            Open(duration=1.0),
            Retreat(duration=1.0),
        ]
