"""Quality gates of a reference motion, computed from the reference's arrays and the scene's geometry.

:func:`gate_report` replays a reference kinematically in a private copy of the scene's model and
measures, over all frames:

* ``penetration_hand_object``, ``penetration_hand_env``, ``penetration_hand_hand``,
  ``penetration_object_env``: deepest penetration (m, >= 0) between hand links and the object, the
  fixtures (table, door frame), other hand links, and between the object and the fixtures;
* ``contact_link_point_distance`` / ``contact_object_point_distance``: on active frames, the largest
  distance of a stored link-local point (mapped through the link's pose) to that link's geom surface,
  and of a stored object-local point (mapped through its object body's pose) to that body's surface;
  ``contact_gap``: the largest distance between the two mapped points;
* ``joint_limit_violations``: entries of ``hand_qpos`` outside the hand's joint ranges;
* ``hold_links_min``: fewest links within the contact threshold (``meta["contact_threshold"]``) of the
  object over the frames of the holding phases (``meta["phases"]``), and ``hold_active_min`` the fewest
  links marked active there;
* ``keyframe_*_error``: object configuration at the keyframe times of ``meta["keyframes"]`` against
  the keyframes; ``start_error``: first frame against the task's initial state;
* ``max_wrist_speed``, ``max_wrist_rate``, ``max_finger_rate``: finite-difference speeds (m/s, rad/s).

:func:`check_gates` compares a report with :class:`GateLimits` and raises
:class:`~contactmpc.reference.synthetic.kinematics.SynthesisError` on the first failure.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from contactmpc.reference.data import Reference
from contactmpc.reference.synthetic.kinematics import Kinematics, SynthesisError

if TYPE_CHECKING:
    from contactmpc.scene import Scene

__all__ = ["GateLimits", "check_gates", "gate_report"]


@dataclass(frozen=True)
class GateLimits:
    """Thresholds of the quality gates (m, rad, s).

    Attributes:
        max_penetration: deepest allowed penetration of any kind.
        max_contact_distance: contact points to their surfaces, and link point to object point.
        min_hold_links: fewest links in contact during holds (the TTF rule needs more than six).
        max_keyframe_position_error, max_keyframe_rotation_error, max_keyframe_articulation_error:
            object configuration at the keyframe times.
        max_start_error: first frame against the task's initial hand and object configuration.
        max_wrist_speed, max_wrist_rate, max_finger_rate: speed limits (m/s, rad/s).
    """

    max_penetration: float = 0.002
    max_contact_distance: float = 0.003
    min_hold_links: int = 7
    max_keyframe_position_error: float = 1e-3
    max_keyframe_rotation_error: float = 1e-2
    max_keyframe_articulation_error: float = 1e-2
    max_start_error: float = 1e-6
    max_wrist_speed: float = 1.0
    max_wrist_rate: float = 6.0
    max_finger_rate: float = 8.0


def gate_report(scene: Scene, ref: Reference, kin: Kinematics | None = None) -> dict:
    """Measure a reference against the scene's geometry (see the module docstring).

    Args:
        scene: the scene the reference is for.
        ref: the reference (``meta`` must hold ``phases``, ``keyframes`` and ``contact_threshold``
            for the hold and keyframe gates; missing ones are reported as None).
        kin: kinematics to reuse (default: a fresh copy of the scene's model).

    Returns:
        A JSON-serialisable dict of floats and ints (None for a gate the meta gives no basis for).
    """
    kin = Kinematics(scene) if kin is None else kin
    task = scene.task
    threshold = float(ref.meta.get("contact_threshold", 0.001))
    hand, obj, env = kin.link_geoms, kin.object_geoms, kin.env_geoms
    groups = {
        "hand_object": kin.collision_pairs(hand, obj),
        "hand_env": kin.collision_pairs(hand, env),
        "hand_hand": kin.collision_pairs(hand, hand),
        "object_env": kin.collision_pairs(obj, env),
    }
    pairs = np.concatenate(list(groups.values()))
    group = np.concatenate([np.full(len(v), i) for i, v in enumerate(groups.values())])
    hand_obj = group == 0
    link_of_pair = kin.link_of_geom[pairs[hand_obj, 0]]
    num_t, num_l = ref.num_frames, ref.num_links
    deepest = np.zeros(len(groups))
    in_contact = np.zeros((num_t, num_l), bool)
    link_dist = obj_dist = gap = 0.0
    body_geoms = [obj[kin.object_of_geom[obj] == b] for b in range(len(kin.object_bodies))]
    distmax = max(threshold, 1e-4) + 1e-3
    for t in range(num_t):
        kin.set(ref.hand_qpos[t], ref.object_qpos[t])
        dist = kin.pair_distances(pairs, distmax)
        for i in range(len(groups)):
            if (group == i).any():
                deepest[i] = max(deepest[i], -dist[group == i].min())
        in_contact[t, link_of_pair[dist[hand_obj] <= threshold]] = True
        for link in np.flatnonzero(ref.contact_active[t]):
            p_link = kin.body_pose(kin.link_bodies[link]).apply(ref.contact_link_point[t, link])
            body = int(ref.contact_object_body[t, link])
            p_obj = kin.body_pose(kin.object_bodies[body]).apply(ref.contact_object_point[t, link])
            link_dist = max(link_dist, abs(kin.point_distance(p_link, [hand[link]])))
            obj_dist = max(obj_dist, abs(kin.point_distance(p_obj, body_geoms[body])))
            gap = max(gap, float(np.linalg.norm(p_link - p_obj)))
    pen = {k: float(max(v, 0.0)) for k, v in zip(groups, deepest, strict=True)}

    ranges = scene.hand.joint_ranges
    below = ref.hand_qpos < ranges[:, 0]
    above = ref.hand_qpos > ranges[:, 1]
    excess = np.maximum(ranges[:, 0] - ref.hand_qpos, ref.hand_qpos - ranges[:, 1]).max()

    holding = np.zeros(num_t, bool)
    phases = ref.meta.get("phases")
    for p in phases or []:
        if p.get("holding"):
            holding |= (ref.time >= p["start"] - 1e-9) & (ref.time <= p["end"] + 1e-9)

    report: dict = {
        "frames": num_t,
        "duration": ref.duration,
        "contact_threshold": threshold,
        **{f"penetration_{k}": v for k, v in pen.items()},
        "contact_link_point_distance": link_dist,
        "contact_object_point_distance": obj_dist,
        "contact_gap": gap,
        "joint_limit_violations": int(below.sum() + above.sum()),
        "joint_limit_excess": float(max(excess, 0.0)),
        "hold_frames": int(holding.sum()),
        "hold_links_min": int(in_contact[holding].sum(1).min()) if holding.any() else None,
        "hold_active_min": int(ref.contact_active[holding].sum(1).min()) if holding.any() else None,
        "active_links_max": int(ref.contact_active.sum(1).max()),
    }
    report.update(_keyframe_errors(task, ref))
    start = np.concatenate(
        [ref.hand_qpos[0] - task.hand_home, ref.object_qpos[0] - task.initial_object_qpos(kin.model)]
    )
    report["start_error"] = float(np.abs(start).max())
    dt = np.diff(ref.time)[:, None]
    vel = np.diff(ref.hand_qpos, axis=0) / dt
    n = scene.hand.num_root  # the floating wrist: slides [:3], hinges [3:n]; fingers [n:]
    report["max_wrist_speed"] = float(np.linalg.norm(vel[:, :3], axis=1).max()) if len(vel) else 0.0
    report["max_wrist_rate"] = float(np.abs(vel[:, 3:n]).max()) if len(vel) else 0.0
    report["max_finger_rate"] = float(np.abs(vel[:, n:]).max()) if len(vel) else 0.0
    return report


def _keyframe_errors(task, ref: Reference) -> dict:
    keyframes = ref.meta.get("keyframes")
    if not keyframes:
        return {
            "keyframe_position_error": None,
            "keyframe_rotation_error": None,
            "keyframe_articulation_error": None,
        }
    times = np.array([k["time"] for k in keyframes])
    frames = np.array([int(np.argmin(np.abs(ref.time - t))) for t in times])
    want = np.array([k["object_qpos"] for k in keyframes], float)
    err = task.layout.error(ref.object_qpos[frames], want)
    off = np.abs(ref.time[frames] - times).max()  # a keyframe between samples counts as misplaced
    return {
        "keyframe_position_error": float(err.position.max()) + float(off > 1e-9),
        "keyframe_rotation_error": float(err.rotation.max()),
        "keyframe_articulation_error": float(err.articulation.max()),
    }


def check_gates(report: dict, limits: GateLimits | None = None, task: str | None = None) -> None:
    """Raise if a report fails a gate.

    Args:
        report: from :func:`gate_report`.
        limits: thresholds (default :class:`GateLimits`).
        task: task name for the message.

    Raises:
        SynthesisError: one line naming the first failing gate, its value and its limit.
    """
    lim = limits or GateLimits()
    checks = [
        *((f"penetration_{k}", "<=", lim.max_penetration) for k in ("hand_object", "hand_env", "hand_hand")),
        ("penetration_object_env", "<=", lim.max_penetration),
        ("contact_link_point_distance", "<=", lim.max_contact_distance),
        ("contact_object_point_distance", "<=", lim.max_contact_distance),
        ("contact_gap", "<=", lim.max_contact_distance),
        ("joint_limit_violations", "<=", 0),
        ("hold_links_min", ">=", lim.min_hold_links),
        ("hold_active_min", ">=", lim.min_hold_links),
        ("keyframe_position_error", "<=", lim.max_keyframe_position_error),
        ("keyframe_rotation_error", "<=", lim.max_keyframe_rotation_error),
        ("keyframe_articulation_error", "<=", lim.max_keyframe_articulation_error),
        ("start_error", "<=", lim.max_start_error),
        ("max_wrist_speed", "<=", lim.max_wrist_speed),
        ("max_wrist_rate", "<=", lim.max_wrist_rate),
        ("max_finger_rate", "<=", lim.max_finger_rate),
    ]
    where = f"task {task!r}: " if task else ""
    for key, op, bound in checks:
        value = report.get(key)
        if value is None:
            raise SynthesisError(
                f"{where}gate {key}: not measured (reference meta lacks phases or keyframes)"
            )
        ok = value <= bound if op == "<=" else value >= bound
        if not ok:
            raise SynthesisError(f"{where}gate {key} failed: {value:.6g} (must be {op} {bound:.6g})")
