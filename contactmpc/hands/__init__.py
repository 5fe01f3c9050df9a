"""Hands: each adds its bodies, joints, actuators and sensors to a ``mujoco.MjSpec`` and names them
(:class:`~contactmpc.hands.base.Hand`)."""

from contactmpc.hands.allegro import AllegroHand
from contactmpc.hands.allegro_paper import AllegroPaperHand
from contactmpc.hands.base import FloatingHand, Hand
from contactmpc.hands.gripper import ParallelGripper

__all__ = ["AllegroHand", "AllegroPaperHand", "FloatingHand", "Hand", "ParallelGripper"]
