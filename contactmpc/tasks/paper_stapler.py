"""The paper's stapler (``stapler_staple_2``): pick the stapler up and turn it to its use pose."""

from __future__ import annotations

import mujoco
import numpy as np

from contactmpc.tasks.base import ObjectJoint, quat_angle
from contactmpc.tasks.paper import PaperTask


class PaperStaplerTask(PaperTask):
    """The authors' stapler: five convex pieces (three binder pieces, head, stand) at density 1250, on
    their table, a plane at z = 0.845 in body ``tablebody``. As in their scene, the hand does not collide
    with the table (their ``<exclude>`` of every hand body with ``tablebody``).

    Milestones: *lifted* (5 cm above its start) and *turned*: within ``TURN_TOLERANCE`` of the
    reference's use pose (its orientation where it is turned furthest from the start), both while held.
    """

    name = "paper_stapler"
    demo = "stapler_staple_2"
    object_name = "stapler"
    slowdown = 7.0
    hand_mount = (-0.4805667866948928, 0.58770014610545768, 1.2733766645971997)
    object_joints = (ObjectJoint("stapler_sim_free", "free"),)
    object_bodies = ("stapler_sim",)
    TURN_TOLERANCE = np.radians(30.0)
    SETTLE_ROTATION = TURN_TOLERANCE  # the final milestone's, from the reference's final orientation
    # their "Recording" camera's direction, closer
    view = {"lookat": (0.05, -0.45, 1.1), "distance": 1.2, "azimuth": 83.5, "elevation": -20.0}

    def add_objects(self, spec) -> None:
        self.add_floor(spec)
        table = spec.worldbody.add_body(name="tablebody")
        table.add_geom(
            name="table",
            type=mujoco.mjtGeom.mjGEOM_PLANE,
            pos=[0.13301, -0.96019, 0.84498],
            size=[0.5, 0.5, 0.5],
            rgba=[0.55, 0.55, 0.57, 1.0],
            friction=[1.0, 0.005, 0.0001],
        )
        # Their scene lets the hand pass through the table (the hand bodies are already in the spec).
        for body in spec.bodies:
            if body.name != "tablebody" and body.name and self._is_hand(body):
                spec.add_exclude(bodyname1=body.name, bodyname2="tablebody")
        self.add_free_object(
            spec, ("binder0", "binder1", "binder2", "head", "stand"), 1250.0, (0.75, 0.12, 0.1, 1.0)
        )

    @staticmethod
    def _is_hand(body) -> bool:
        """Whether ``body`` is the hand's root or one of its descendants."""
        while body is not None and body.name != "world":
            if body.name == "hand_root":
                return True
            body = body.parent
        return False

    def conditions(self, qo: np.ndarray, expected: np.ndarray) -> dict[str, np.ndarray]:
        """Lifted; lifted and within ``TURN_TOLERANCE`` of the reference's use pose in the trial."""
        lifted = self.lift(qo) > self.LIFT
        use = self.layout.quaternion(expected)[int(np.argmax(self.rotation_from_start(expected)))]
        turned = quat_angle(self.layout.quaternion(qo), use[None]) < self.TURN_TOLERANCE
        return {"lifted": lifted, "turned": lifted & turned}
