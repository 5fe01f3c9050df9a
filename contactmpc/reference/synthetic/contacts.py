"""Per-frame, per-link contact summaries of a kinematic motion.

Per frame and link the contact is summarised as in the paper (§II-A, :func:`summarise_contacts`): the
link is *active* when its collision geom lies within ``contact_threshold`` of an object geom; its
link-local point is the mean of the link-side points of its contacts with that geom (MuJoCo's collision
with a margin, so a flat patch yields several points), in the link body frame; the object-local point
is the mean of the corresponding object-side points, in the frame of the object body owning the geom.
"""

from __future__ import annotations

import numpy as np

from contactmpc.reference.synthetic.kinematics import Kinematics

__all__ = ["summarise_contacts"]


def summarise_contacts(
    kin: Kinematics, hand_qpos: np.ndarray, object_qpos: np.ndarray, threshold: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per-frame, per-link contact summary of a kinematic motion.

    A link is active in a frame when its collision geom lies within ``threshold`` of an object geom
    (signed distance, ``mj_geomDistance``). Its link point is the mean of the link-side points of
    MuJoCo's contacts (collision with a margin, so a flat patch yields several points) between the
    link and its nearest object geom, in the link body frame; its object point is the mean of the
    object-side points, in the frame of the object body owning that geom. When the collision yields
    no contact for the pair, the nearest points of the distance query are used. Inactive frames repeat
    the points of the nearest active frame of the link (zeros for a link never in contact), so the
    curves stay continuous.

    Args:
        kin: kinematics of the scene.
        hand_qpos: (T, J) hand configurations.
        object_qpos: (T, n_o) object configurations.
        threshold: contact distance (m).

    Returns:
        ``active (T, L) bool``, ``link_point (T, L, 3)``, ``object_point (T, L, 3)``,
        ``object_body (T, L) int``.
    """
    num_t, num_l = len(hand_qpos), len(kin.link_bodies)
    active = np.zeros((num_t, num_l), bool)
    link_pt = np.zeros((num_t, num_l, 3))
    obj_pt = np.zeros((num_t, num_l, 3))
    obj_body = np.zeros((num_t, num_l), dtype=np.int64)
    pairs = kin.collision_pairs(kin.link_geoms, kin.object_geoms)
    pair_link = kin.link_of_geom[pairs[:, 0]]
    distmax = 2.0 * threshold + 1e-3
    for t in range(num_t):
        kin.set(hand_qpos[t], object_qpos[t])
        dist = kin.pair_distances(pairs, distmax)
        close = dist <= threshold
        if not close.any():
            continue
        con = kin.contacts(threshold + 5e-4)
        for link in np.unique(pair_link[close]):
            mine = np.flatnonzero(pair_link == link)
            g_link, g_obj = pairs[mine[np.argmin(dist[mine])]]
            hit_ab = (con.geom1 == g_link) & (con.geom2 == g_obj)
            hit_ba = (con.geom1 == g_obj) & (con.geom2 == g_link)
            if hit_ab.any() or hit_ba.any():
                p_link = np.concatenate([con.point1[hit_ab], con.point2[hit_ba]]).mean(axis=0)
                p_obj = np.concatenate([con.point2[hit_ab], con.point1[hit_ba]]).mean(axis=0)
            else:
                _, fromto = kin.distance(int(g_link), int(g_obj), distmax)
                p_link, p_obj = fromto[:3], fromto[3:]
            body = int(kin.object_of_geom[g_obj])
            active[t, link] = True
            link_pt[t, link] = kin.body_pose(kin.link_bodies[link]).inv().apply(p_link)
            obj_pt[t, link] = kin.body_pose(kin.object_bodies[body]).inv().apply(p_obj)
            obj_body[t, link] = body
    # Fill inactive frames from the nearest active frame of the same link.
    frames = np.arange(num_t)
    for link in range(num_l):
        on = np.flatnonzero(active[:, link])
        if on.size == 0:
            continue
        pos = np.clip(np.searchsorted(on, frames), 0, on.size - 1)
        prev = on[np.clip(pos - 1, 0, on.size - 1)]
        nxt = on[pos]
        nearest = np.where(np.abs(prev - frames) <= np.abs(nxt - frames), prev, nxt)
        off = ~active[:, link]
        link_pt[off, link] = link_pt[nearest[off], link]
        obj_pt[off, link] = obj_pt[nearest[off], link]
        obj_body[off, link] = obj_body[nearest[off], link]
    return active, link_pt, obj_pt, obj_body
