"""Synthetic demonstrations: a reference motion built from a per-task design, no recorded data needed.

The pipeline, one module per step, each importing only the modules listed before it:

1. :mod:`~contactmpc.reference.synthetic.kinematics`: a private copy of the scene's model for pose,
   distance and contact queries (and :class:`SynthesisError`);
2. :mod:`~contactmpc.reference.synthetic.grasp`: the grasp solved by bounded least squares, the open
   fingers of the approach, and grasps re-solved along one object coordinate;
3. :mod:`~contactmpc.reference.synthetic.phases`: approach, reach, close, moves of the object, open,
   retreat, with the hand riding with the object while it holds it;
4. :mod:`~contactmpc.reference.synthetic.contacts`: the per-frame, per-link expected contacts;
5. :mod:`~contactmpc.reference.synthetic.gates`: quality gates of a finished reference;
6. :mod:`~contactmpc.reference.synthetic.demonstration`: the :class:`Demonstration` base class and
   :func:`synthesize` (design → sampled phases → gated reference);
7. :mod:`~contactmpc.reference.synthetic.designs`: one demonstration per task.

The submodules import each other directly, never this package's ``__init__``.
"""

from contactmpc.reference.synthetic.demonstration import SYNTHESIS_VERSION, Demonstration, synthesize
from contactmpc.reference.synthetic.designs import AppleDemo, BottleDemo, DoorknobDemo, StaplerDemo
from contactmpc.reference.synthetic.gates import GateLimits, check_gates, gate_report
from contactmpc.reference.synthetic.grasp import ContactTarget, GraspProblem
from contactmpc.reference.synthetic.kinematics import SynthesisError
from contactmpc.reference.synthetic.phases import Approach, Close, Move, Open, Phase, Reach, Retreat

__all__ = [
    "SYNTHESIS_VERSION",
    "AppleDemo",
    "Approach",
    "BottleDemo",
    "Close",
    "ContactTarget",
    "Demonstration",
    "DoorknobDemo",
    "GateLimits",
    "GraspProblem",
    "Move",
    "Open",
    "Phase",
    "Reach",
    "Retreat",
    "StaplerDemo",
    "SynthesisError",
    "check_gates",
    "gate_report",
    "synthesize",
]
