"""Reference motions: the format of a reference and the curve maths on it.

Layout of the package:

* ``data.py``: the format, the :class:`Reference` data class and its ``.npz`` file;
* ``bspline.py`` and ``pca.py``: the curve maths (uniform B-splines, PCA of the hand curves);
* ``source.py``: where a trial's reference comes from (a user's file or a synthesised demonstration,
  cached);
* ``synthetic/``: synthetic demonstrations, one sub-package per kind of source (the importer of the
  paper's data will sit beside it). This package does not import them; use
  :mod:`contactmpc.reference.synthetic` or :func:`contactmpc.reference.source.get_reference`.

``ReferenceError`` (a ``ValueError``) shadows Python's builtin weak-reference ``ReferenceError`` where it
is imported by name; prefer ``from contactmpc import reference`` and ``reference.ReferenceError``.
"""

from contactmpc.reference.bspline import UniformBSpline
from contactmpc.reference.data import QUAT_NORM_TOLERANCE, Reference, ReferenceError
from contactmpc.reference.pca import PCABasis, PCACurves

__all__ = [
    "QUAT_NORM_TOLERANCE",
    "PCABasis",
    "PCACurves",
    "Reference",
    "ReferenceError",
    "UniformBSpline",
]
