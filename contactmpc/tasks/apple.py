"""Apple pickup and hand-off: an ~8 cm, 0.2 kg apple resting on a table."""

from __future__ import annotations

import mujoco
import numpy as np

from contactmpc.tasks.base import ObjectJoint, Task


class AppleTask(Task):
    """Pick an apple up from the table and carry it to a hand-off pose.

    The apple is a slightly flattened ellipsoid (8.2 cm wide, 7.4 cm tall) of 0.2 kg with a stem,
    so that it rests on its base instead of rolling.

    Args:
        radius: horizontal semi-axis (m).
        height_ratio: vertical / horizontal semi-axis.
        mass: apple mass (kg).
        position: (x, y) of the apple on the table (m).
        **kwargs: see :class:`~contactmpc.tasks.base.Task`.
    """

    name = "apple"
    object_joints = (ObjectJoint("apple_free", "free"),)
    object_bodies = ("apple",)
    view = {"lookat": (0.0, 0.0, 0.08), "distance": 0.6, "azimuth": 135.0, "elevation": -20.0}

    def __init__(
        self,
        radius: float = 0.041,
        height_ratio: float = 0.9,
        mass: float = 0.2,
        position: tuple[float, float] = (0.0, 0.0),
        friction: float = 1.0,
        **kwargs,
    ) -> None:
        super().__init__(**kwargs)
        self.radius = radius
        self.height_ratio = height_ratio
        self.mass = mass
        self.position = tuple(position)
        self.friction = friction

    def add_objects(self, spec: mujoco.MjSpec) -> None:
        self.add_table(spec, height=self.table_height)
        rz = self.radius * self.height_ratio
        apple = spec.worldbody.add_body(
            name="apple", pos=[self.position[0], self.position[1], self.table_height + rz]
        )
        apple.add_freejoint(name="apple_free")
        apple.add_geom(
            name="apple_col",
            type=mujoco.mjtGeom.mjGEOM_ELLIPSOID,
            size=[self.radius, self.radius, rz],
            mass=self.mass,
            rgba=[0.78, 0.08, 0.10, 1.0],
            friction=[self.friction, 0.01, 0.001],
            condim=4,
        )
        apple.add_geom(
            name="apple_stem",
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            fromto=[0, 0, rz - 0.004, 0.003, 0, rz + 0.012],
            size=[0.0025, 0, 0],
            mass=0.001,
            rgba=[0.35, 0.22, 0.08, 1.0],
            contype=0,
            conaffinity=0,
        )

    LIFT = 0.05  # m above the table to count as lifted
    HANDOFF_TOLERANCE = 0.03  # m from the reference's final (hand-off) position
    SETTLE_POSITION = HANDOFF_TOLERANCE  # the final milestone's: the final pose is the hand-off pose

    def conditions(self, qo: np.ndarray, expected: np.ndarray) -> dict[str, np.ndarray]:
        """Lifted off the table; lifted and at the reference's final (hand-off) position."""
        lifted = self.lift(qo) > self.LIFT
        at_handoff = np.linalg.norm(qo[:, :3] - expected[-1, :3], axis=-1) < self.HANDOFF_TOLERANCE
        return {"lifted": lifted, "handed_off": lifted & at_handoff}
