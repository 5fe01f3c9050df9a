"""Reference motions: the ``Reference`` data class and its ``.npz`` format, B-splines and PCA, and
synthetic demonstrations (:func:`synthesize`, quality gates in :mod:`contactmpc.reference.gates`).

``ReferenceError`` (a ``ValueError``) shadows Python's builtin weak-reference ``ReferenceError`` where it
is imported by name; prefer ``from contactmpc import reference`` and ``reference.ReferenceError``.
"""

from contactmpc.reference.bspline import UniformBSpline
from contactmpc.reference.data import NUM_HAND_DOFS, QUAT_NORM_TOLERANCE, Reference, ReferenceError
from contactmpc.reference.demos import DEMOS
from contactmpc.reference.gates import GateLimits, check_gates, gate_report
from contactmpc.reference.pca import PCABasis, PCACurves
from contactmpc.reference.synthesis import SYNTHESIS_VERSION, SynthesisError, synthesize

__all__ = [
    "DEMOS",
    "NUM_HAND_DOFS",
    "QUAT_NORM_TOLERANCE",
    "GateLimits",
    "PCABasis",
    "PCACurves",
    "Reference",
    "ReferenceError",
    "SYNTHESIS_VERSION",
    "SynthesisError",
    "UniformBSpline",
    "check_gates",
    "gate_report",
    "synthesize",
]
