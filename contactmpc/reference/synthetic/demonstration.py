"""A synthetic demonstration and the function that turns one into a gated reference.

A demonstration (one per task in :mod:`contactmpc.reference.synthetic.designs`) is described by

* a **grasp problem**, solved once (and optionally re-solved along one object coordinate), and open
  fingers for approach and release (:mod:`contactmpc.reference.synthetic.grasp`);
* a list of **phases** (approach, reach, close, moves of the object, open, retreat) whose object
  keyframes are interpolated with a minimum-jerk profile (:mod:`contactmpc.reference.synthetic.phases`).

:meth:`Demonstration.synthesize` samples the phases at ``rate``, converts the wrist poses to joint
values, summarises the expected contacts (:mod:`contactmpc.reference.synthetic.contacts`) and builds the
:class:`~contactmpc.reference.data.Reference`; :func:`synthesize` then validates it and applies the
quality gates (:mod:`contactmpc.reference.synthetic.gates`).

Everything here is deterministic: no random initialisation, no wall-clock dependence.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np

from contactmpc.reference.bspline import UniformBSpline
from contactmpc.reference.data import Reference
from contactmpc.reference.synthetic.contacts import summarise_contacts
from contactmpc.reference.synthetic.gates import check_gates, gate_report
from contactmpc.reference.synthetic.grasp import (
    Grasp,
    GraspProblem,
    GraspSchedule,
    _GraspResidual,
    solve_grasp,
    solve_preshape,
)
from contactmpc.reference.synthetic.kinematics import Kinematics, Pose
from contactmpc.reference.synthetic.phases import Phase, PhaseContext

if TYPE_CHECKING:
    from contactmpc.scene import Scene

__all__ = ["SYNTHESIS_VERSION", "Demonstration", "suggest_num_control_points", "synthesize"]

SYNTHESIS_VERSION = 1
"""Bumped whenever synthesis changes its output (callers cache references by it)."""


def suggest_num_control_points(
    time: np.ndarray, hand_qpos: np.ndarray, tol_slide: float = 0.003, tol_angle: float = 0.05
) -> int:
    """Smallest M (cubic, clamped, uniform) fitting every hand curve within tolerance.

    Args:
        time: (T,) seconds.
        hand_qpos: (T, J) curves (wrist slides first).
        tol_slide: max error of the wrist slides (m).
        tol_angle: max error of the angles (rad).

    Returns:
        M, at most ``T // 2``.
    """
    tol = np.concatenate([np.full(3, tol_slide), np.full(hand_qpos.shape[1] - 3, tol_angle)])
    upper = max(4, len(time) // 2)
    for m in range(4, upper + 1):
        spline = UniformBSpline(m, (float(time[0]), float(time[-1])))
        fit = spline.evaluate(spline.fit(time, hand_qpos), time)
        if np.all(np.abs(fit - hand_qpos).max(axis=0) <= tol):
            return m
    return upper


# ----------------------------------------------------------------------------------- demonstration
class Demonstration:
    """Base class of a task's synthetic demonstration.

    Subclasses define :meth:`grasp_problem` (the grasp at the object's initial configuration),
    :meth:`phases` and optionally :meth:`regrasp_values` (re-solve the grasp along one object
    coordinate). :meth:`synthesize` turns them into a :class:`~contactmpc.reference.Reference` (gates
    are applied by the module-level :func:`synthesize`).

    Attributes:
        rate: samples per second of demonstration time.
        contact_threshold: link–object distance (m) under which a contact is expected.
        approach_offset: (3,) world offset of the pre-grasp pose from the grasp pose (m); the hand
            also backs off along it (in the grasp body's frame) in :class:`Retreat`.
        open_fraction: how far the pre-shape's initial guess opens the grasp's flexion (0 to 1).
        preshape_standoff: distance (m) of the open fingers from the object during the approach.
        regrasp_weight: regulariser of a regrasp towards its neighbour (per rad, per cm).
        regrasp_tolerance: extra penetration (m) between two regrasps that triggers a midpoint one.
        regrasp_refinements: rounds of midpoint regrasps.
    """

    cacheable = True  # synthesis takes seconds: get_reference caches the result
    rate: float = 50.0
    contact_threshold: float = 0.001
    approach_offset: tuple[float, float, float] = (0.0, 0.0, 0.06)
    open_fraction: float = 0.5
    preshape_standoff: float = 0.008
    regrasp_weight: float = 10.0
    regrasp_tolerance: float = 0.0003
    regrasp_refinements: int = 3

    def build(self, scene: Scene) -> Reference:
        """The gated reference of ``scene.task`` by this design (:func:`synthesize`)."""
        return synthesize(scene, self)

    def grasp_problem(self, scene: Scene, kin: Kinematics) -> GraspProblem:
        """The grasp at the object's initial configuration."""
        raise NotImplementedError

    def regrasp_values(self, scene: Scene) -> tuple[int, tuple[float, ...], np.ndarray | None] | None:
        """Re-solve the grasp along one object coordinate: ``(column of q_o, values, object_qpos)``.

        ``values[0]`` is the coordinate's value in the initial grasp; each further value is solved
        warm-started from the previous, at ``object_qpos`` (None: the initial grasp's) with the
        column set to the value, e.g. with the object lifted clear of the table. None: one grasp.
        """
        return None

    def phases(self, scene: Scene) -> list[Phase]:
        """The phases, in order."""
        raise NotImplementedError

    def preshape(self, scene: Scene, kin: Kinematics, problem: GraspProblem, grasp: Grasp) -> np.ndarray:
        """(num_fingers,) open fingers for approach and release: :func:`solve_preshape` started from the
        grasp's fingers with their flexion joints (``hand.flexion_joints``) opened by ``open_fraction``."""
        hand = scene.hand
        flexion = np.array([hand.finger_joints.index(j) for j in hand.flexion_joints], dtype=int)
        fingers = grasp.fingers.copy()
        fingers[flexion] *= 1.0 - self.open_fraction
        return solve_preshape(
            kin,
            problem,
            grasp,
            np.asarray(self.approach_offset, float),
            scene.hand.finger_ranges,
            initial=fingers,
            standoff=self.preshape_standoff,
        )

    # ---------------------------------------------------------------------------------------
    def solve(self, scene: Scene, kin: Kinematics, problem: GraspProblem) -> GraspSchedule:
        """Solve the grasp, and the regrasps along :meth:`regrasp_values`.

        Each regrasp is warm-started from the previous one (riding with the body) and regularised
        towards it. Then every interval whose interpolated hand penetrates the object or itself by
        more than ``regrasp_tolerance`` beyond its end grasps is split by one more regrasp at its
        midpoint (up to ``regrasp_refinements`` rounds).
        """
        ranges = scene.hand.joint_ranges
        first = solve_grasp(kin, problem, ranges)
        regrasp = self.regrasp_values(scene)
        if regrasp is None:
            return GraspSchedule((first,))
        column, values, where = regrasp
        base = np.asarray(first.object_qpos if where is None else where, float)
        body = kin.body_id(problem.body)
        check = _GraspResidual(kin, problem)
        inside = check.pair_kind != 1  # hand-object and hand-hand pairs

        def at(value: float) -> np.ndarray:
            qo = base.copy()
            qo[column] = value
            return qo

        def hand(offset: Pose, fingers: np.ndarray, qo: np.ndarray, reference: np.ndarray) -> np.ndarray:
            kin.set(first.hand_qpos, qo)
            wrist = kin.body_pose(body) * offset
            return np.concatenate([kin.wrist_qpos(wrist, reference[: kin.num_root]), fingers])

        def regrasp(qo: np.ndarray, init: np.ndarray) -> Grasp:
            step = dataclasses.replace(
                problem,
                object_qpos=qo,
                initial=init,
                natural=init[kin.num_root :],
                natural_weight=self.regrasp_weight,
                wrist_weight=self.regrasp_weight,
                wrist_position_weight=self.regrasp_weight,
            )
            return solve_grasp(kin, step, ranges)

        def schedule(chain: list[Grasp]) -> GraspSchedule:
            order = np.argsort(np.asarray([g.object_qpos[column] for g in chain]), kind="stable")
            return GraspSchedule(
                tuple(chain[i] for i in order),
                column=column,
                values=np.asarray([chain[i].object_qpos[column] for i in order], float),
                initial=int(np.flatnonzero(order == 0)[0]),
            )

        chain = [first]
        for v in values[1:]:
            prev = chain[-1]
            chain.append(regrasp(at(v), hand(prev.offset, prev.fingers, at(v), prev.hand_qpos)))
        for _ in range(self.regrasp_refinements):
            sched = schedule(chain)
            grasps, added = sched.grasps, []
            for a, b in zip(grasps[:-1], grasps[1:], strict=True):
                va, vb = a.object_qpos[column], b.object_qpos[column]
                deepest = 0.0
                for f in (0.25, 0.5, 0.75):
                    qo = at((1 - f) * va + f * vb)
                    kin.set(hand(*sched.at(qo), qo, a.hand_qpos), qo)
                    dist = kin.pair_distances(check.pairs[inside], check.margin)
                    deepest = max(deepest, -float(dist.min()))
                if deepest - max(a.max_penetration, b.max_penetration) > self.regrasp_tolerance:
                    qo = at(0.5 * (va + vb))
                    added.append(regrasp(qo, hand(*sched.at(qo), qo, a.hand_qpos)))
            if not added:
                break
            chain += added
        return schedule(chain)

    def synthesize(self, scene: Scene) -> tuple[Reference, dict]:
        """Build the reference (without gates) and a dict of diagnostics (grasps, timings)."""
        kin = Kinematics(scene)
        task = scene.task
        problem = self.grasp_problem(scene, kin)
        schedule = self.solve(scene, kin, problem)
        first = schedule.first
        kin.set(task.hand_home, first.object_qpos)
        body_id = kin.body_id(first.body)
        body0 = kin.body_pose(body_id)
        initial_qo = task.initial_object_qpos(kin.model)
        preshape = self.preshape(scene, kin, problem, first)
        kin.set(task.hand_home, initial_qo)
        home_wrist = kin.root_pose()
        ctx = PhaseContext(
            kin=kin,
            task=task,
            body=body_id,
            schedule=schedule,
            home=task.hand_home.copy(),
            preshape=preshape,
            approach_offset=body0.rot.inv().apply(np.asarray(self.approach_offset, float)),
            object_qpos=initial_qo,
            wrist=home_wrist,
            fingers=task.hand_home[kin.num_root :].copy(),
        )
        phases = self.phases(scene)
        frames = [max(1, round(p.duration * self.rate)) for p in phases]
        num_t = sum(frames) + 1
        wrists: list[Pose] = []
        root = slice(0, kin.num_root)
        fingers = np.zeros((num_t, scene.hand.num_fingers))
        objects = np.zeros((num_t, task.layout.width))
        phase_meta, keyframes = [], [{"time": 0.0, "object_qpos": initial_qo.tolist()}]
        k = 0
        for i, (phase, n) in enumerate(zip(phases, frames, strict=True)):
            last = i == len(phases) - 1
            for j in range(n + 1 if last else n):
                w, f, qo = phase.sample(j / n, ctx)
                wrists.append(w)
                fingers[k], objects[k] = f, qo
                k += 1
            w, f, qo = phase.sample(1.0, ctx)
            start = (k - (n + 1 if last else n)) / self.rate
            phase_meta.append(
                {"name": phase.name, "start": start, "end": start + n / self.rate, "holding": phase.holding}
            )
            keyframes.append({"time": start + n / self.rate, "object_qpos": np.asarray(qo).tolist()})
            ctx.wrist, ctx.fingers, ctx.object_qpos = w, np.asarray(f, float), np.asarray(qo, float)
        hand = np.zeros((num_t, scene.hand.num_joints))
        prev = task.hand_home[root]
        for t, w in enumerate(wrists):
            hand[t, root] = kin.wrist_qpos(w, prev)
            prev = hand[t, root]
        hand[:, root.stop :] = fingers
        time = np.arange(num_t) / self.rate
        active, link_pt, obj_pt, obj_body = summarise_contacts(kin, hand, objects, self.contact_threshold)
        meta = {
            "source": "synthetic",
            "generator": f"{type(self).__module__}.{type(self).__name__}",
            "version": SYNTHESIS_VERSION,
            "units": "m, rad, s",
            "time_scale": task.time_scale,
            "sample_rate": self.rate,
            "object_quat_index": task.layout.quat_index,
            "num_control_points": suggest_num_control_points(time, hand),
            "contact_threshold": self.contact_threshold,
            "grasp_body": first.body,
            "phases": phase_meta,
            "keyframes": keyframes,
        }
        ref = Reference(
            time=time,
            hand_qpos=hand,
            object_qpos=objects,
            contact_active=active,
            contact_link_point=link_pt,
            contact_object_point=obj_pt,
            contact_object_body=obj_body,
            link_names=np.array(scene.hand.link_names),
            joint_names=np.array(scene.hand.joint_names),
            object_bodies=np.array(task.object_bodies),
            task=task.name,
            meta=meta,
        )
        info = {
            "grasps": [
                {
                    "object_qpos": g.object_qpos.tolist(),
                    "target_distance_mm": (1e3 * g.target_distance).round(2).tolist(),
                    "max_penetration_mm": round(1e3 * g.max_penetration, 3),
                    "min_clearance_mm": round(1e3 * g.min_clearance, 3)
                    if np.isfinite(g.min_clearance)
                    else None,
                    "cost": g.cost,
                }
                for g in schedule.grasps
            ]
        }
        return ref, info


def synthesize(scene: Scene, demo: Demonstration, *, gates: bool = True) -> Reference:
    """Synthesise, check and return the reference motion of ``scene.task`` by the demonstration ``demo``.

    Deterministic: the same scene and demonstration give bit-identical arrays.

    Args:
        scene: the scene (hand + task).
        demo: the task's demonstration (e.g. one of
            :mod:`contactmpc.reference.synthetic.designs`).
        gates: run the quality gates (:func:`~contactmpc.reference.synthetic.gates.check_gates`) before
            returning.

    Returns:
        The validated reference; ``meta["gates"]`` holds the gate report and ``meta["grasps"]`` the
        solver's diagnostics of each grasp.

    Raises:
        SynthesisError: a gate failed (one line naming the gate and value).
    """
    ref, info = demo.synthesize(scene)
    ref.meta["grasps"] = info["grasps"]
    ref.validate(scene.hand.joint_names, scene.hand.link_names)
    if gates:
        report = gate_report(scene, ref)
        ref.meta["gates"] = report
        check_gates(report, task=scene.task.name)
    return ref
