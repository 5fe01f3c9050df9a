"""The importer of the paper authors' task data (a sibling of ``synthetic/``).

The authors ship, for each task, B-spline curves of the retargeted hand motion and of the object motion
(``.smexp``), the PCA of the finger curves with its PC-curves (``.pcmexp``) and per-frame hand/object
contact points (a MuJoCo ``<custom>`` XML). This package reads those files from a directory the user
names; the data is never copied into the repository.

* :mod:`~contactmpc.reference.paper.splines`: the readers of the ``.smexp`` curves and ``.pcmexp`` PCA;
* :mod:`~contactmpc.reference.paper.contacts`: the reader of the contact XML;
* :mod:`~contactmpc.reference.paper.fields`: what the readers share: opening a file, the JSON field
  checks, one-line errors naming the file and the field;
* :mod:`~contactmpc.reference.paper.evaluation`: the curves and PCs evaluated exactly as the authors'
  C++ does it;
* :mod:`~contactmpc.reference.paper.importer`: one task's files -> a
  :class:`~contactmpc.reference.data.Reference`; :mod:`~contactmpc.reference.paper.demonstration`: a
  paper task's demonstration, built with it.

The submodules import each other directly, never this package's ``__init__``, which exports nothing:
import from the submodule (``from contactmpc.reference.paper.splines import read_smexp``).
"""
