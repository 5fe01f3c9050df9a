"""A paper task's demonstration: the authors' retargeted motion of the task, imported from their files.

A paper task's config names it (``demonstration: {_target_: ...PaperDemonstration}``), as the synthetic
tasks name their designs; the task itself knows where the files are (``task.files``), which of the
authors' demonstrations it is and how its object's world pose becomes its object configuration.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from contactmpc.reference.data import Reference
from contactmpc.reference.paper.importer import import_reference
from contactmpc.reference.retarget import offset_wrist, wrist_offset

if TYPE_CHECKING:
    from contactmpc.scene import Scene

__all__ = ["PaperDemonstration"]


class PaperDemonstration:
    """The authors' demonstration of a paper task (:class:`~contactmpc.tasks.paper.PaperTask`).

    Importing takes well under a second, so the reference is not cached: it is always read from the
    files the task names.

    Args:
        wrist_fit: offset the wrist's slides by the translation that best puts the links the reference
            expects in contact on the object's surface over its grasp
            (:mod:`contactmpc.reference.retarget`; not the paper's, ``retarget=wrist``). Off: the authors'
            motion as imported.
        wrist_fit_ramp: seconds of the trial (the slowed reference) over which the offset eases in
            before the first expected contact and out after the last.
    """

    cacheable = False

    def __init__(self, wrist_fit: bool = False, wrist_fit_ramp: float = 1.0) -> None:
        if wrist_fit_ramp <= 0:
            raise ValueError(f"task.demonstration.wrist_fit_ramp={wrist_fit_ramp}: expected > 0 seconds")
        self.wrist_fit = bool(wrist_fit)
        self.wrist_fit_ramp = float(wrist_fit_ramp)

    def build(self, scene: Scene) -> Reference:
        """Import the reference of ``scene.task`` for ``scene.hand`` mounted at ``scene.hand_root``.

        Raises:
            ReferenceError: one line naming the file and what is wrong with it.
        """
        task, hand = scene.task, scene.hand
        ref = import_reference(
            task.files,
            task=task.name,
            object_name=task.object_name,
            slowdown=task.slowdown,
            joint_names=hand.joint_names,
            link_names=hand.link_names,
            mount=scene.hand_root,
            object_qpos=task.object_configuration,
            object_bodies=task.object_bodies,
            object_quat_index=task.layout.quat_index,
            joint_ranges=hand.joint_ranges,
        )
        if not self.wrist_fit:
            return ref
        return offset_wrist(ref, wrist_offset(scene, ref), self.wrist_fit_ramp / task.time_scale)
