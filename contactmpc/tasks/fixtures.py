"""The scene side of a task: its fixtures (the table) and the sensors on its objects.

:class:`TaskScene` is a base of :class:`~contactmpc.tasks.base.Task`: a task adds its fixtures and
object bodies to a ``mujoco.MjSpec`` (:meth:`TaskScene.add_objects`), and :meth:`TaskScene.add_to`
adds them with a frame sensor on every object body and a joint-position sensor on every articulation.
"""

from __future__ import annotations

import mujoco

from contactmpc.tasks.layout import ObjectLayout


class TaskScene:
    """What a task adds to the scene (a base of :class:`~contactmpc.tasks.base.Task`, which sets
    ``object_bodies`` and :attr:`layout`)."""

    object_bodies: tuple[str, ...] = ()
    layout: ObjectLayout

    def add_to(self, spec: mujoco.MjSpec) -> None:
        """Add the task's fixtures, objects and object sensors to ``spec``: frame sensors
        ``<body>_pos``/``<body>_quat`` on every object body, and joint-position sensors ``<joint>_pos``
        on the articulations, so that ``q_o`` comes back in sensordata too."""
        self.add_objects(spec)
        for body in self.object_bodies:
            spec.add_sensor(
                name=f"{body}_pos",
                type=mujoco.mjtSensor.mjSENS_FRAMEPOS,
                objtype=mujoco.mjtObj.mjOBJ_XBODY,  # body frame, not the CoM frame
                objname=body,
            )
            spec.add_sensor(
                name=f"{body}_quat",
                type=mujoco.mjtSensor.mjSENS_FRAMEQUAT,
                objtype=mujoco.mjtObj.mjOBJ_XBODY,  # body frame, not the CoM frame
                objname=body,
            )
        for joint in self.layout.articulation_joints:
            spec.add_sensor(
                name=f"{joint}_pos",
                type=mujoco.mjtSensor.mjSENS_JOINTPOS,
                objtype=mujoco.mjtObj.mjOBJ_JOINT,
                objname=joint,
            )

    def add_objects(self, spec: mujoco.MjSpec) -> None:
        """Add fixtures and object bodies (with the joints of ``object_joints``) to ``spec``."""
        raise NotImplementedError

    @staticmethod
    def add_table(spec: mujoco.MjSpec, size=(0.45, 0.45), height: float = 0.0) -> None:
        """A table whose top is the plane z = ``height``, with visual-only legs and top slab."""
        world = spec.worldbody
        world.add_geom(
            name="table_top",
            type=mujoco.mjtGeom.mjGEOM_PLANE,
            pos=[0, 0, height],
            size=[size[0], size[1], 0.01],
            rgba=[0.62, 0.47, 0.33, 1.0],
            friction=[0.8, 0.01, 0.001],
        )
        slab = 0.02
        world.add_geom(
            name="table_slab",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=[0, 0, height - slab - 0.0005],
            size=[size[0], size[1], slab],
            rgba=[0.55, 0.40, 0.28, 1.0],
            contype=0,
            conaffinity=0,
        )
        leg_h = 0.35
        world.add_geom(
            name="floor",
            type=mujoco.mjtGeom.mjGEOM_PLANE,
            pos=[0, 0, height - 2 * slab - 2 * leg_h],
            size=[2.0, 2.0, 0.05],
            material="floor_mat",
            contype=0,
            conaffinity=0,
        )
        for i, (sx, sy) in enumerate([(1, 1), (1, -1), (-1, 1), (-1, -1)]):
            world.add_geom(
                name=f"table_leg{i}",
                type=mujoco.mjtGeom.mjGEOM_BOX,
                pos=[sx * (size[0] - 0.03), sy * (size[1] - 0.03), height - 2 * slab - leg_h],
                size=[0.02, 0.02, leg_h],
                rgba=[0.45, 0.33, 0.22, 1.0],
                contype=0,
                conaffinity=0,
            )
