"""Hand builders: each hand adds its bodies, joints, actuators and sensors to a ``mujoco.MjSpec``."""

from contactmpc.hands.allegro import AllegroHand

__all__ = ["AllegroHand"]
