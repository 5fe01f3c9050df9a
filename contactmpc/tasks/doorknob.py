"""Doorknob twist and pull: a hinged door with a spring-returned knob and a latch bolt.

Frame of reference: the door's face lies in the world x-z plane at y = 0 and its hinge is the vertical
line x = -width, y = 0 on the left; the hand stands on the -y side. Pulling the door towards the hand
turns the door hinge negative. The knob turns about the door's normal; twisting it (positive angle)
retracts the latch bolt through an equality constraint ``bolt = -retract * knob / unlock_angle``, so the
latch works inside batched rollouts with no Python callbacks. Untwisted, the bolt sits in a strike
on the frame's jamb and stops the door after ``play`` metres of travel at the bolt.
"""

from __future__ import annotations

import mujoco
import numpy as np

from contactmpc.tasks.base import ObjectJoint, Task


class DoorknobTask(Task):
    """Twist a doorknob and pull the door open.

    A 0.5 m x 0.8 m x 3 cm, 3 kg cabinet-sized door on a fixed frame, a 5.6 cm round knob 6 cm
    proud of the face, 7 cm from the door's free edge, with a return spring, and a 12 mm latch bolt.

    Args:
        door_width: door width (m).
        door_height: door height (m).
        door_mass: door mass (kg).
        knob_height: height of the knob's axis above the floor (m).
        knob_radius: knob radius (m).
        knob_stiffness: knob return spring (N m / rad).
        unlock_angle: knob angle at which the bolt is fully retracted (rad).
        bolt_throw: how far the bolt protrudes from the door edge (m).
        play: free travel of the latched bolt before it meets the strike (m).
        door_damping: door hinge damping (N m s / rad).
        **kwargs: see :class:`~contactmpc.tasks.base.Task`.
    """

    name = "doorknob"
    object_joints = (ObjectJoint("door_hinge", "hinge"), ObjectJoint("knob_hinge", "hinge"))
    object_bodies = ("knob", "door")
    BOLT_FRICTION = 0.3  # sliding friction of the latch bolt on its strike (greased metal)
    view = {"lookat": (-0.1, -0.14, 0.4), "distance": 0.65, "azimuth": 45.0, "elevation": -20.0}

    def __init__(
        self,
        door_width: float = 0.5,
        door_height: float = 0.8,
        door_thickness: float = 0.03,
        door_mass: float = 3.0,
        knob_height: float = 0.4,
        knob_radius: float = 0.028,
        knob_offset: float = 0.07,
        knob_stiffness: float = 0.3,
        max_knob_angle: float = 1.2,
        unlock_angle: float = 0.7,
        bolt_throw: float = 0.012,
        play: float = 0.002,
        door_damping: float = 0.5,
        **kwargs,
    ) -> None:
        super().__init__(**kwargs)
        self.door_width = door_width
        self.door_height = door_height
        self.door_thickness = door_thickness
        self.door_mass = door_mass
        self.knob_height = knob_height
        self.knob_radius = knob_radius
        self.knob_offset = knob_offset
        self.knob_stiffness = knob_stiffness
        self.max_knob_angle = max_knob_angle
        self.unlock_angle = unlock_angle
        self.bolt_throw = bolt_throw
        self.play = play
        self.door_damping = door_damping

    def add_objects(self, spec: mujoco.MjSpec) -> None:
        w, h, th = self.door_width, self.door_height, self.door_thickness
        world = spec.worldbody
        wood, frame_c, brass = [0.70, 0.55, 0.38, 1.0], [0.92, 0.92, 0.90, 1.0], [0.80, 0.65, 0.25, 1.0]
        world.add_geom(
            name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[2, 2, 0.05], material="floor_mat"
        )
        # Fixed frame: hinge-side post, header, and the latch-side jamb split around the bolt's strike.
        jamb = 0.04
        world.add_geom(
            name="frame_hinge_post",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=[-w - jamb - 0.003, th / 2, h / 2],
            size=[jamb, th, h / 2],
            rgba=frame_c,
        )
        world.add_geom(
            name="frame_header",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=[-w / 2, th / 2, h + jamb + 0.003],
            size=[w / 2 + 2 * jamb + 0.003, th, jamb],
            rgba=frame_c,
        )
        gap = 0.002  # door edge to jamb
        bolt_half_t = 0.006  # half thickness of the bolt in y
        bolt_y = th / 2
        strike_front = bolt_y - bolt_half_t - self.play  # jamb face on the hand's side of the bolt
        jx = gap + jamb
        world.add_geom(
            name="frame_strike_front",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=[jx, (strike_front - th) / 2, h / 2],
            size=[jamb, (strike_front + th) / 2, h / 2],
            rgba=frame_c,
        )
        back_face = bolt_y + bolt_half_t + 0.002
        world.add_geom(
            name="frame_strike_back",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=[jx, (back_face + 1.5 * th) / 2, h / 2],
            size=[jamb, (1.5 * th - back_face) / 2, h / 2],
            rgba=frame_c,
        )
        # The door, hinged about z on its left edge; it can only swing towards the hand (pull).
        door = world.add_body(name="door", pos=[-w, 0, 0])
        door.add_joint(
            name="door_hinge",
            type=mujoco.mjtJoint.mjJNT_HINGE,
            axis=[0, 0, 1],
            range=[-1.6, 0.0],
            limited=mujoco.mjtLimited.mjLIMITED_TRUE,
            damping=self.door_damping,
            frictionloss=0.05,
        )
        door.add_geom(
            name="door_col",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=[w / 2, th / 2, h / 2],
            size=[w / 2 - 0.001, th / 2, h / 2 - 0.001],
            mass=self.door_mass,
            rgba=wood,
        )
        # Latch bolt: slides along the door's width, coupled to the knob.
        bolt = door.add_body(name="bolt", pos=[w, bolt_y, self.knob_height])
        bolt.add_joint(
            name="bolt_slide",
            type=mujoco.mjtJoint.mjJNT_SLIDE,
            axis=[1, 0, 0],
            range=[-self.bolt_throw * self.max_knob_angle / self.unlock_angle - 0.002, 0.001],
            limited=mujoco.mjtLimited.mjLIMITED_TRUE,
            armature=0.01,
            damping=1.0,
        )
        bolt.add_geom(
            name="bolt_col",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=[self.bolt_throw / 2, 0, 0],
            size=[self.bolt_throw / 2, bolt_half_t, 0.01],
            mass=0.02,
            rgba=brass,
            # Greased metal latch on its strike: low friction, and priority makes this friction (not
            # the max with the frame's) apply, so a twisted knob can retract a loaded bolt.
            friction=[self.BOLT_FRICTION, 0.005, 0.0001],
            priority=1,
        )
        # Knob: on a rose and shaft on the hand's side of the door, turning about the door normal.
        knob_x = w - self.knob_offset
        door.add_geom(
            name="knob_rose",
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            pos=[knob_x, -0.004, self.knob_height],
            quat=[0.7071068, 0.7071068, 0, 0],
            size=[0.03, 0.004, 0],
            rgba=brass,
            mass=0.02,
        )
        knob = door.add_body(name="knob", pos=[knob_x, -0.06, self.knob_height])
        knob.add_joint(
            name="knob_hinge",
            type=mujoco.mjtJoint.mjJNT_HINGE,
            axis=[0, -1, 0],
            range=[0.0, self.max_knob_angle],
            limited=mujoco.mjtLimited.mjLIMITED_TRUE,
            stiffness=self.knob_stiffness,
            springref=0.0,
            damping=0.02,
            # Inertia of the knob's spindle and latch mechanism. With a bare 1e-3 the knob is so light
            # that it dominates the latch equality's impedance and the latch cannot hold the bolt.
            armature=0.005,
        )
        knob.add_geom(
            name="knob_shaft",
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            pos=[0, 0.03, 0],
            quat=[0.7071068, 0.7071068, 0, 0],
            size=[0.008, 0.026, 0],
            mass=0.02,
            rgba=brass,
        )
        knob.add_geom(
            name="knob_col",
            type=mujoco.mjtGeom.mjGEOM_ELLIPSOID,
            size=[self.knob_radius, 0.02, self.knob_radius],
            mass=0.08,
            rgba=brass,
            friction=[1.2, 0.02, 0.001],
            condim=4,
        )
        # A small mark on the knob so its twist is visible.
        knob.add_geom(
            name="knob_mark",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=[0, -0.0195, 0.016],
            size=[0.003, 0.001, 0.008],
            rgba=[0.2, 0.1, 0.05, 1],
            contype=0,
            conaffinity=0,
            mass=0.0001,
        )
        # The latch: bolt = -(throw / unlock_angle) * knob.
        eq = spec.add_equality(
            name="latch",
            type=mujoco.mjtEq.mjEQ_JOINT,
            name1="bolt_slide",
            name2="knob_hinge",
            objtype=mujoco.mjtObj.mjOBJ_JOINT,
        )
        coef = np.zeros(5)
        coef[1] = -self.bolt_throw / self.unlock_angle
        eq.data[: len(coef)] = coef
        # Near-hard coupling. The default impedance (0.9-0.95) makes the regulariser ~1/20 of the
        # summed inverse weights of bolt and knob, so the latch passed ~1 N at 2 cm of violation:
        # a knob turned to its stop left the bolt in the strike. timeconst stays at 0.02 s (stable at
        # the 10 ms planning step).
        eq.solimp = [0.99, 0.999, 0.001, 0.5, 2.0]
        eq.solref = [0.02, 1.0]
        spec.add_exclude(bodyname1="door", bodyname2="knob")

    OPEN = 0.3  # rad the door must swing towards the hand to count as pulled open
    SETTLE_ARTICULATION = 0.1  # rad (door and knob): the final milestone's; 5 cm at the door's free edge

    def conditions(self, qo: np.ndarray, expected: np.ndarray) -> dict[str, np.ndarray]:
        """Knob twisted past the unlock angle; the door pulled open (columns: door, knob)."""
        return {"twisted": qo[:, 1] >= self.unlock_angle, "opened": qo[:, 0] <= -self.OPEN}
