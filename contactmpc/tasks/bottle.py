"""Water bottle lift and pour: a 6.5 cm x 20 cm, 0.45 kg bottle standing on a table."""

from __future__ import annotations

import mujoco
import numpy as np

from contactmpc.tasks.base import ObjectJoint, Task


class BottleTask(Task):
    """Lift a full water bottle from the table and tilt it to pour.

    Body: a cylinder (radius 3.25 cm, 20 cm tall incl. shoulder) of 0.45 kg (0.5 l of water in a
    light bottle), a narrower shoulder and a cap. The body frame is at the bottle's centre.

    Args:
        radius: bottle radius (m).
        height: bottle height without the cap (m).
        mass: total mass (kg).
        position: (x, y) on the table (m).
        **kwargs: see :class:`~contactmpc.tasks.base.Task`.
    """

    name = "bottle"
    object_joints = (ObjectJoint("bottle_free", "free"),)
    object_bodies = ("bottle",)
    view = {"lookat": (0.0, 0.0, 0.1), "distance": 0.7, "azimuth": 120.0, "elevation": -15.0}

    def __init__(
        self,
        radius: float = 0.0325,
        height: float = 0.20,
        mass: float = 0.45,
        position: tuple[float, float] = (0.0, 0.0),
        friction: float = 0.9,
        **kwargs,
    ) -> None:
        super().__init__(**kwargs)
        self.radius = radius
        self.height = height
        self.mass = mass
        self.position = tuple(position)
        self.friction = friction

    def add_objects(self, spec: mujoco.MjSpec) -> None:
        self.add_table(spec, height=self.table_height)
        h2 = self.height / 2
        body_half = 0.8 * h2  # straight cylindrical part; the rest is the shoulder
        bottle = spec.worldbody.add_body(
            name="bottle", pos=[self.position[0], self.position[1], self.table_height + h2]
        )
        bottle.add_freejoint(name="bottle_free")
        fric = [self.friction, 0.01, 0.001]
        bottle.add_geom(
            name="bottle_col",
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            pos=[0, 0, -h2 + body_half],
            size=[self.radius, body_half, 0],
            mass=0.93 * self.mass,
            rgba=[0.55, 0.75, 0.95, 0.85],
            friction=fric,
            condim=4,
        )
        shoulder_half = (self.height - 2 * body_half) / 2
        bottle.add_geom(
            name="bottle_shoulder",
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            pos=[0, 0, -h2 + 2 * body_half + shoulder_half],
            size=[0.6 * self.radius, shoulder_half, 0],
            mass=0.05 * self.mass,
            rgba=[0.55, 0.75, 0.95, 0.85],
            friction=fric,
            condim=4,
        )
        bottle.add_geom(
            name="bottle_cap",
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            pos=[0, 0, h2 + 0.008],
            size=[0.015, 0.008, 0],
            mass=0.02 * self.mass,
            rgba=[0.1, 0.35, 0.85, 1.0],
            friction=fric,
        )

    LIFT = 0.05  # m above the table to count as lifted
    POUR_TILT = 1.2  # rad (~70 deg) from upright to count as pouring
    POUR_TOLERANCE = 0.05  # m from the reference's position while pouring (held, not knocked over)
    SETTLE_POSITION = POUR_TOLERANCE  # the final milestone's, from the reference's final position

    def conditions(self, qo: np.ndarray, expected: np.ndarray) -> dict[str, np.ndarray]:
        """Lifted off the table; tilted to pour while lifted and where the reference pours."""
        lifted = self.lift(qo) > self.LIFT
        near = np.linalg.norm(qo[:, :3] - expected[:, :3], axis=-1) < self.POUR_TOLERANCE
        return {"lifted": lifted, "poured": lifted & near & (self.tilt(qo) > self.POUR_TILT)}
