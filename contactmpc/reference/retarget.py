"""A retargeted demonstration's grasp corrected by one wrist translation (not the paper's).

The authors' demonstrations are retargeted from a human hand: played back on the Allegro hand, the links
the reference expects in contact are not on the object's surface (some pass into it, others stay off it;
``python launch.py job=reference_report task=paper_<t>`` measures how far), while the plant's fingers stop
at the surface.

:func:`wrist_offset` finds the one translation of the wrist's three slides that best puts the expected
links on the object's surface over the grasp (the frames with more than six expected contacts, where the
paper's failure rule can fire): a least-squares fit of the links' signed distances to the object (0 for a
link the reference expects in contact; the penetration of any other link). :func:`offset_wrist` applies it
over the reference's contact span, eased in over ``ramp`` before the first expected contact and out over
``ramp`` after the last, so the approach and the retreat keep their shape. Deterministic (no random
start, MuJoCo's own distances).
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
from scipy.optimize import least_squares

from contactmpc.reference.consistency import FAILURE_MIN_EXPECTED
from contactmpc.reference.data import Reference
from contactmpc.reference.synthetic.kinematics import Kinematics

if TYPE_CHECKING:
    from contactmpc.scene import Scene

__all__ = ["contact_distances", "offset_wrist", "wrist_offset"]

_DISTMAX = 0.05  # m: links farther than this from the object count at this distance
_EVERY = 10  # fit on every tenth frame of the grasp (the reference's frames are 8 ms apart)


def contact_distances(kin: Kinematics, pairs: np.ndarray, hand_qpos: np.ndarray, object_qpos) -> np.ndarray:
    """(L,) each hand link's signed distance to the object (m, negative inside; at most ``_DISTMAX``)."""
    kin.set(hand_qpos, object_qpos)
    dist = kin.pair_distances(pairs, _DISTMAX)
    out = np.full(len(kin.link_bodies), _DISTMAX)
    np.minimum.at(out, kin.link_of_geom[pairs[:, 0]], dist)
    return out


def wrist_offset(scene: Scene, ref: Reference) -> np.ndarray:
    """(3,) the translation of the wrist's slides (m, in their own axes) that best puts the reference's
    expected links on the object's surface over its grasp (see the module docstring).

    Raises:
        ValueError: the hand has no wrist slides, or the reference no frame with more than six expected
            contacts.
    """
    kin = Kinematics(scene)
    if kin.num_root < 3:
        raise ValueError(f"retarget=wrist: hand {scene.hand.name!r} has no wrist slides to offset")
    grasp = np.flatnonzero(ref.contact_active.sum(axis=1) > FAILURE_MIN_EXPECTED)
    if not len(grasp):
        raise ValueError(
            f"retarget=wrist: the reference of {ref.task!r} expects more than six contacts nowhere"
        )
    frames = grasp[::_EVERY]
    pairs = kin.collision_pairs(kin.link_geoms, kin.object_geoms)

    def residuals(offset: np.ndarray) -> np.ndarray:
        out = []
        for t in frames:
            q = ref.hand_qpos[t].copy()
            q[:3] += offset
            d = contact_distances(kin, pairs, q, ref.object_qpos[t])
            expected = ref.contact_active[t]
            out.append(np.where(expected, d, np.minimum(d, 0.0)))
        return np.concatenate(out)

    return least_squares(residuals, np.zeros(3), diff_step=1e-3).x


def offset_wrist(ref: Reference, offset: np.ndarray, ramp: float) -> Reference:
    """``ref`` with ``offset`` added to its wrist slides over its contact span, eased in linearly over
    ``ramp`` (s, the reference's time) before the first frame with an expected contact and out over
    ``ramp`` after the last; ``meta["wrist_offset"]`` records it (m)."""
    contact = np.flatnonzero(ref.contact_active.any(axis=1))
    t = ref.time
    if not len(contact):
        return ref
    first, last = t[contact[0]], t[contact[-1]]
    ramp = max(float(ramp), 1e-9)
    weight = np.clip((t - first + ramp) / ramp, 0.0, 1.0) * np.clip((last + ramp - t) / ramp, 0.0, 1.0)
    hand = ref.hand_qpos.copy()
    hand[:, :3] += weight[:, None] * np.asarray(offset, float)[None, :]
    meta = {**ref.meta, "wrist_offset": [float(v) for v in offset]}
    return replace(ref, hand_qpos=hand, meta=meta)
