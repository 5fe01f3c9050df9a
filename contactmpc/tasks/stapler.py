"""Stapler pickup and use: a base and a spring-returned top arm on a hinge, lying on a table."""

from __future__ import annotations

import mujoco
import numpy as np

from contactmpc.tasks.base import ObjectJoint, Task


class StaplerTask(Task):
    """Pick a stapler up from the table, reconfigure it in the hand and press its top arm.

    Geometry of a desk stapler: 16 cm long, 4 cm wide, 5 cm tall, 0.35 kg (base 0.2 kg, arm 0.15 kg).
    The arm hinges at the back of the base about the stapler's y axis. Its angle is 0 when pressed
    shut and rests at ``open_angle`` (the joint's upper limit), pushed there by a torsion spring whose
    rest angle lies beyond the limit, so a press of about ``press_force`` N at the arm's front is needed.

    Args:
        length: stapler length (m).
        width: stapler width (m).
        base_mass: mass of the base (kg).
        top_mass: mass of the top arm (kg).
        open_angle: resting angle of the arm (rad).
        spring_stiffness: torsion spring stiffness (N m / rad).
        position: (x, y) on the table (m).
        **kwargs: see :class:`~contactmpc.tasks.base.Task`.
    """

    name = "stapler"
    object_joints = (ObjectJoint("stapler_free", "free"), ObjectJoint("stapler_hinge", "hinge"))
    object_bodies = ("stapler", "stapler_top")
    view = {"lookat": (0.0, 0.0, 0.06), "distance": 0.6, "azimuth": 135.0, "elevation": -25.0}

    def __init__(
        self,
        length: float = 0.16,
        width: float = 0.04,
        base_mass: float = 0.2,
        top_mass: float = 0.15,
        open_angle: float = 0.22,
        spring_stiffness: float = 1.5,
        spring_rest: float = 0.35,
        position: tuple[float, float] = (0.0, 0.0),
        friction: float = 0.9,
        **kwargs,
    ) -> None:
        super().__init__(**kwargs)
        self.length = length
        self.width = width
        self.base_mass = base_mass
        self.top_mass = top_mass
        self.open_angle = open_angle
        self.spring_stiffness = spring_stiffness
        self.spring_rest = spring_rest
        self.position = tuple(position)
        self.friction = friction

    def add_objects(self, spec: mujoco.MjSpec) -> None:
        self.add_table(spec, height=self.table_height)
        hl, hw = self.length / 2, self.width / 2
        base_h = 0.0075  # half thickness of the base plate
        post = 0.012  # half size of the hinge post
        fric = [self.friction, 0.01, 0.001]
        dark, silver = [0.12, 0.12, 0.14, 1.0], [0.72, 0.74, 0.78, 1.0]
        base = spec.worldbody.add_body(
            name="stapler", pos=[self.position[0], self.position[1], self.table_height + base_h]
        )
        base.add_freejoint(name="stapler_free")
        base.add_geom(
            name="stapler_base_col",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[hl, hw, base_h],
            mass=0.8 * self.base_mass,
            rgba=dark,
            friction=fric,
        )
        base.add_geom(
            name="stapler_post_col",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=[-hl + post, 0, base_h + post],
            size=[post, 0.9 * hw, post],
            mass=0.2 * self.base_mass,
            rgba=dark,
            friction=fric,
        )
        hinge_pos = [-hl + post, 0, base_h + 2 * post]
        top = base.add_body(name="stapler_top", pos=hinge_pos)
        # Axis -y: a positive angle lifts the front of the arm (opens the stapler).
        top.add_joint(
            name="stapler_hinge",
            type=mujoco.mjtJoint.mjJNT_HINGE,
            axis=[0, -1, 0],
            range=[0.0, self.open_angle],
            limited=mujoco.mjtLimited.mjLIMITED_TRUE,
            stiffness=self.spring_stiffness,
            springref=self.spring_rest,
            # Hinge friction and the inertia of the spring/staple-pusher mechanism. With the bare
            # arm (0.02, 5e-4) the 10 ms planning model bounced the light arm under a finger press
            # and tipped the base (0.13-0.24 m/s, 5.6 mm penetration); the 1 ms plant did not.
            damping=0.1,
            armature=0.002,
        )
        arm_half = 0.011
        arm_len = hl - 0.004  # half length of the arm
        top.add_geom(
            name="stapler_top_col",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=[arm_len - post, 0, -0.002],
            size=[arm_len, 0.95 * hw, arm_half],
            mass=self.top_mass,
            rgba=silver,
            friction=fric,
        )
        spec.add_exclude(bodyname1="stapler", bodyname2="stapler_top")

    def initial_object_qpos(self, model: mujoco.MjModel) -> np.ndarray:
        """(8,) the stapler lying on the table with its arm resting open."""
        qo = super().initial_object_qpos(model)
        qo[-1] = self.open_angle
        return qo

    LIFT = 0.04  # m above the table to count as lifted
    PRESSED = 0.05  # rad: the arm's angle when pressed shut

    def conditions(self, qo: np.ndarray, expected: np.ndarray) -> dict[str, np.ndarray]:
        """Lifted off the table; the top arm pressed shut while lifted."""
        lifted = self.lift(qo) > self.LIFT
        arm = qo[:, self.layout.articulation_columns[0]]
        return {"lifted": lifted, "pressed": lifted & (arm < self.PRESSED)}
