"""Reference motions: the ``Reference`` data class and its ``.npz`` format, B-splines and PCA.

``ReferenceError`` (a ``ValueError``) shadows Python's builtin weak-reference ``ReferenceError`` where it
is imported by name; prefer ``from contactmpc import reference`` and ``reference.ReferenceError``.
"""

from contactmpc.reference.bspline import UniformBSpline
from contactmpc.reference.data import NUM_HAND_DOFS, QUAT_NORM_TOLERANCE, Reference, ReferenceError
from contactmpc.reference.pca import PCABasis, PCACurves

__all__ = [
    "NUM_HAND_DOFS",
    "QUAT_NORM_TOLERANCE",
    "PCABasis",
    "PCACurves",
    "Reference",
    "ReferenceError",
    "UniformBSpline",
]
