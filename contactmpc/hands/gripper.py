"""A minimal two-finger parallel gripper on the same floating wrist as the Allegro hand.

It exists to keep the hand interface honest (a second hand, with 2 finger joints instead of 16, runs
through the same scene, sampler spaces, cost and planners) and as the smallest example of adding a
hand: one module like this, one YAML in ``conf/hand/``, one test.

In the wrist root's frame the palm is a plate in the x-y plane; the two fingers hang along +z (so a
root turned by rx = pi points them down) and close towards each other along y on slide joints.
"""

from __future__ import annotations

from typing import Annotated

import mujoco

from contactmpc.hands.base import FloatingHand
from contactmpc.validate import ConfigError, Ge, Gt, checked

__all__ = ["ParallelGripper"]


class ParallelGripper(FloatingHand):
    """Two slide fingers under a palm plate, each with a force-limited position servo.

    Args:
        stroke: travel of each finger from open (0) to closed (m).
        opening: distance between the finger pads when open (m).
        finger_length: length of each finger (m).
        kp_finger: position gain of the finger servos (N/m).
        damping_finger: finger slide damping (N·s/m).
        force_limit_finger: finger servo force limit (N).
        name: identifier of this hand (for records).
        **kwargs: the wrist, see :class:`~contactmpc.hands.base.FloatingHand`.
    """

    FINGER_JOINTS: tuple[str, ...] = ("left_slide", "right_slide")
    LINKS: tuple[str, ...] = ("palm", "left_finger", "right_finger")
    FLEXION: tuple[str, ...] = FINGER_JOINTS

    @checked
    def __init__(
        self,
        stroke: Annotated[float, Gt(0)] = 0.035,
        opening: Annotated[float, Gt(0)] = 0.1,
        finger_length: Annotated[float, Gt(0)] = 0.06,
        kp_finger: Annotated[float, Ge(0)] = 200.0,
        damping_finger: Annotated[float, Ge(0)] = 20.0,
        force_limit_finger: Annotated[float, Gt(0)] = 20.0,
        name: str = "parallel_gripper",
        **kwargs,
    ) -> None:
        super().__init__(name=name, **kwargs)
        if not stroke < opening / 2:
            raise ConfigError(
                f"{type(self).__name__}.stroke must be < opening / 2 ({opening / 2:g}), got {stroke!r}"
            )
        self.stroke = float(stroke)
        self.opening = float(opening)
        self.finger_length = float(finger_length)
        self.kp_finger = float(kp_finger)
        self.damping_finger = float(damping_finger)
        self.force_limit_finger = float(force_limit_finger)

    def finger_range(self, joint: str) -> tuple[float, float]:
        return (0.0, self.stroke)

    def add_fingers(
        self, spec: mujoco.MjSpec, root: mujoco.MjsBody, hinge_unit: float
    ) -> dict[str, mujoco.MjsBody]:
        palm = root.add_body(name="palm")
        half_width = 0.5 * self.opening + 0.01
        palm.add_geom(
            name="palm_col", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.02, half_width, 0.01],
            mass=0.3, rgba=[0.27, 0.27, 0.27, 1.0],
        )  # fmt: skip
        bodies = {"palm": palm}
        half = 0.5 * self.finger_length
        for link, joint, side in (("left_finger", "left_slide", 1.0), ("right_finger", "right_slide", -1.0)):
            finger = palm.add_body(name=link, pos=[0.0, side * (0.5 * self.opening + 0.005), 0.01])
            finger.add_joint(
                name=joint, type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0.0, -side, 0.0],
                range=[0.0, self.stroke], limited=mujoco.mjtLimited.mjLIMITED_TRUE,
                damping=self.damping_finger,
            )  # fmt: skip
            finger.add_geom(
                name=f"{link}_col", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.012, 0.005, half],
                pos=[0.0, 0.0, half], mass=0.05, rgba=[0.9, 0.9, 0.9, 1.0], condim=4,
            )  # fmt: skip
            self.add_position_actuator(
                spec, joint, self.kp_finger, (0.0, self.stroke), self.force_limit_finger
            )
            bodies[link] = finger
        return bodies
