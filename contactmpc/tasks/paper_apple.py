"""The paper's apple pass (``apple_pass_1``): pick the apple up from the table and hand it off."""

from __future__ import annotations

import numpy as np

from contactmpc.tasks.base import ObjectJoint
from contactmpc.tasks.paper import PaperTask


class PaperAppleTask(PaperTask):
    """The authors' apple: two convex pieces (stem, fruit) at density 375, on their table (a 1 m box,
    top at z = 0.84). As their code does, the trial starts the apple 12 mm along +y from the reference's
    first pose (``allegro.h``: "allow sim body to start slightly inside table geom").

    Milestones: *lifted* (5 cm above its start) and *handed_off*: within ``HANDOFF_TOLERANCE`` of the
    reference's hand-off pose (where the reference holds the apple highest), both while held.
    """

    name = "paper_apple"
    demo = "apple_pass_1"
    object_name = "apple"
    slowdown = 8.0
    hand_mount = (-0.559059652010766, 1.009854895156828, 1.3654812428175624)
    object_joints = (ObjectJoint("apple_sim_free", "free"),)
    object_bodies = ("apple_sim",)
    START_OFFSET = (0.0, 0.012, 0.0)
    HANDOFF_TOLERANCE = 0.05
    SETTLE_POSITION = HANDOFF_TOLERANCE  # the final milestone's: from where the reference sets it down
    # their "Recording" camera's direction, closer
    view = {"lookat": (0.12, -0.25, 1.15), "distance": 1.3, "azimuth": 171.0, "elevation": -15.0}

    def add_objects(self, spec) -> None:
        self.add_floor(spec)
        self.add_box_table(spec, (0.22647, -0.4, 0.34))
        self.add_free_object(spec, ("stem", "fruit"), 375.0, (0.78, 0.08, 0.10, 1.0))

    def start_object_qpos(self, reference_qo: np.ndarray) -> np.ndarray:
        out = np.array(reference_qo, dtype=float, copy=True)
        out[:3] += self.START_OFFSET
        return out

    def conditions(self, qo: np.ndarray, expected: np.ndarray) -> dict[str, np.ndarray]:
        """Lifted; lifted and at the reference's hand-off position (its highest point in the trial)."""
        lifted = self.lift(qo) > self.LIFT
        handoff = expected[int(np.argmax(expected[:, 2])), :3]
        near = np.linalg.norm(qo[:, :3] - handoff, axis=-1) < self.HANDOFF_TOLERANCE
        return {"lifted": lifted, "handed_off": lifted & near}
