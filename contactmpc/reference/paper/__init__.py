"""The importer of the paper authors' task data (a sibling of ``synthetic/``).

The authors ship, for each task, B-spline curves of the retargeted hand motion and of the object motion
(``.smexp``), the PCA of the finger curves with its PC-curves (``.pcmexp``) and per-frame hand/object
contact points (a MuJoCo ``<custom>`` XML). This package reads those files from a directory the user
names; the data is never copied into the repository.

* :mod:`~contactmpc.reference.paper.formats`: the readers of the three file formats and the curve
  evaluation exactly as the authors' C++ does it. The importer that turns them into a
  :class:`~contactmpc.reference.data.Reference` comes next.

The submodules import each other directly, never this package's ``__init__``, which exports nothing:
import from the submodule (``from contactmpc.reference.paper import formats``).
"""
