"""The importer of the paper authors' task data (a sibling of ``synthetic/``).

The authors ship, for each task, B-spline curves of the retargeted hand motion and of the object motion
(``.smexp``), the PCA of the finger curves with its PC-curves (``.pcmexp``) and per-frame hand/object
contact points (a MuJoCo ``<custom>`` XML). This package reads those files from a directory the user
names; the data is never copied into the repository.

* :mod:`~contactmpc.reference.paper.formats`: the readers of the three file formats and the curve
  evaluation exactly as the authors' C++ does it. The importer that turns them into a
  :class:`~contactmpc.reference.data.Reference` comes next.

The submodules import each other directly, never this package's ``__init__``.
"""

from contactmpc.reference.paper.formats import (
    MOCAP_FPS,
    ContactFrames,
    FrameContacts,
    PCSplines,
    SplineCurves,
    aliased_transpose,
    code_component_matrix,
    contact_frame_index,
    evaluate,
    read_contacts,
    read_pcmexp,
    read_smexp,
    reconstruct,
    reconstruct_as_code,
    spline_parameter,
    time_column,
    to_mujoco_units,
    value_column,
)

__all__ = [
    "MOCAP_FPS",
    "ContactFrames",
    "FrameContacts",
    "PCSplines",
    "SplineCurves",
    "aliased_transpose",
    "code_component_matrix",
    "contact_frame_index",
    "evaluate",
    "read_contacts",
    "read_pcmexp",
    "read_smexp",
    "reconstruct",
    "reconstruct_as_code",
    "spline_parameter",
    "time_column",
    "to_mujoco_units",
    "value_column",
]
