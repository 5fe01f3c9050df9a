"""Kinematic consistency of a reference: how well its hand, object and contacts agree when played back.

:func:`consistency_report` replays a reference kinematically in a private copy of the scene's model and
measures what a retargeted demonstration gets wrong (the paper's data, :mod:`contactmpc.reference.paper`)
and a synthesised one should not:

* ``gap_median`` / ``gap_p90`` / ``gap_max`` (m): over every frame and expected-contact link, the
  distance between the link point (mapped through the link's pose) and the object point (mapped through
  its object body's pose), which should coincide;
* ``penetration_median`` / ``penetration_p90`` / ``penetration_max`` (m, >= 0): the hand's deepest
  penetration into the object per frame, over the frames with any expected contact
  (``penetration_per_frame`` holds it for every frame);
* ``touch_share_over_six``: of the frames with more than six expected contacts (the frames on which the
  paper's failure rule can fire), the share where some hand link touches the object (signed distance
  <= ``touch_tolerance``);
* ``expected_links_touching``: over the same frames, the mean share of the expected links that touch.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from contactmpc.reference.data import Reference
from contactmpc.reference.synthetic.kinematics import Kinematics

if TYPE_CHECKING:
    from contactmpc.scene import Scene

__all__ = ["consistency_report"]

FAILURE_MIN_EXPECTED = 6  # the paper's rule: more than six expected contacts


def consistency_report(scene: Scene, ref: Reference, touch_tolerance: float = 0.001) -> dict:
    """Measure ``ref`` played back in ``scene`` (see the module docstring).

    Args:
        scene: the scene the reference is for.
        ref: the reference, validated against the scene.
        touch_tolerance: signed distance (m) under which a link counts as touching the object.

    Returns:
        A JSON-serialisable dict (floats, ints, a list; None where there is no frame to measure).
    """
    kin = Kinematics(scene)
    pairs = kin.collision_pairs(kin.link_geoms, kin.object_geoms)
    link_of_pair = kin.link_of_geom[pairs[:, 0]]
    num_t = ref.num_frames
    penetration = np.zeros(num_t)
    touching = np.zeros((num_t, ref.num_links), bool)
    gaps: list[float] = []
    for t in range(num_t):
        kin.set(ref.hand_qpos[t], ref.object_qpos[t])
        dist = kin.pair_distances(pairs, touch_tolerance + 0.01)
        if len(dist):
            penetration[t] = max(0.0, -float(dist.min()))
            touching[t, link_of_pair[dist <= touch_tolerance]] = True
        for link in np.flatnonzero(ref.contact_active[t]):
            p_link = kin.body_pose(kin.link_bodies[link]).apply(ref.contact_link_point[t, link])
            body = int(ref.contact_object_body[t, link])
            p_obj = kin.body_pose(kin.object_bodies[body]).apply(ref.contact_object_point[t, link])
            gaps.append(float(np.linalg.norm(p_link - p_obj)))
    expected = ref.contact_active.sum(axis=1)
    contact_frames = expected > 0
    over = expected > FAILURE_MIN_EXPECTED

    def stat(values: np.ndarray, q: float) -> float | None:
        return float(np.percentile(values, q)) if len(values) else None

    gaps_arr = np.asarray(gaps)
    pen = penetration[contact_frames]
    share = touching[over].any(axis=1).mean() if over.any() else None
    links = (touching & ref.contact_active)[over].sum(axis=1) / expected[over] if over.any() else None
    return {
        "frames": num_t,
        "contact_frames": int(contact_frames.sum()),
        "frames_over_six": int(over.sum()),
        "expected_links_max": int(expected.max()) if num_t else 0,
        "gap_median": stat(gaps_arr, 50),
        "gap_p90": stat(gaps_arr, 90),
        "gap_max": stat(gaps_arr, 100),
        "penetration_median": stat(pen, 50),
        "penetration_p90": stat(pen, 90),
        "penetration_max": stat(pen, 100),
        "touch_tolerance": touch_tolerance,
        "touch_share_over_six": None if share is None else float(share),
        "expected_links_touching": None if links is None else float(np.mean(links)),
        "penetration_per_frame": [round(float(v), 6) for v in penetration],
    }
