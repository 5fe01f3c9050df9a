"""The paper's doorknob (``doorknob_use_1``): grasp the knob and pull it along its slide."""

from __future__ import annotations

from typing import Annotated

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from contactmpc.tasks.base import ObjectJoint
from contactmpc.tasks.paper import PaperTask
from contactmpc.validate import Ge, checked


class PaperDoorknobTask(PaperTask):
    """The authors' doorknob: a knob body (ellipsoid knob, cylinder shaft, box stopper; density 1250,
    gravity-compensated) on one slide joint along its local z (range 0 to 1 m), hung from
    ``doorknob_attachment`` with no door and no table. Their "twist" is not in the scene: the knob only
    slides. The object configuration is the slide; the reference's is the object curves' position
    projected on the slide axis.

    Milestone: *pulled*: slid out to ``PULL_FRACTION`` of the reference's largest extent (about 25 cm),
    while held.

    Args:
        slide_friction: dry friction on the slide (N, MuJoCo's ``frictionloss``; not the authors'): the
            authors' slide has none, so nothing stops the knob once the hand is off it. 0 (the default)
            is their slide, the model unchanged.
        **kwargs: :class:`~contactmpc.tasks.paper.PaperTask`'s.
    """

    name = "paper_doorknob"
    demo = "doorknob_use_1"
    object_name = "doorknob"
    slowdown = 8.0
    hand_mount = (-1.0543771773975556, 0.30091857905335375, 1.28798410204936)
    object_joints = (ObjectJoint("doorknob_slide", "slide"),)
    object_bodies = ("doorknob_sim",)
    ATTACHMENT = (-0.0825822262763977, -0.6478415727615356, 0.9384804964065552)
    KNOB_POS = (-0.047, 0.0, 0.0)  # in the attachment's frame
    KNOB_QUAT = (0.47815212453295514, 0.5128687163825603, -0.5009253359069297, -0.5073559237924161)
    PULL_FRACTION = 0.75
    # The final milestone's, on the slide (m, m/s): the free objects' position tolerance and rest speed.
    SETTLE_ARTICULATION = 0.05
    REST_ARTICULATION_SPEED = 0.02
    # their "Recording" camera's direction, closer
    view = {"lookat": (-0.25, -0.65, 0.95), "distance": 0.8, "azimuth": 60.0, "elevation": -20.0}

    @checked
    def __init__(self, slide_friction: Annotated[float, Ge(0)] = 0.0, **kwargs) -> None:
        self.slide_friction = float(slide_friction)
        super().__init__(**kwargs)

    def add_objects(self, spec) -> None:
        self.add_floor(spec)
        mount = spec.worldbody.add_body(name="doorknob_attachment", pos=list(self.ATTACHMENT))
        knob = mount.add_body(
            name="doorknob_sim", pos=list(self.KNOB_POS), quat=list(self.KNOB_QUAT), gravcomp=1.0
        )
        slide = knob.add_joint(
            name="doorknob_slide",
            type=mujoco.mjtJoint.mjJNT_SLIDE,
            axis=[0, 0, 1],
            range=[0.0, 1.0],
            limited=mujoco.mjtLimited.mjLIMITED_TRUE,
        )
        if self.slide_friction > 0:
            slide.frictionloss = self.slide_friction
        self.add_visual(spec, knob, (0.8313, 0.686, 0.216, 1.0))
        geoms = (
            ("knob", mujoco.mjtGeom.mjGEOM_ELLIPSOID, [0.0325, 0.0325, 0.015], [0, 0, 0.021]),
            ("shaft", mujoco.mjtGeom.mjGEOM_CYLINDER, [0.01, 0.0157, 0], [0, 0, -0.01]),
            ("stopper", mujoco.mjtGeom.mjGEOM_BOX, [0.05, 0.025, 0.005], [0, 0, -0.0315]),
        )
        for name, kind, size, pos in geoms:
            knob.add_geom(
                name=f"doorknob_{name}",
                type=kind,
                size=size,
                pos=pos,
                density=1250.0,
                condim=4,
                group=3,
                friction=[1.0, 0.005, 0.0001],
            )

    def object_configuration(self, pos: np.ndarray, quat: np.ndarray) -> np.ndarray:
        """(T, 1) the slide: the knob's world position relative to its rest position, along the slide's
        world axis (its local z)."""
        axis = Rotation.from_quat(self.KNOB_QUAT, scalar_first=True).apply([0.0, 0.0, 1.0])
        rest = np.add(self.ATTACHMENT, self.KNOB_POS)
        return ((np.asarray(pos) - rest) @ axis)[:, None]

    def conditions(self, qo: np.ndarray, expected: np.ndarray) -> dict[str, np.ndarray]:
        """Pulled out to ``PULL_FRACTION`` of the reference's largest extent in the trial."""
        extent = float(np.max(expected[:, 0]))
        return {"pulled": (qo[:, 0] >= self.PULL_FRACTION * extent) & (extent > 0.01)}
