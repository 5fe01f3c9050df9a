"""ContactMPC: online sampling-based MPC for contact-rich dexterous manipulation.

The library never imports hydra or omegaconf: every class takes plain typed arguments and is
built from config by ``hydra.utils.instantiate`` in ``launch.py`` only.
"""

__version__ = "0.1.0"
