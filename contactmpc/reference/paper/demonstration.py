"""A paper task's demonstration: the authors' retargeted motion of the task, imported from their files.

A paper task's config names it (``demonstration: {_target_: ...PaperDemonstration}``), as the synthetic
tasks name their designs; the task itself knows where the files are (``task.files``), which of the
authors' demonstrations it is and how its object's world pose becomes its object configuration.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from contactmpc.reference.data import Reference
from contactmpc.reference.paper.importer import import_reference

if TYPE_CHECKING:
    from contactmpc.scene import Scene

__all__ = ["PaperDemonstration"]


class PaperDemonstration:
    """The authors' demonstration of a paper task (:class:`~contactmpc.tasks.paper.PaperTask`).

    Importing takes well under a second, so the reference is not cached: it is always read from the
    files the task names.
    """

    cacheable = False

    def build(self, scene: Scene) -> Reference:
        """Import the reference of ``scene.task`` for ``scene.hand`` mounted at ``scene.hand_root``.

        Raises:
            ReferenceError: one line naming the file and what is wrong with it.
        """
        task, hand = scene.task, scene.hand
        return import_reference(
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
