"""The sampling-planner loop shared by every planner.

A planner implements two methods, :meth:`Planner.sample` (candidate control points around the
nominal) and :meth:`Planner.update` (the new nominal from scored candidates). The base class owns
everything else: the spline window, warm start (the committed control points persist between
replans), mapping control points to clipped joint targets, the batched rollout, and scoring.

Its public surface: :meth:`Planner.bind` (attach a :class:`~contactmpc.control.problem.Problem`),
:meth:`Planner.plan` (one planning iteration that commits its result), :meth:`Planner.targets` (the
committed policy: joint targets at given times), :meth:`Planner.candidates` (the candidate batch of
an iteration) and :meth:`Planner.evaluate` (roll out and score control points).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Annotated, NamedTuple

import mujoco
import numpy as np

from contactmpc.control.cost import as_index
from contactmpc.control.grip import Grip
from contactmpc.control.guidance import CONTROL_SPEC, ObjectGuidance
from contactmpc.control.latency import ComputeLatency
from contactmpc.control.problem import Problem
from contactmpc.control.release import retraction, time_window
from contactmpc.control.robust import ModelEnsemble
from contactmpc.control.rollout import RolloutEngine
from contactmpc.tasks.layout import tilt_angle
from contactmpc.validate import ConfigError, Ge, Gt, checked


@dataclass
class PlanInfo:
    """What one planning iteration did.

    Attributes:
        time: control time at which it planned (s).
        nominal_cost: cumulative cost of the unperturbed nominal (sample 0), or NaN without rollouts (with
            guidance: the nominal the last, unguided iteration starts from, as the planning model scores it).
        best_cost: lowest cumulative cost among the samples (NaN without rollouts).
        terms: cumulative cost terms of the committed (best) sample, by the cost's term names (NaN
            without rollouts).
        num_diverged: samples whose rollout diverged (over all the iterations).
        window: (Mw,) indices of the control points that could change.
        seconds: wall time of the iteration.
        iterations: sampling iterations it ran (``planner.iterations``, fewer when it stopped early).
        samples: the samples an iteration drew (``acquire_samples`` in the acquire window, cut to
            ``step_budget``); 0 without rollouts.
        reference_time: the reference's time it planned at (s); ``None``: ``time`` (the reference is not
            paced, ``planner.pace_lag``).
        prediction: (:attr:`Planner.compensate_latency`) how far the state it planned from is from where
            the last plan's prediction put it: the free object's position (m) and orientation (rad) errors
            between the measured state and the planning model's prediction for this time (NaN where there
            was none for it); ``None`` for a planner that does not predict.
    """

    time: float
    nominal_cost: float = float("nan")
    best_cost: float = float("nan")
    terms: dict[str, float] = field(default_factory=dict)
    num_diverged: int = 0
    window: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    seconds: float = 0.0
    iterations: int = 1
    samples: int = 0
    reference_time: float | None = None
    prediction: tuple[float, float] | None = None


class Scored(NamedTuple):
    """One planning iteration's scored candidates, what :meth:`Planner.commit` chooses from.

    Attributes:
        state: the full physics state planned from.
        t: control time (s).
        window: (Mw,) the control points sampled.
        candidates: (S, Mw, d) their sampled values.
        total: (S,) cumulative costs.
        terms: cost term -> (S,) values.
    """

    state: np.ndarray
    t: float
    window: np.ndarray
    candidates: np.ndarray
    total: np.ndarray
    terms: dict


class Planner:
    """Base class of the sampling planners.

    Args:
        num_samples: rollouts per planning iteration (sample 0 is the nominal).
        horizon: planning horizon (s).
        replan_period: control time between the starts of planning iterations (s), at least: with a
            latency longer than it, the next plan starts when the last one takes effect (MuJoCo MPC's
            continuous replanning). A whole number of plant steps.
        latency: planning latency (s): the plan computed from the state at t takes effect at t +
            latency, the plant following the previous plan until then. 0: at once (the synchronous
            loop). A whole number of plant steps.
        latency_model: model the latency from the planner's size instead
            (:class:`~contactmpc.control.latency.ComputeLatency`); ``latency`` must then be 0.
        latency_per_plan: charge each plan its own price (:meth:`latency_at`: the model's price of the
            samples and horizon of that plan's phase) instead of every plan the dearest phase's
            (:meth:`latency_for`), so a trial's grasp plans take longer than its later ones, as on a
            machine of the model's threads (MuJoCo MPC's loop, deterministically). Needs
            ``latency_model``; False (the default): every plan the same latency.
        nthread: rollout threads; ``None`` = the CPUs this process may use (its affinity mask and
            cgroup quota, :func:`~contactmpc.control.rollout.available_cpus`), so a Slurm job with
            8 CPUs on a 64-core node starts 8.
        robust: score every candidate under an ensemble of randomised planning models and a risk
            measure (:class:`~contactmpc.control.robust.ModelEnsemble`); ``None``: the nominal model.
        iterations: sampling iterations per plan (SPIDER, DIAL-MPC): each samples around the nominal
            the last one committed, from the same state; the latency model charges them all. 1 (the
            paper): one.
        anneal: the noise of iteration ``i`` (from 0) is the sampler's times ``anneal ** (i /
            iterations)`` (SPIDER: 0.1); 1: the same noise in every iteration.
        early_stop: stop iterating once an iteration improves the cost by less than this fraction of
            its nominal's (SPIDER: 0.01); 0: run every iteration.
        compensate_latency: plan from the state the plant is predicted to be in when the plan takes
            effect (:meth:`predict`: the planning model rolled forward from the measured state under
            the committed policy, which the plant follows until then, for the latency), starting the
            plan's window there; False (the paper, MuJoCo MPC): from the measured state, so a plan
            spends its first ``latency`` on controls that are never applied. No effect without latency.
        acquire_samples: samples a plan draws while contact is approached and acquired, from the start
            until ``acquire_until`` after the reference's first expected contact (where the stapler's
            grasp is won or lost: the paper point's 128 samples lift it, 32 rarely); ``None`` (the
            paper): ``num_samples`` throughout. A latency model prices the larger plan.
        acquire_until: seconds after the first expected contact that ``acquire_samples`` (and
            ``acquire_horizon``) lasts.
        acquire_grasp: with ``acquire_samples``, the window lasts ``acquire_until`` after the reference's
            first instant with at least this many fingers on the object (a finger as counted for
            ``reuse_grasp``) instead of after its first expected contact (not the paper's), so a grasp the
            reference closes finger by finger (the stapler's: its index alone before the others come)
            keeps the grasp's samples until it has closed, and one it closes at once (the apple's) keeps
            them about as long as from its first contact; 0 (the default): from the first expected
            contact. A reference that never expects that many: from the first expected contact.
        acquire_waiting: with ``acquire_samples`` and a paced reference (``pace_lag``), a plan that takes
            effect while the reference's clock is held draws ``acquire_samples`` (and plans over
            ``acquire_horizon``) after the window too (not the paper's): a lift that waits for the grasp
            once the window is over keeps the grasp's samples while it waits. No plan draws more than
            ``acquire_samples``; a latency model already prices every plan at the dearer phase's.
        acquire_error: ``(position m, rotation rad)``: with ``acquire_samples``, a plan made between the
            reference's first and last expected contact from a state whose free object is more than
            either from where the reference has it draws ``acquire_samples`` (and plans over
            ``acquire_horizon``) after the window too (not the paper's): a carried object that slips or
            turns in the grasp is planned with the grasp's samples until it is back. ``None`` (the
            default): never. No plan draws more than ``acquire_samples``; a latency model already prices
            every plan at the dearer phase's. No effect on an object without a free body.
        acquire_horizon: the horizon (s) of the plans in that window, the grasp's (not the paper's): a
            plan there rolls out and scores this much of the reference, so its samples cost
            ``acquire_horizon / horizon`` of a full plan's; ``None`` (the paper): ``horizon`` throughout. A
            latency model prices the dearer of the two phases' plans.
        step_budget: the rollout steps one plan may run per iteration (samples x the horizon's
            planning-model steps): a plan draws at most ``step_budget // steps`` samples (at least 1),
            so a finer planning model draws fewer; ``None`` (the paper): no budget.
        approach_reset: seconds before the reference's first expected contact at which the committed
            control points whose support meets the rest of the trial go back to the reference's own
            (the problem's ``theta0``), once: the hand meets the object with the reference's nominal,
            as a screen trial (``job.start_before_contact``) starts, not with what the approach's
            sampling did to it. ``None`` (the paper): never.
        guidance: contact guidance in the planning model only, annealed over the plan's ``iterations``
            (:class:`~contactmpc.control.guidance.ObjectGuidance`; not the paper's): every iteration but
            the last rolls out with the object pulled toward the reference's, the last without; an
            iteration with guidance does not stop the plan early. ``None`` (the paper): none.
        pace_lag: pace the reference by the object (not the paper's): between the reference's first and
            last expected contact, while the free object's position is more than this many metres from
            the reference's, the reference's clock runs at ``pace_rate`` instead of with control time, so
            the reference waits for the object (a lift waits for a grasp) instead of leaving without it;
            every time-indexed part of a plan (the cost's reference, the sampled control points, the
            acquire and release phases, the policy's targets) follows the reference's clock
            (:meth:`reference_time`). ``None`` (the paper): the reference runs with control time. A trial
            on a free object then runs ``pace_budget`` longer; on one without a free body it never waits.
        pace_budget: control time the reference may fall behind in all (s).
        pace_rate: the reference's clock rate while it waits, in [0, 1): 0 holds it.
        pace_angle: wait also while the free object's orientation is more than this many radians from
            the reference's; ``None``: its position alone.
        pace_window: ``(start, end)`` seconds relative to the reference's last expected contact: wait only
            while the reference's time is in that interval (``(-0.5, 0.0)``: the release waits for the
            object to be where the reference sets it down); ``None``: anywhere between the first and last
            expected contact.
        pace_grasp: with ``pace_window``, wait also before that window (not the paper's; m): from the
            reference's first expected contact until its window begins, while the free object's position
            is more than this many metres from the reference's (``pace_window`` ``None``'s rule: a lift
            waits for a grasp), for up to ``pace_budget`` of its own, so the window's wait keeps its
            whole budget; a trial then runs twice ``pace_budget`` longer. ``pace_turn`` acts only in the
            window's wait. ``None``: the window alone.
        pace_retry: try a lost grasp again (not the paper's; s; needs ``pace_lag`` without ``pace_window``):
            where, between the reference's first and last expected contact, the free object has lain this
            long not lifted (not more than ``carry_lift`` above where it starts) while the reference has it
            lifted (more than that), more than ``pace_lag`` from the reference's, with at most
            ``pace_retry_fingers`` fingers on it (a lift that left it behind, or dropped it), the
            reference not waiting for it (its wait's time is not counted: ``pace_budget`` first), the
            reference's clock runs backwards at ``pace_retry_rate`` to ``pace_retry_to`` before the first
            expected contact, then on with control time: the hand comes to the object again, from the
            reference's own control points (``problem.theta0``) from there on. A rewind costs its
            reference seconds x (1 + 1 / ``pace_retry_rate``) of control time, out of
            ``pace_retry_budget`` (a trial on a free object runs that much longer); none that does not fit.
            The holds' ``pace_budget`` does not count the rewinds. ``None`` (the paper): never.
        pace_retry_to: seconds before the reference's first expected contact that a rewind goes back to.
        pace_retry_rate: how fast the reference's clock runs backwards while it rewinds (reference seconds
            per control second).
        pace_retry_budget: control time the rewinds may take in all (s).
        pace_retry_fingers: the most fingers on the object (:meth:`fingers_touching`) for it to count as lost.
        pace_retry_tilt: the most the object may be tilted from how it starts (rad, its vertical axis) for a
            rewind: one that has fallen on its side or over is not tried again. ``None``: any.
        pace_retry_follow: ``(start, end)`` seconds after the first expected contact: a rewind also moves the
            wrist's translation across the table by where the object now lies from where the reference has
            it at ``pace_retry_to`` (its horizontal offset; not its turn), wholly on the control points up to
            ``start`` and fading to none at ``end`` by each point's Greville abscissa, so the hand comes to
            the object where it lies and carries it back onto the reference's path. ``None``: the
            reference's wrist.
        carry_gain: carry the object where the reference has it (not the paper's; 1/s): while the free
            object and the reference's are both more than ``carry_lift`` above where the object starts
            (it is carried), each plan moves the wrist's committed translation, on the control points from
            the plan's window on, by this gain x the control time since the last plan x the object's
            position error (the reference's position minus the object's): the wrist takes up the object's
            slip in the hand, an integral feedback on the object. The shift stays after the carry (and
            through a release reset), at most ``carry_limit`` in all. 0 (the paper): never.
        carry_lift: height above its start (m) at which the object (and the reference's) counts as carried.
        carry_limit: the most the wrist is shifted in all (m, the norm of the shift).
        carry_turn: the same for the object's orientation (1/s; 0: its position only): the wrist's
            committed hinge angles turn by this gain x the time since the last plan x the rotation that
            takes the object's orientation to the reference's (world frame, through the wrist's rotational
            Jacobian at the measured state), and its translation moves the object back where the turn
            about the wrist would swing it; at most ``carry_turn_limit`` (rad) in all.
        carry_turn_limit: the most the wrist's hinges are turned in all (rad, the norm of the turn).
        pace_turn: turn the object upright while a paced reference waits (not the paper's; 1/s; needs
            ``pace_lag``): at each plan that finds the reference's clock held and the object not carried
            (set down), the wrist turns as ``carry_turn`` has it, at this gain, toward the orientation the
            reference has the object in there, the object kept where it is; in the same total as the
            carry's turn (``carry_turn_limit``). 0: the wait only holds the hand still.
        pace_turn_fade: wind the wrist's hinge shift (the turn) back after the release (not the paper's; s):
            the release's control points take it in full at the reference's last expected contact and none
            of it from this many seconds after, linearly by each point's Greville abscissa, so the
            retraction follows the reference's wrist angles again (a hinge shift kept on the reference's
            retraction can bring the wrist's three hinges to their gimbal lock). ``None``: kept.
        carry_hold: control time (s) the object must have been carried (both above ``carry_lift``, without
            a break) before the carry shifts the wrist: the grasp has held, so the feedback does not pull
            on an object the hand is still lifting. 0: from the first plan it is carried.
        grip: squeeze the fingers the reference expects in contact (not the paper's): their flexion
            joints' targets pressed into the object, in the rollouts and the plant alike
            (:class:`~contactmpc.control.grip.Grip`); ``None`` (the paper): the policy's targets as they are.
        switch_timestep: from ``switch_after`` seconds after the reference's first expected contact on, plan
            on a model stepped at this many seconds instead of the scene's ``planner_timestep`` (not the
            paper's): its own planning model, its reference track and its cost
            (:meth:`~contactmpc.control.problem.Problem.stepped`), the committed control points carried
            over; ``step_budget`` then counts that model's steps, and a latency model prices the larger
            plan of the two phases. ``None`` (the paper): one planning model throughout.
        switch_after: seconds after the reference's first expected contact at which ``switch_timestep``
            takes over; ``None``: only by ``switch_error``.
        switch_error: switch also (or only, with ``switch_after`` ``None``) once the planning model has
            mispredicted the object: from the reference's first expected contact on, at the plan whose last
            ``switch_count`` predictions (:attr:`PlanInfo.prediction`, ``compensate_latency``) each missed the
            free object's position by more than this many metres. ``None``: by time alone.
        switch_count: consecutive predictions over ``switch_error`` that switch.
        switch_back_after: seconds after the reference's last expected contact (where it lets go) at which
            a switched planner goes back to the scene's planning model (its own problem, as bound), once;
            ``None``: it keeps the switched model to the end.
        switch_back_held: the switched model only until the grasp has held: the object carried
            ``carry_hold`` seconds (the signal that starts the wrist's carry, ``carry_gain``, which it
            needs). From that plan on a switched planner goes back to the scene's planning model, once, and
            one that has not switched yet never does. False: not on the grasp.
        switch_for: seconds of reference time a switched planner plans on the switched model, counted from
            its switch (:attr:`switched_at`): from then on its own problem on the scene's planning model
            again, once, so the finer model plans one stretch (e.g. the lift) and not the rest. ``None``: by
            ``switch_back_after`` or ``switch_back_held`` alone (which it cannot join with
            ``switch_back_after``).
        reuse: carry the last plan's runners-up into the next plan (iCEM's kept elites, Pinneri et al.
            2020; not the paper's): the next plan's first iteration replaces this many of its fresh
            samples (the last rows; row 0 stays the nominal) by the last plan's cheapest finite
            candidates other than the one it committed, each as its difference from the committed control
            points added to the nominal on the control points both windows cover (the nominal elsewhere),
            so a reset or a carry shift of the nominal since is kept. The same rollouts a plan, so the
            latency model charges nothing more. 0 (the paper): every sample fresh.
        reuse_after: with ``reuse``, carry the runners-up only into the plans from this many seconds after
            the reference's first expected contact (not the paper's; ``acquire_until``'s 2 s: once the
            grasp's plans of ``acquire_samples`` are over), so the grasp is won by fresh samples alone
            and the lift and carry keep their runners-up; ``None`` (the default): into every plan.
        reuse_fingers: with ``reuse``, carry the runners-up only into the plans whose state has at least
            this many fingers on the object (not the paper's; a finger: the hand's contact links named
            ``<finger>_*``, touching the object in the planning model at the plan's state), so a plan
            with one finger alone on the object (the stapler's index, pushing it before the thumb comes)
            draws every sample fresh; 0 (the default): into every plan.
        reuse_until: with a fingers' gate (``reuse_fingers``, ``reuse_alone``), carry the runners-up into
            every plan before this many seconds after the reference's first expected contact (negative:
            before it) whatever the fingers on the object, so the approach keeps them until then and the
            last of it draws fresh (not the paper's); ``None`` (the default): the fingers alone decide.
        reuse_alone: with ``reuse``, carry the runners-up also into the plans whose state has exactly one
            finger on the object (as counted for ``reuse_fingers``). False (not the paper's): such a plan
            draws every sample fresh, while a plan with no finger on the object (the approach) or with two
            or more keeps them; True (the default): no such gate.
        reuse_grasp: with ``reuse``, carry the runners-up only into the plans from the reference's first
            instant at which it expects at least this many fingers on the object (not the paper's; a
            finger as counted for ``reuse_fingers``, from the reference's expected contacts), so the
            approach and a reference's lone finger (the stapler's index, before the thumb comes)
            draw every sample fresh, and a grasp the reference closes at once (the apple's, the bottle's)
            keeps them from its start; 0 (the default): no such gate. A reference that never expects that
            many: into no plan.
        reuse_scaled: with ``reuse``, keep and carry in ``reuse`` runners-up per ``num_samples`` samples
            of the plan (not the paper's): a plan of ``acquire_samples`` (128 against 32) keeps 4x as
            many and the next takes in as many as its own size allows at that share, so the grasp's
            larger plans carry the same share of runners-up as the later ones; False (the default):
            ``reuse`` of them whatever a plan's size.
        lazy_distances: compute a link's link-object distance sensors (``scene.link_distance_cutoff``) only
            in the plans whose window the cost reads them in (:meth:`TrackingCost.distances_read
            <contactmpc.control.cost.TrackingCost.distances_read>`: the clearance term's links before
            their first expected contact, the surface term's expected ones); the others are computed as
            MuJoCo's clock, the cheapest sensor, in the same place, for that plan's rollouts. The same
            costs, so the same trial bit for bit, at fewer ``geomdist`` computations (not the paper's, which
            has no such sensors); False (the default): every distance at every step. Not with ``guidance``
            or ``robust`` (their planning models are not the engine's).
    """

    needs_rollouts = True
    extra_rollouts = 0  # rollouts an iteration runs besides its samples (see :meth:`rollouts_per_plan`)

    @checked
    def __init__(
        self,
        num_samples: Annotated[int, Ge(1)] = 128,
        horizon: Annotated[float, Gt(0)] = 2.5,
        replan_period: Annotated[float, Gt(0)] = 0.01,
        nthread: Annotated[int, Ge(1)] | None = None,
        robust: ModelEnsemble | None = None,
        latency: Annotated[float, Ge(0)] = 0.0,
        latency_model: ComputeLatency | None = None,
        latency_per_plan: bool = False,
        iterations: Annotated[int, Ge(1)] = 1,
        anneal: Annotated[float, Gt(0)] = 1.0,
        early_stop: Annotated[float, Ge(0)] = 0.0,
        compensate_latency: bool = False,
        acquire_samples: Annotated[int, Ge(1)] | None = None,
        acquire_until: float = 2.0,
        acquire_grasp: Annotated[int, Ge(0)] = 0,
        acquire_waiting: bool = False,
        acquire_error: tuple[float, float] | None = None,
        acquire_horizon: Annotated[float, Gt(0)] | None = None,
        step_budget: Annotated[int, Ge(1)] | None = None,
        approach_reset: Annotated[float, Ge(0)] | None = None,
        guidance: ObjectGuidance | None = None,
        pace_lag: Annotated[float, Gt(0)] | None = None,
        pace_budget: Annotated[float, Ge(0)] = 3.0,
        pace_rate: Annotated[float, Ge(0)] = 0.0,
        pace_angle: Annotated[float, Gt(0)] | None = None,
        pace_window: tuple[float, float] | None = None,
        pace_grasp: Annotated[float, Gt(0)] | None = None,
        pace_retry: Annotated[float, Ge(0)] | None = None,
        pace_retry_to: Annotated[float, Ge(0)] = 0.5,
        pace_retry_rate: Annotated[float, Gt(0)] = 3.0,
        pace_retry_budget: Annotated[float, Ge(0)] = 8.0,
        pace_retry_fingers: Annotated[int, Ge(0)] = 1,
        pace_retry_tilt: Annotated[float, Gt(0)] | None = None,
        pace_retry_follow: tuple[float, float] | None = None,
        carry_gain: Annotated[float, Ge(0)] = 0.0,
        carry_lift: Annotated[float, Ge(0)] = 0.02,
        carry_limit: Annotated[float, Ge(0)] = 0.1,
        carry_turn: Annotated[float, Ge(0)] = 0.0,
        carry_turn_limit: Annotated[float, Ge(0)] = 0.5,
        carry_hold: Annotated[float, Ge(0)] = 0.0,
        pace_turn: Annotated[float, Ge(0)] = 0.0,
        pace_turn_fade: Annotated[float, Gt(0)] | None = None,
        grip: Grip | None = None,
        switch_timestep: Annotated[float, Gt(0)] | None = None,
        switch_after: float | None = 2.0,
        switch_error: Annotated[float, Gt(0)] | None = None,
        switch_count: Annotated[int, Ge(1)] = 2,
        switch_back_after: float | None = None,
        switch_back_held: bool = False,
        switch_for: Annotated[float, Ge(0)] | None = None,
        reuse: Annotated[int, Ge(0)] = 0,
        reuse_after: float | None = None,
        reuse_fingers: Annotated[int, Ge(0)] = 0,
        reuse_alone: bool = True,
        reuse_until: float | None = None,
        reuse_grasp: Annotated[int, Ge(0)] = 0,
        reuse_scaled: bool = False,
        lazy_distances: bool = False,
    ) -> None:
        if latency and latency_model is not None:
            raise ConfigError(
                f"{type(self).__name__}: latency = {latency:g} s and a latency_model are both set: "
                "choose one (planner.latency=0 or planner.latency_model=null)"
            )
        if latency_per_plan:  # each plan priced by its time alone (Trial.schedule): nothing else may set it
            for on, why in (
                (latency_model is None, "a fixed latency (set planner.latency_model)"),
                (
                    switch_timestep is not None,
                    "a planning model switched on the state (planner.switch_timestep)",
                ),
                (pace_lag is not None, "a paced reference, whose phase lags its time (planner.pace_lag)"),
            ):
                if on:
                    raise ConfigError(
                        f"planner.latency_per_plan prices each plan by its time: not with {why}"
                    )
        if pace_rate >= 1.0:
            raise ConfigError(
                f"planner.pace_rate = {pace_rate:g}: a waiting reference's clock must run slower than 1"
            )
        self.pace_lag = None if pace_lag is None else float(pace_lag)
        self.pace_budget = float(pace_budget)
        self.pace_rate = float(pace_rate)
        self.pace_angle = None if pace_angle is None else float(pace_angle)
        self.pace_window = time_window("planner.pace_window", pace_window)
        if pace_grasp is not None and (pace_lag is None or pace_window is None):
            raise ConfigError(
                "planner.pace_grasp paces the grasp before the release's window: set planner.pace_lag and "
                "planner.pace_window"
            )
        self.pace_grasp = None if pace_grasp is None else float(pace_grasp)
        self._paced_release = False  # (pace_grasp) the clock was last held by the window's rule
        self._grasp_behind = 0.0  # (pace_grasp) how far the grasp's waits left the reference behind
        if pace_retry is not None and (pace_lag is None or pace_window is not None):
            raise ConfigError(
                "planner.pace_retry tries the grasp again where a paced reference's wait for it runs long: "
                "set planner.pace_lag, without planner.pace_window"
            )
        self.pace_retry = None if pace_retry is None else float(pace_retry)
        self.pace_retry_to = float(pace_retry_to)
        self.pace_retry_rate = float(pace_retry_rate)
        self.pace_retry_budget = float(pace_retry_budget)
        self.pace_retry_fingers = int(pace_retry_fingers)
        self.pace_retry_tilt = None if pace_retry_tilt is None else float(pace_retry_tilt)
        self.pace_retry_follow = time_window("planner.pace_retry_follow", pace_retry_follow)
        self._lost_since: float | None = None  # (pace_retry) control time the object has lain lost since
        self._retry_spent = 0.0  # (pace_retry) control time the rewinds took so far
        self.retried_at: list[float] = []  # (pace_retry) the control times the rewinds began
        self.carry_gain = float(carry_gain)
        self.carry_lift = float(carry_lift)
        self.carry_limit = float(carry_limit)
        self.carry_turn = float(carry_turn)
        self.carry_turn_limit = float(carry_turn_limit)
        self.carry_hold = float(carry_hold)
        if pace_turn and pace_lag is None:
            raise ConfigError(
                "planner.pace_turn turns the object while a paced reference waits: set planner.pace_lag"
            )
        self.pace_turn = float(pace_turn)
        self.pace_turn_fade = None if pace_turn_fade is None else float(pace_turn_fade)
        self._carry_since: float | None = None  # control time the object has been carried since (carry_hold)
        self._carry = np.zeros(6)  # the wrist's shift so far (carry_gain): translation, hinge angles
        self._carry_data = None  # (carry_turn) scratch data for the wrist's Jacobian
        self._carry_at: float | None = None  # the control time of the last plan (carry_gain)
        self.grip = grip
        self._grip: np.ndarray | None = None  # (N, J) the grip's offsets on the track's grid (bind)
        self._state_data = None  # scratch data of the planning model forwarded at a state (_forwarded)
        # the reference's clock (pace_lag): from control time t0 at reference time s0, at rate until
        # control time t1, then with control time
        self._clock = (0.0, 0.0, 1.0, np.inf)
        self.latency = float(latency)
        self.latency_model = latency_model
        self.latency_per_plan = bool(latency_per_plan)
        self.num_samples = int(num_samples)
        self.robust = robust
        self._models: list | None = None
        self.horizon = float(horizon)
        self.replan_period = float(replan_period)
        self.nthread = nthread
        self.engine: RolloutEngine | None = None
        self.iterations = int(iterations)
        self.anneal = float(anneal)
        self.early_stop = float(early_stop)
        self.compensate_latency = bool(compensate_latency)
        self.acquire_samples = None if acquire_samples is None else int(acquire_samples)
        self.acquire_until = float(acquire_until)
        self.acquire_grasp = int(acquire_grasp)
        self._acquire_from: float | None = None  # (acquire_grasp) reference time of the reference's grasp
        if acquire_waiting and (acquire_samples is None or pace_lag is None):
            raise ConfigError(
                "planner.acquire_waiting keeps the grasp's samples while a paced reference waits: set "
                "planner.acquire_samples and planner.pace_lag"
            )
        self.acquire_waiting = bool(acquire_waiting)
        if acquire_error is not None:
            if acquire_samples is None:
                raise ConfigError(
                    "planner.acquire_error draws the grasp's samples where the object is off the reference: "
                    "set planner.acquire_samples"
                )
            if len(acquire_error) != 2 or min(float(v) for v in acquire_error) <= 0:
                raise ConfigError(
                    f"planner.acquire_error must be (position m, rotation rad), both > 0; got {acquire_error}"
                )
        self.acquire_error = None if acquire_error is None else tuple(float(v) for v in acquire_error)
        self.error_plans = 0  # (acquire_error) the plans that drew acquire_samples for the object's error
        self.acquire_horizon = None if acquire_horizon is None else float(acquire_horizon)
        self._horizon_now = self.horizon  # the horizon of the plan being made (horizon_at)
        self.step_budget = None if step_budget is None else int(step_budget)
        self.approach_reset = None if approach_reset is None else float(approach_reset)
        self._plan_samples: int | None = None  # the samples of the plan being made (samples_at)
        self._noise_scale: np.ndarray | None = None  # (Mw, 1) factor on the noise being drawn, or None
        self.guidance = guidance
        self._iteration = 0  # the plan's iteration being rolled out (the guidance's strength)
        self.switch_timestep = None if switch_timestep is None else float(switch_timestep)
        self.switch_after = None if switch_after is None else float(switch_after)
        self.switch_error = None if switch_error is None else float(switch_error)
        self.switch_count = int(switch_count)
        self.switch_back_after = None if switch_back_after is None else float(switch_back_after)
        self.switch_back_held = bool(switch_back_held)
        self.switch_for = None if switch_for is None else float(switch_for)
        for name, on in (
            ("switch_back_after", switch_back_after is not None),
            ("switch_back_held", switch_back_held),
            ("switch_for", switch_for is not None),
        ):
            if on and switch_timestep is None:
                raise ConfigError(f"planner.{name} needs planner.switch_timestep (the model it leaves)")
        if switch_for is not None and switch_back_after is not None:
            raise ConfigError(
                "planner.switch_for and planner.switch_back_after: choose one (when it goes back)"
            )
        if switch_back_held and not carry_gain:
            raise ConfigError(
                "planner.switch_back_held needs planner.carry_gain (carry=held: the grasp's hold)"
            )
        self._held = False  # (switch_back_held) the grasp has held: the carry's hold reached
        if switch_error is not None and (switch_timestep is None or not compensate_latency):
            raise ConfigError(
                "planner.switch_error needs planner.switch_timestep (the model it switches to) and "
                "planner.compensate_latency (compensation=predict: the predictions it checks)"
            )
        self._misses = 0  # (switch_error) consecutive predictions over it
        # (compensate_latency) the last prediction's path: its start time, step and full states
        self._path: tuple[float, float, np.ndarray] | None = None
        self._switch_at: float | None = None  # reference time of the switch still to come (switch_timestep)
        self._switched: Problem | None = None  # the problem planned from then on
        self.switched_at: float | None = None  # reference time of the first plan on the switched model
        self.switched_back_at: float | None = None  # (switch_back_after) ... of the first plan back
        # (switch_back_after, switch_back_held) when to go back (inf: only on the hold), and the problem
        self._back: tuple[float, Problem] | None = None
        self.reuse = int(reuse)
        self.reuse_after = None if reuse_after is None else float(reuse_after)
        self.reuse_fingers = int(reuse_fingers)
        self.reuse_alone = bool(reuse_alone)
        self.reuse_until = None if reuse_until is None else float(reuse_until)
        self.reuse_grasp = int(reuse_grasp)
        self.reuse_scaled = bool(reuse_scaled)
        self.lazy_distances = bool(lazy_distances)
        if self.lazy_distances and (guidance is not None or robust is not None):
            raise ConfigError(
                "planner.lazy_distances switches the distance sensors of the rollout engine's own planning "
                "model: not with planner.guidance or planner.robust"
            )
        self._reuse_from: float | None = None  # (reuse_grasp) reference time of the reference's grasp
        self._reuse_gate = True  # (reuse_fingers, reuse_alone, reuse_until) whether this plan carries them in
        # (reuse) the last plan's runners-up: its window and their differences from what it committed
        self._kept: tuple[np.ndarray, np.ndarray] | None = None

    # --- the two methods a planner implements ------------------------------------------------
    def sample(self, rng: np.random.Generator, nominal: np.ndarray, window: np.ndarray) -> np.ndarray:
        """Candidate control points around the nominal.

        Args:
            rng: the trial's random generator.
            nominal: (Mw, d) nominal control points of the window.
            window: (Mw,) their indices among the M control points.

        Returns:
            (S, Mw, d) candidates.
        """
        raise NotImplementedError

    def update(self, candidates: np.ndarray, costs: np.ndarray, window: np.ndarray) -> np.ndarray:
        """The new nominal of the window from scored candidates.

        Args:
            candidates: (S, Mw, d) the sampled control points.
            costs: (S,) cumulative costs (``inf`` for diverged rollouts).
            window: (Mw,) indices of the window's control points.

        Returns:
            (Mw, d) the control points to commit.
        """
        raise NotImplementedError

    # --- the loop ------------------------------------------------------------------------------
    def bind(self, problem: Problem) -> None:
        """Attach the problem; the nominal control points start as the reference's own (``theta0``), a
        paced reference's clock at control time."""
        self.theta = np.array(problem.theta0, dtype=float)
        self._clock = (0.0, 0.0, 1.0, np.inf)  # a paced reference's clock starts with control time
        self._paced_release, self._grasp_behind = False, 0.0
        self._lost_since, self._retry_spent, self.retried_at = None, 0.0, []
        self.error_plans = 0
        self._carry, self._carry_at, self._carry_since = np.zeros(6), None, None
        self._held = False
        self._path = None
        self.noise_std = problem.space.noise_std if problem.noise_std is None else problem.noise_std
        self._actuators = as_index(problem.scene.index.actuators)
        self._attach(problem)
        if self.grip is not None:
            self._touched = np.full(len(self._grip_fingers), np.inf)  # (grip touched) when each touched
        # sampler.release.reset: when the reference lets go, the committed control points from then on
        # go to the release nominal, once (None: never)
        self._release_at = problem.last_contact if problem.release_theta is not None else None
        # sampler.release.retract: (start, q, dq, away) once the hand lets go by the retraction (None: not)
        self._retract = None
        # sampler.release.hold: that long before, the committed wrist control points go to the release
        # nominal's (which stands still from then), once (None: never)
        hold = getattr(getattr(problem.space, "release", None), "hold", 0.0)
        self._hold_at = self._release_at - hold if self._release_at is not None and hold > 0.0 else None
        # approach_reset: before the first expected contact, the committed control points from then on go
        # back to the reference's own, once (None: never)
        first = problem.first_contact
        self._approach_at = (
            max(0.0, first - self.approach_reset)
            if self.approach_reset is not None and first is not None
            else None
        )
        # switch_timestep: the problem on the other planning model, planned from its switch on
        self._switch_at, self._switched, self._misses, self.switched_at = None, None, 0, None
        self._back, self.switched_back_at = None, None
        if self.switch_timestep is not None and first is not None:
            self._switch_at = np.inf if self.switch_after is None else first + self.switch_after
            self._switched = problem.stepped(self.switch_timestep)
            if self.switch_back_after is not None and problem.last_contact is not None:
                self._back = (problem.last_contact + self.switch_back_after, problem)
            elif self.switch_back_held:
                self._back = (np.inf, problem)

    def _attach(self, problem: Problem) -> None:
        """Plan ``problem`` from now on: its planning model's step and horizon steps, its track's grip
        tables, and the rollout engine (a new one where there is none), guided or robust models on it."""
        self.problem = problem
        self.dt = problem.scene.planner_model.opt.timestep
        self._at_horizon(self.horizon)
        self._basis_cache: dict[tuple[int, int], np.ndarray] = {}
        self._state_data = self._carry_data = None  # scratch data of the planning model
        if self.grip is not None:
            track, hand = problem.track, problem.scene.hand
            carried = self.grip.carried(problem.scene.task.layout, track.object_qpos)
            fingers, weights, masks = self.grip.tables(hand, track.contact_active, track.dt, carried)
            self._grip_fingers, self._grip_weights, self._grip_masks = fingers, weights, masks
            self._grip = weights @ masks
        if self.guidance is not None and self.needs_rollouts:
            if self.robust is not None:
                raise ConfigError("planner.guidance and planner.robust: choose one")
            guided = self.guidance.bind(problem.scene, problem.track, self.iterations)
            if self.engine is None:
                self.engine = RolloutEngine(guided, self.nthread, CONTROL_SPEC, self.guidance.off())
        if self.acquire_grasp:
            self._acquire_from = first_grasp(problem, self.acquire_grasp)
        if self.reuse_grasp:
            grasp = first_grasp(problem, self.reuse_grasp)
            self._reuse_from = float("inf") if grasp is None else grasp
        if self.needs_rollouts and self.engine is None:
            self.engine = RolloutEngine(problem.scene.planner_model, self.nthread)
        if self.robust is not None:
            self._models = self.robust.build(problem.scene)

    def phase(self, s: float, prediction: tuple[float, float] | None = None) -> bool:
        """Enter the planning phase of reference time ``s``: from the switch on (``switch_timestep``: at
        ``switch_after``, or, with ``switch_error``, once the last ``switch_count`` ``prediction`` s, this
        plan's the last, each missed the object by more than it), plan the problem on the other planning
        model, with a new rollout engine; once (:attr:`switched_at` then says when). With
        ``switch_back_after`` (or ``switch_back_held``, once the grasp has held), from then on the planner's
        own problem again, once (:attr:`switched_back_at`); with ``switch_for``, that long after the switch.

        Returns:
            True where it switched (or went back) now.
        """
        if self._switched is None:
            return self._switch_back(s)
        if self.switch_back_held and self._held:  # the grasp has held before the switch: none to make
            self._switch_at, self._switched, self._back = None, None, None
            return False
        due = s >= self._switch_at - 1e-9
        first = self.problem.first_contact
        if self.switch_error is not None and prediction is not None and s >= first - 1e-9:
            self._misses = self._misses + 1 if prediction[0] > self.switch_error else 0
            due = due or self._misses >= self.switch_count
        if not due:
            return False
        problem, self._switch_at, self._switched = self._switched, None, None
        self.switched_at = float(s)
        if self.switch_for is not None:  # back on the planner's own problem that long after the switch
            self._back = (self.switched_at + self.switch_for, self.problem)
        self.close()
        self._attach(problem)
        return True

    @property
    def switches_back(self) -> bool:
        """Whether a switched planner goes back to the scene's planning model (``switch_back_after``,
        ``switch_for`` or ``switch_back_held``), so that a record says when (``switch_back_time``)."""
        return self.switch_back_after is not None or self.switch_for is not None or self.switch_back_held

    def _switch_back(self, s: float) -> bool:
        """(``switch_back_after``, ``switch_for``, ``switch_back_held``) From its time on (or from the plan at
        which the grasp has held), once the planner has switched, plan its own problem on the scene's planning
        model again, once; True where it went back now."""
        if self._back is None or self.switched_at is None:
            return False
        if s < self._back[0] - 1e-9 and not (self.switch_back_held and self._held):
            return False
        problem, self._back = self._back[1], None
        self.switched_back_at = float(s)
        self.close()
        self._attach(problem)
        return True

    def latency_for(self, plant_timestep: float) -> float:
        """The planning latency (s) a trial applies: ``latency``, or the model's price of one iteration
        (its rollouts, :meth:`rollouts_per_plan`), the larger of the two phases' with ``switch_timestep``.
        Needs :meth:`bind` (the horizon's steps)."""
        if self.latency_model is None:
            return self.latency
        price = self.latency_model.seconds(self.rollouts_per_plan(), self.steps, plant_timestep)
        if self.acquire_horizon is not None:  # the grasp's plans: their samples at their horizon
            short = max(1, int(round(self.acquire_horizon / self.dt)))
            price = max(
                self.latency_model.seconds(self.rollouts_per_plan(acquire=False), self.steps, plant_timestep),
                self.latency_model.seconds(self.rollouts_per_plan(short), short, plant_timestep),
            )
        if self._switched is None:
            return price
        steps = max(1, int(round(self.horizon / self.switch_timestep)))
        early = self.switch_error is not None or self.switch_after < self.acquire_until - 1e-9
        acquiring = self.acquire_samples is not None and early
        switched = self.rollouts_per_plan(steps, acquiring)
        return max(price, self.latency_model.seconds(switched, steps, plant_timestep))

    def latency_at(self, t: float, plant_timestep: float) -> float:
        """The latency (s) of the plan started from the state at control time ``t``: with
        ``latency_per_plan``, the model's price of the samples and horizon that plan draws
        (:meth:`samples_at`, :meth:`horizon_at`) at ``t``; else :meth:`latency_for`, every plan's. With
        ``compensate_latency`` a plan draws the samples of where it takes effect: the one plan whose state
        is in the acquire window but which acts after it is charged the grasp's price (the dearer; the
        window only ends). Needs :meth:`bind`."""
        if not self.latency_per_plan:
            return self.latency_for(plant_timestep)
        return self.latency_model.seconds(*self.rollouts_at(t), plant_timestep)

    def rollouts_at(self, t: float) -> tuple[int, int]:
        """``(rollouts, steps)`` of the plan at reference time ``t``: its iterations x (samples
        (:meth:`samples_at`) + extra rollouts) x the robust ensemble's models, each of the planning steps
        of its horizon (:meth:`horizon_at`); no rollouts for a planner without them."""
        steps = max(1, int(round(self.horizon_at(t) / self.dt)))
        acquiring = self.acquire_samples is not None and self.acquiring(t)
        return self._rollouts(self.acquire_samples if acquiring else self.num_samples, steps), steps

    def rollouts_per_plan(self, steps: int | None = None, acquire: bool = True) -> int:
        """The rollouts one plan runs at most: ``iterations x (samples + extra_rollouts)`` x the robust
        ensemble's models; 0 for a planner without rollouts. ``steps``: the horizon's planning steps the
        ``step_budget`` counts (``None``: the bound model's); ``acquire``: False where the plans cannot be
        in the acquire window (``acquire_samples``)."""
        return self._rollouts(max(self.num_samples, (self.acquire_samples or 0) if acquire else 0), steps)

    def _rollouts(self, samples: int, steps: int | None) -> int:
        """The rollouts of a plan drawing ``samples`` (cut to ``step_budget`` at ``steps``): ``iterations x
        (samples + extra_rollouts)`` x the robust ensemble's models; 0 for a planner without rollouts."""
        if not self.needs_rollouts:
            return 0
        per_iteration = self._budgeted(samples, steps) + self.extra_rollouts
        return self.iterations * per_iteration * (len(self._models) if self._models else 1)

    def close(self) -> None:
        """Release the rollout threads."""
        if self.engine is not None:
            self.engine.close()
            self.engine = None

    def basis(self, t: float) -> np.ndarray:
        """(H, M) spline basis over the horizon starting at grid time ``t`` (cached per grid index), at
        :meth:`basis_times`."""
        key = (self.problem.track.index(t), self.steps)
        if key not in self._basis_cache:
            self._basis_cache[key] = self.problem.spline.basis(self.basis_times(t))
        return self._basis_cache[key]

    def basis_times(self, t: float) -> np.ndarray:
        """(H,) the times of the horizon starting at grid time ``t``: its grid steps."""
        return (self.problem.track.index(t) + np.arange(self.steps)) * self.dt

    def targets(
        self, times: np.ndarray, theta: np.ndarray | None = None, clock: tuple | None = None
    ) -> np.ndarray:
        """The committed policy: (N, J) joint targets at control ``times`` (N,), the spline read at the
        reference's times there (:meth:`reference_time`).

        ``theta`` (M, d): control points to evaluate instead of the committed ones (the wall-clock loop,
        :mod:`contactmpc.online`, evaluates its published copy while the planner works on its own);
        ``clock``: a paced reference's clock to read them at instead of the planner's own (:attr:`clock`:
        the published plan's, while the planner's moves on with the next plan).
        """
        theta = self.theta if theta is None else theta
        s = self.reference_time(times, clock)
        u = self.problem.space.controls(theta, self.problem.spline.basis(s))
        u = u if self._grip is None else self.gripped(u, self.grip_at(s))
        if self._retract is not None:  # the hand lets go by the retraction from its start on
            later, retracted = self.retracted(times)
            u = np.array(u, copy=True)
            u[later] = retracted
        return u

    def retracted(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(later, targets)`` once the retraction began (``sampler.release.retract``): which control
        ``times`` (N,) come after its start (bool (N,)) and the hand's targets at those (K, J)."""
        times = np.asarray(times, float)
        later = times >= self._retract[0] - 1e-9
        return later, self.problem.space.release.retracted(times[later], *self._retract)

    def retract(self, t: float, state: np.ndarray, again: bool = False) -> None:
        """(``sampler.release.retract``) From control time ``t`` on, the hand's targets are the
        retraction (:func:`~contactmpc.control.release.retraction`) from ``state``, read in the planning
        model, instead of the committed policy's. ``again`` (``retract_again``): the contacts in
        ``state`` retracted from the targets at ``t`` (none: the retraction goes on as it was)."""
        scene = self.problem.scene
        d = self._forwarded(state)
        release = self.problem.space.release
        q, dq, away = retraction(scene.planner_model, d, scene.index, release.retract, release.retract_margin)
        if not again:
            self._retract = (float(t), q, dq, away)
        elif np.any(dq):
            now = self.targets(np.array([t]))[0]
            self._retract = (float(t), now, dq, self._retract[3])

    def _forwarded(self, state: np.ndarray) -> mujoco.MjData:
        """The planning model's scratch data at the full-physics ``state``, forwarded (contacts,
        kinematics); overwritten by the next call."""
        m = self.problem.scene.planner_model
        if self._state_data is None:
            self._state_data = mujoco.MjData(m)
        mujoco.mj_setState(m, self._state_data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        mujoco.mj_forward(m, self._state_data)
        return self._state_data

    def grip_at(self, times) -> np.ndarray:
        """(N, J) the grip's offsets at reference ``times`` (N,) (the nearest grid step, clipped to the
        grid); needs a grip (:attr:`grip`) and :meth:`bind`."""
        times = np.asarray(times, float)
        index = np.clip(np.rint(times / self.problem.track.dt), 0, len(self._grip) - 1).astype(int)
        if self.grip.during != "touched":
            return self._grip[index]
        gate = np.clip((times[..., None] - self._touched) / self.grip.ramp, 0.0, 1.0)
        return (self._grip_weights[index] * gate) @ self._grip_masks

    def touch(self, s: float, state: np.ndarray) -> np.ndarray:
        """(grip touched) Mark the fingers found touching the object in ``state`` (the links' contacts
        in the planning model) at reference time ``s``, while the reference expects their contact; a
        finger stays marked. Returns (F,) bool: the fingers marked now."""
        scene = self.problem.scene
        touching = scene.link_contacts(self._forwarded(state))
        expected = self._grip_weights[self.problem.track.index(s)] > 0.0
        new = np.array([touching[links].any() for links, _ in self._grip_fingers]) & expected
        new &= ~np.isfinite(self._touched)
        self._touched[new] = s
        return new

    def gripped(self, u: np.ndarray, offset: np.ndarray) -> np.ndarray:
        """Joint targets ``u`` (..., H, J) with the grip's ``offset`` (H, J) added, clipped to the
        actuators' ranges."""
        ranges = self.problem.space.ranges
        return np.clip(u + offset, ranges[:, 0], ranges[:, 1])

    @property
    def clock(self) -> tuple[float, float, float, float]:
        """A paced reference's clock as the plans so far have set it (``pace_lag``): ``(t0, s0, rate, t1)``,
        the reference at ``s0`` at control time ``t0``, running at ``rate`` until ``t1``, then with control
        time (an immutable tuple: a copy to evaluate targets with later, :meth:`targets`)."""
        return self._clock

    def reference_time(self, t, clock: tuple | None = None):
        """The reference's time at control time ``t`` (a float or an array): ``t`` itself unless the
        reference is paced (``pace_lag``), else its clock's as the plans so far have set it (or as
        ``clock``, a copy of :attr:`clock` taken earlier, has it)."""
        if self.pace_lag is None:
            return t
        t0, s0, rate, t1 = self._clock if clock is None else clock
        t = np.asarray(t, float)
        s = s0 + rate * (np.minimum(t, t1) - t0) + np.maximum(t - t1, 0.0)
        return float(s) if s.ndim == 0 else s

    def waiting(self, t: float) -> bool:
        """Whether a paced reference's clock is held (runs slower than control time) at control time ``t``."""
        if self.pace_lag is None:
            return False
        t0, _, rate, t1 = self._clock
        return 0.0 <= rate < 1.0 and t0 - 1e-9 <= t < t1 - 1e-9

    def rewinding(self, t: float) -> bool:
        """Whether a paced reference's clock runs backwards (``pace_retry``: a grasp tried again) at control
        time ``t``."""
        t0, _, rate, t1 = self._clock
        return rate < 0.0 and t0 - 1e-9 <= t < t1 - 1e-9

    def pace(self, t: float, s: float, state: np.ndarray) -> None:
        """Set the reference's clock from control time ``t`` on (where a plan takes effect), for the plan
        made from ``state`` at reference time ``s``: it waits (runs at ``pace_rate``) while the reference
        expects contact, the free object is more than ``pace_lag`` from where the reference has it at
        ``s`` (or, with ``pace_angle``, turned more than that from it), and the reference is less than
        ``pace_budget`` behind control time (until it is); else it runs with control time. With
        ``pace_window`` it waits only while ``s`` lies in that window around the last expected contact."""
        problem = self.problem
        first, last = problem.first_contact, problem.last_contact
        if self.rewinding(t):  # (pace_retry) a rewind runs its course
            return
        at = self.reference_time(t)
        behind = t - at - self._retry_spent  # (the rewinds' time is their own budget's)
        grasp = False  # (pace_grasp) the grasp's rule, before the window
        if self.pace_window is None:
            wait = self.in_span(s)
        else:
            start, end = self.pace_window
            wait = last is not None and last + start - 1e-9 <= s < last + end - 1e-9
            if self.pace_grasp is not None and (last is None or s < last + start - 1e-9):
                grasp = first is not None and first - 1e-9 <= s
                self._grasp_behind = behind  # (all the grasp's waits, once the window is reached)
        spent = behind if grasp else behind - self._grasp_behind  # this rule's budget spent
        if (wait or grasp) and spent < self.pace_budget - 1e-9:
            scene, track = problem.scene, problem.track
            error = scene.task.layout.error(self.object_qpos(state), track.object_qpos[track.index(s)])
            lag = float(error.position)
            if grasp:
                hold = lag > self.pace_grasp
            else:
                turned = self.pace_angle is not None and float(error.rotation) > self.pace_angle
                hold = lag > self.pace_lag or turned
            if hold:
                until = t + (self.pace_budget - spent) / (1.0 - self.pace_rate)
                self._clock = (t, at, self.pace_rate, until)
                self._paced_release = not grasp
                self._lost_since = None  # (pace_retry: the reference's own wait first, its time not counted)
                return
        if self.pace_retry is not None and self.retry(t, at, s, state, wait):
            return
        if self._clock[2:] != (1.0, np.inf):  # (running on already: the same clock, exactly)
            self._clock = (t, at, 1.0, np.inf)

    def retry(self, t: float, at: float, s: float, state: np.ndarray, span: bool) -> bool:
        """(``pace_retry``) Rewind a paced reference at reference time ``at`` where the plan takes effect
        (control time ``t``; the plan made at reference time ``s`` from ``state``, ``span``: in the
        reference's contact span; :meth:`pace` asks only where this plan does not hold the clock) once the
        free object has lain lost (on the table, left behind by the reference's lift) for ``pace_retry``
        since the reference last waited for it, and the rewind fits the budget left: the clock runs
        backwards to ``pace_retry_to`` before the first expected contact, the committed control points from
        there on go to the reference's own (the wrist moved to the object with ``pace_retry_follow``), the
        carry's shift with them, and the kept runners-up are dropped. Returns whether it rewound."""
        problem = self.problem
        first = problem.first_contact
        free = problem.scene.task.layout.free_columns
        if not span or not len(free):
            self._lost_since = None
            return False
        c, track = free[0], problem.track
        qo, expected, begun = self.object_qpos(state), track.object_qpos[track.index(s)], track.object_qpos[0]
        lag = float(problem.scene.task.layout.error(qo, expected).position)
        lost = (
            qo[c + 2] - begun[c + 2] <= self.carry_lift < expected[c + 2] - begun[c + 2]
            and lag > self.pace_lag
            and self.fingers_touching(state) <= self.pace_retry_fingers
        )
        if lost and self.pace_retry_tilt is not None:  # (fallen on its side or over: not tried again)
            lost = float(tilt_angle(qo[c + 3 : c + 7], begun[c + 3 : c + 7])) <= self.pace_retry_tilt
        if not lost:
            self._lost_since = None
            return False
        if self._lost_since is None:
            self._lost_since = t
        to = max(0.0, first - self.pace_retry_to)
        back = at - to
        cost = back * (1.0 + 1.0 / self.pace_retry_rate)
        if (
            t - self._lost_since < self.pace_retry - 1e-9
            or back <= 0.0
            or self._retry_spent + cost > self.pace_retry_budget + 1e-9
        ):
            return False
        self._clock = (t, at, -self.pace_retry_rate, t + back / self.pace_retry_rate)
        self._retry_spent += cost
        self._lost_since = None
        self.retried_at.append(float(t))
        spline = problem.spline
        reset = spline.window_indices(to, max(0.0, spline.domain[1] - to))
        self.theta[reset] = problem.theta0[reset]
        if self.pace_retry_follow is not None:  # the wrist to where the object lies
            start, end = self.pace_retry_follow
            weight = np.clip((first + end - spline.greville(reset)) / (end - start), 0.0, 1.0)
            offset = qo[c : c + 2] - track.object_qpos[track.index(to), c : c + 2]
            self.theta[reset, :2] += weight[:, None] * offset[None]
        self._kept = None
        self._carry, self._carry_since = np.zeros(6), None  # (carry_gain: its shift went with them)
        return True

    def controls(self, theta: np.ndarray, basis: np.ndarray, times=None) -> np.ndarray:
        """(..., H, nu) actuator controls from control points (..., M, d) through a basis (H, M) at
        reference ``times`` (H,) (the grip's, :attr:`grip`; without a grip they are not needed)."""
        u = self.problem.space.controls(theta, basis)
        if self._grip is not None and self.grip.planned:
            u = self.gripped(u, self.grip_at(times))
        nu = self.problem.scene.planner_model.nu
        if self._actuators == slice(0, nu):
            return u
        ctrl = np.zeros(u.shape[:-1] + (nu,))
        ctrl[..., self._actuators] = u
        return ctrl

    def predict(
        self, t: float, state: np.ndarray, duration: float, reach: float = 0.0
    ) -> tuple[float, np.ndarray]:
        """Where the committed policy takes the planning model from ``state`` at control time ``t`` in
        ``duration`` seconds (rounded to whole planning steps): ``(t', state')``, for a plan that takes
        effect then (:attr:`compensate_latency`). One rollout of ``duration / dt`` steps; where it
        diverges, ``duration`` rounds to no step, or the planner runs no rollouts (replay), ``(t, state)``
        as given.

        It keeps the predicted path, from ``t`` to ``reach`` seconds past ``t'`` (the rollout run on that
        much further), for the next plan's check of where it put the object (:meth:`prediction_error`);
        none where it made no prediction.
        """
        n = int(round(duration / self.dt))
        self._path = None
        if n < 1 or self.engine is None:
            return t, state
        m = n + max(0, int(round(reach / self.dt)))
        clock = t + np.arange(m) * self.dt
        times = self.reference_time(clock)
        ctrl = self.controls(self.theta[None], self.problem.spline.basis(times), times)
        if self._retract is not None:  # the plant follows the retraction, not the committed policy
            later, retracted = self.retracted(clock)
            rows = ctrl[0, later]
            rows[:, self._actuators] = retracted
            ctrl[0, later] = rows
        states, _, diverged = self.engine.run(state, ctrl)
        if diverged[0]:
            return t, state
        self._path = (t, self.dt, np.concatenate([state[None], states[0]]))
        ahead = states[0, n - 1].copy()
        ahead[0] = t + n * self.dt  # the control clock (a rollout's time is the state's plus n steps)
        return t + n * self.dt, ahead

    def evaluate(
        self, state: np.ndarray, t: float, thetas: np.ndarray
    ) -> tuple[np.ndarray, dict, np.ndarray]:
        """Roll out full control-point sets and score them.

        Args:
            state: (nstate,) full-physics initial state.
            t: control time of ``state``.
            thetas: (S, M, d) control points.

        Returns:
            total: (S,) cumulative cost (``inf`` where diverged); terms: name -> (S,) cumulative;
            diverged: (S,) bool.
        """
        ctrl = self.controls(thetas, self.basis(t), self.basis_times(t))
        models, extra = None, None
        window = self.problem.track.window(t, self.steps)
        if self.guidance is not None:  # this iteration's weld, and the guide along the reference
            weight = float(self.guidance.weights(self.iterations)[self._iteration])
            models = [self.guidance.models[self._iteration]] * len(ctrl)
            extra = self.guidance.inputs(window, self.steps, weight)
        if self._models is not None:  # every candidate under each of the K models: (K * S) rollouts
            num_models, num_cand = len(self._models), len(thetas)
            ctrl = np.concatenate([ctrl] * num_models, axis=0)
            models = [m for m in self._models for _ in range(num_cand)]
        unread = self._unread_distances(window) if self.lazy_distances else None
        try:
            _, sensordata, diverged = self.engine.run(state, ctrl, models, extra)
        finally:
            if unread is not None:
                self.engine.model.sensor_type[unread] = mujoco.mjtSensor.mjSENS_GEOMDIST
        n = window.stop - window.start
        terms = {k: v.sum(axis=-1) for k, v in self.problem.cost(sensordata[:, :n], window).items()}
        total = sum(terms.values())
        total = np.where(diverged | ~np.isfinite(total), np.inf, total)
        if self._models is not None:
            total = self.robust.aggregate(total.reshape(num_models, num_cand))
            terms = {name: v.reshape(num_models, num_cand).mean(axis=0) for name, v in terms.items()}
            diverged = diverged.reshape(num_models, num_cand).any(axis=0)
        return total, terms, diverged

    def _unread_distances(self, window: slice) -> np.ndarray | None:
        """(``lazy_distances``) Switch the engine model's link-object distance sensors that the cost reads
        nowhere in ``window`` to MuJoCo's clock (one number, computed at the same stage, in the same
        place); returns their ids, which :meth:`evaluate` switches back after the rollout (``None``: the
        scene has none)."""
        m, idx = self.engine.model, self.problem.scene.index
        if idx.link_object_dist.shape[1] == 0:
            return None
        unread = ~self.problem.cost.distances_read(window)  # (L,) links
        ids = np.searchsorted(m.sensor_adr, idx.link_object_dist[unread].ravel())
        m.sensor_type[ids] = mujoco.mjtSensor.mjSENS_CLOCK
        return ids

    def candidates(
        self, rng: np.random.Generator, t: float, iteration: int = 0
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The candidate batch of a planning iteration at control time ``t`` (``iteration``: which of the
        plan's, for :meth:`noise_scale`).

        Returns:
            window: (Mw,) indices of the control points whose support meets ``[t, t + horizon]``;
            candidates: (S, Mw, d) their sampled values (:meth:`sample`);
            thetas: (S, M, d) full control-point sets: the nominal with the window replaced.
        """
        window = self.problem.spline.window_indices(t, self._horizon_now)
        self._noise_scale = self.noise_scale(t, window, iteration)
        candidates = self.sample(rng, self.theta[window], window)
        if iteration == 0 and self._kept is not None and self._reuse_gate and self.reusing(t):
            self.reused(candidates, window)
        thetas = np.broadcast_to(self.theta, (len(candidates),) + self.theta.shape).copy()
        thetas[:, window] = candidates
        return window, candidates, thetas

    def plan(
        self,
        t: float,
        state: np.ndarray,
        rng: np.random.Generator,
        ahead: float = 0.0,
        reach: float = 0.0,
    ) -> PlanInfo:
        """One planning iteration at control time ``t`` from the plant's state; commits the result.

        Args:
            t: control time (s).
            state: (nstate,) full-physics state of the plant.
            rng: the trial's random generator.
            ahead: seconds after ``t`` at which the plan takes effect (its latency). With
                :attr:`compensate_latency` the plan starts from the state :meth:`predict` gives for
                then, its prediction counted in its compute time; else, or at 0, from ``state`` at ``t``.
            reach: (:attr:`compensate_latency`) seconds past ``t + ahead`` the prediction's path runs on,
                so that the next plan finds where the object was predicted to be even when it starts
                later than this plan takes effect (``job=online``, whose plans take as long as they
                take); 0: up to ``t + ahead`` (the simulated loop's next plan starts there).
        """
        start = time.perf_counter()
        takes_effect = t + ahead
        prediction = self.prediction_error(t, state) if self.compensate_latency else None
        if ahead and self.compensate_latency:  # plan from where the plant will be when the plan acts
            t, state = self.predict(t, state, ahead, reach)
        s = self.reference_time(t)  # where the plan is on the reference: t unless it is paced
        if self.pace_lag is not None:
            self.pace(takes_effect, s, state)
        if self._approach_at is not None and s >= self._approach_at - 1e-9:
            self.reset_approach()
        if self._hold_at is not None and s >= self._hold_at - 1e-9:
            self.release(self._hold_at, wrist_only=True)
        if self._release_at is not None and s >= self._release_at - 1e-9:
            self.release()
            if self.problem.space.release.retract > 0.0:
                self.retract(takes_effect if ahead and self.compensate_latency else t, state)
        elif self._retract is not None and self.problem.space.release.retract_again:
            self.retract(takes_effect if ahead and self.compensate_latency else t, state, again=True)
        if self.carry_gain or self.pace_turn:
            self.carry(t, s, state)
        if self.grip is not None and self.grip.during == "touched":
            self.touch(s, state)
        self.phase(s, prediction)
        grasp = self.acquire_waiting and self.waiting(takes_effect)  # (the reference waits for the grasp)
        off = self.acquire_error is not None and not grasp and not self.acquiring(s)
        if off and self.off_reference(s, state):  # (acquire_error) the object slipped or turned
            grasp = True
            self.error_plans += 1
        self._at_horizon(self.horizon_at(s, grasp))
        self._plan_samples = self.samples_at(s, grasp)
        if self.reuse and (self.reuse_fingers or not self.reuse_alone):
            fingers = self.fingers_touching(state)
            self._reuse_gate = fingers >= self.reuse_fingers and (self.reuse_alone or fingers != 1)
            first = getattr(self.problem, "first_contact", None)
            if self.reuse_until is not None and first is not None:
                self._reuse_gate |= s < first + self.reuse_until - 1e-9
        try:
            info = self._plan(s, state, rng, start)
        finally:
            self._plan_samples = None
        if self.pace_lag is not None:
            info.time, info.reference_time = t, s
        info.prediction = prediction
        return info

    def object_qpos(self, state: np.ndarray) -> np.ndarray:
        """(n_o,) the object configuration of a full-physics ``state`` (``mjSTATE_FULLPHYSICS``: the time,
        then qpos)."""
        return state[1 + self.problem.scene.index.object_qpos]

    def prediction_error(self, t: float, state: np.ndarray) -> tuple[float, float]:
        """``(position m, orientation rad)``: the free object's errors between ``state``, measured at
        control time ``t``, and where the last prediction (:meth:`predict`, :attr:`compensate_latency`) put
        it at ``t`` (between two of its planning steps: the configuration interpolated between them); NaN
        where its path does not reach ``t``, or none was made."""
        if self._path is None:
            return float("nan"), float("nan")
        t0, dt, path = self._path
        u = (t - t0) / dt
        k = int(round(u))
        layout = self.problem.scene.task.layout
        if abs(u - k) * dt <= 1e-9:  # on one of its steps
            if not 0 <= k < len(path):
                return float("nan"), float("nan")
            expected = self.object_qpos(path[k])
        else:
            k = int(np.floor(u))
            if not 0 <= k < len(path) - 1:
                return float("nan"), float("nan")
            expected = layout.interpolate(self.object_qpos(path[k]), self.object_qpos(path[k + 1]), u - k)
        error = layout.error(self.object_qpos(state), expected)
        return float(error.position), float(error.rotation)

    def in_span(self, s: float) -> bool:
        """Whether reference time ``s`` lies in the reference's contact span: from its first expected
        contact up to (not at) its last; never without a first."""
        first, last = self.problem.first_contact, self.problem.last_contact
        return first is not None and first - 1e-9 <= s and (last is None or s < last - 1e-9)

    def off_reference(self, s: float, state: np.ndarray) -> bool:
        """(``acquire_error``) Whether, at reference time ``s`` between the reference's first and last
        expected contact, the free object of ``state`` is more than ``acquire_error``'s position or
        rotation from where the reference has it; False for an object without a free body."""
        if not self.in_span(s):
            return False
        layout, track = self.problem.scene.task.layout, self.problem.track
        if not len(layout.free_columns):
            return False
        error = layout.error(self.object_qpos(state), track.object_qpos[track.index(s)])
        position, rotation = self.acquire_error
        return float(error.position) > position or float(error.rotation) > rotation

    def samples_at(self, t: float, waiting: bool = False) -> int:
        """The samples a plan at control time ``t`` draws: ``acquire_samples`` until ``acquire_until``
        after the first expected contact (or, ``waiting``, where it takes effect while a paced reference
        waits: ``acquire_waiting``), else ``num_samples``; either cut to ``step_budget``."""
        acquiring = self.acquire_samples is not None and (waiting or self.acquiring(t))
        return self._budgeted(self.acquire_samples if acquiring else self.num_samples)

    def acquiring(self, t: float) -> bool:
        """Whether reference time ``t`` is in the acquire window: before ``acquire_until`` after the first
        expected contact (never without one), or with ``acquire_grasp`` after the reference's grasp of that
        many fingers where it has one."""
        first = getattr(self.problem, "first_contact", None)
        if first is None:
            return False
        anchor = self._acquire_from if self.acquire_grasp and self._acquire_from is not None else first
        return t < anchor + self.acquire_until - 1e-9

    def fingers_touching(self, state: np.ndarray) -> int:
        """How many fingers touch the object in the full-physics ``state`` (the planning model's contacts):
        the distinct ``<finger>`` of the touching contact links named ``<finger>_*`` (a link without one,
        the palm, is no finger)."""
        scene = self.problem.scene
        touching = scene.link_contacts(self._forwarded(state))
        return len(fingers_of(scene.hand.link_names, np.flatnonzero(touching)))

    def reusing(self, t: float) -> bool:
        """Whether a plan at reference time ``t`` takes in the last plan's runners-up (``reuse``): from
        ``reuse_after`` after the first expected contact (always where it is ``None``, or without an
        expected contact), and, with ``reuse_grasp``, from the reference's grasp of that many fingers on."""
        if self.reuse_grasp and self._reuse_from is not None and t < self._reuse_from - 1e-9:
            return False
        first = getattr(self.problem, "first_contact", None)
        if self.reuse_after is None or first is None:
            return True
        return t >= first + self.reuse_after - 1e-9

    def horizon_at(self, t: float, waiting: bool = False) -> float:
        """The horizon (s) of a plan at reference time ``t``: ``acquire_horizon`` where
        :meth:`samples_at` draws ``acquire_samples`` (until ``acquire_until`` after the first expected
        contact, or ``waiting``), else ``horizon``."""
        acquiring = self.acquire_horizon is not None and (waiting or self.acquiring(t))
        return self.acquire_horizon if acquiring else self.horizon

    def _at_horizon(self, horizon: float) -> None:
        """Plan the next plan over ``horizon`` seconds: its planning steps (:attr:`steps`) on the bound
        model's step."""
        self._horizon_now = horizon
        self.steps = max(1, int(round(horizon / self.dt)))

    def _budgeted(self, samples: int, steps: int | None = None) -> int:
        """``samples`` cut to what ``step_budget`` allows at ``steps`` planning steps a rollout (``None``:
        the bound horizon's)."""
        if self.step_budget is None:
            return samples
        return max(1, min(samples, self.step_budget // (steps or self.steps)))

    def _plan(self, t: float, state: np.ndarray, rng: np.random.Generator, start: float) -> PlanInfo:
        if not self.needs_rollouts:
            window = self.problem.spline.window_indices(t, self._horizon_now)
            terms = {k: float("nan") for k in self.problem.cost.terms}
            return PlanInfo(time=t, window=window, terms=terms, seconds=time.perf_counter() - start)
        num_diverged, nominal_cost = 0, float("nan")
        for i in range(self.iterations):
            self._iteration = i
            window, candidates, thetas = self.candidates(rng, t, i)
            total, terms, diverged = self.evaluate(state, t, thetas)
            if i == (self.iterations - 1 if self.guidance is not None else 0):
                nominal_cost = float(total[0])  # (with guidance: the first the unguided model scores)
            self.theta[window], best_cost, best_terms = self.commit(
                Scored(state, t, window, candidates, total, terms)
            )
            num_diverged += int(diverged.sum())
            guided = self.guidance is not None and i < self.iterations - 1
            if self.early_stop and not guided and improvement(float(total[0]), best_cost) < self.early_stop:
                break
        self._iteration = 0
        if self.reuse:
            self.keep(window, candidates, total)
        return PlanInfo(
            time=t,
            window=window,
            nominal_cost=nominal_cost,
            best_cost=best_cost,
            terms=best_terms,
            num_diverged=num_diverged,
            seconds=time.perf_counter() - start,
            iterations=i + 1,
            samples=len(candidates),
        )

    def keep(self, window: np.ndarray, candidates: np.ndarray, total: np.ndarray) -> None:
        """Keep the ``reuse`` cheapest finite of a plan's last ``candidates`` (S, Mw, d) scored ``total``
        (S,) other than the committed control points, as their differences from them (:meth:`reused`)."""
        committed = self.theta[window]
        order = [i for i in np.argsort(total, kind="stable") if np.isfinite(total[i])]
        order = [i for i in order if not np.array_equal(candidates[i], committed)]
        order = order[: self.reuse_count(len(total))]
        self._kept = (window.copy(), candidates[order] - committed[None]) if order else None

    def reuse_count(self, samples: int) -> int:
        """How many runners-up a plan of ``samples`` samples keeps and takes in: ``reuse``, or with
        ``reuse_scaled`` ``reuse`` per ``num_samples`` of them (at least 1)."""
        if not self.reuse_scaled:
            return self.reuse
        return max(1, round(self.reuse * samples / self.num_samples))

    def reused(self, candidates: np.ndarray, window: np.ndarray) -> None:
        """Put the last plan's kept runners-up (:meth:`keep`) in the last rows of a plan's fresh
        ``candidates`` (S, Mw, d) over ``window``, in place: each the nominal plus its kept difference on the
        control points both windows cover. Row 0, the nominal, stays."""
        kept_window, differences = self._kept
        count = min(len(differences), self.reuse_count(len(candidates)), len(candidates) - 1)
        if count <= 0:
            return
        _, here, there = np.intersect1d(window, kept_window, assume_unique=True, return_indices=True)
        rows = np.broadcast_to(self.theta[window], (count,) + candidates.shape[1:]).copy()
        rows[:, here] += differences[:count][:, there]
        candidates[len(candidates) - count :] = rows

    def commit(self, scored: Scored) -> tuple[np.ndarray, float, dict[str, float]]:
        """What an iteration commits from its scored candidates (:class:`Scored`; its ``state`` and
        ``t`` are for a planner that rolls out its update,
        :class:`~contactmpc.control.planners.PredictiveSampling`).

        Returns:
            ``(theta_window (Mw, d), cost, terms)``: :meth:`update`'s control points, and the cumulative
            cost and cost terms of the cheapest sample.
        """
        best = int(np.argmin(scored.total))
        return (
            self.update(scored.candidates, scored.total, scored.window),
            float(scored.total[best]),
            {k: float(v[best]) for k, v in scored.terms.items()},
        )

    def noise_scale(self, t: float, window: np.ndarray, iteration: int = 0) -> np.ndarray | None:
        """(Mw, 1) the factor on the sampling noise of the window's control points in a plan's
        ``iteration`` at control time ``t``: ``anneal ** (iteration / iterations)`` times the sampler's
        ramp along the horizon (:meth:`~contactmpc.control.samplers.SplineSpace.horizon_noise`);
        ``None`` where it is 1 everywhere."""
        space = self.problem.space
        ramp = None
        if getattr(space, "noise_ramp", 1.0) != 1.0:  # (a duck-typed space may have no ramp)
            ramp = space.horizon_noise(self.problem.spline, window, t, self._horizon_now)
        if not iteration or self.anneal == 1.0:
            return ramp
        factor = self.anneal ** (iteration / self.iterations)
        return np.full((len(window), 1), factor) if ramp is None else factor * ramp

    def release(self, at: float | None = None, wrist_only: bool = False) -> np.ndarray:
        """Put the committed control points whose support meets the rest of the trial after the
        reference's last expected contact to the release nominal (``problem.release_theta``:
        ``sampler.release.reset``), the wrist keeping the carry's shift; with the schedule's ``blend``,
        partway there by each point's Greville abscissa; done once.

        Args:
            at: from when (s, reference time); ``None``: the last expected contact.
            wrist_only: only the wrist's columns, once, at ``at`` (the schedule's ``hold`` before the
                last contact; the whole reset still comes at the last contact).

        Returns:
            the indices of the control points reset.
        """
        spline = self.problem.spline
        at = self.problem.last_contact if at is None else at
        reset = spline.window_indices(at, max(0.0, spline.domain[1] - at))
        cols = slice(0, self.problem.scene.hand.num_root if wrist_only else None)
        target = self.problem.release_theta[reset, cols].copy()
        if self.carry_gain or self.pace_turn:  # the wrist keeps the shift that carried (or turned) the object
            if self.pace_turn_fade is None:
                target[:, :6] += self._carry
            else:  # (its turn wound back after the release)
                fade = np.clip(1.0 - (spline.greville(reset) - at) / self.pace_turn_fade, 0.0, 1.0)
                target[:, :3] += self._carry[:3]
                target[:, 3:6] += fade[:, None] * self._carry[3:6]
        blend = self.problem.space.release.blend
        if blend > 0.0:  # from the committed points toward the nominal, by each point's Greville abscissa
            weight = np.clip((spline.greville(reset) - at) / blend, 0.0, 1.0)[:, None]
            target = self.theta[reset, cols] + weight * (target - self.theta[reset, cols])
        self.theta[reset, cols] = target
        if wrist_only:
            self._hold_at = None
        else:
            self._release_at = None
        return reset

    def carry(self, t: float, s: float, state: np.ndarray) -> np.ndarray:
        """Shift the wrist's committed translation by the object's slip (``carry_gain``; with
        ``carry_turn`` also its hinges by the object's turn), for the plan made at control time ``t``
        (reference time ``s``) from ``state``; with ``pace_turn``, turn its hinges by a set-down object's
        turn while a paced reference waits (:meth:`waiting`).

        Returns:
            (6,) the shift this plan made (translation, hinge angles; zeros where the object is not
            carried).
        """
        problem = self.problem
        scene, track = problem.scene, problem.track
        free = scene.task.layout.free_columns
        step = np.zeros(6)
        dt = self.replan_period if self._carry_at is None else min(t - self._carry_at, 0.5)
        self._carry_at = t
        if not len(free) or dt <= 0:
            return step
        c = free[0]
        qo = self.object_qpos(state)
        expected = track.object_qpos[track.index(s)]
        start = track.object_qpos[0, c + 2]
        if min(qo[c + 2], expected[c + 2]) - start <= self.carry_lift:
            self._carry_since = None
            if not (self.pace_turn and self.waiting(t) and self._paced_release):
                return step
            # (pace_turn) set down while the reference waits: turned toward where the reference sets it down
            step = self._turn(state, qo[c : c + 7], expected[c + 3 : c + 7], self.pace_turn * dt)
        else:
            if self._carry_since is None:
                self._carry_since = t
            if not self.carry_gain or t - self._carry_since < self.carry_hold - 1e-9:
                return step
            self._held = True
            step[:3] = self.carry_gain * dt * (expected[c : c + 3] - qo[c : c + 3])
            if self.carry_turn:
                step += self._turn(state, qo[c : c + 7], expected[c + 3 : c + 7], self.carry_turn * dt)
        total = self._carry + step
        for part, limit in ((slice(0, 3), self.carry_limit), (slice(3, 6), self.carry_turn_limit)):
            norm = float(np.linalg.norm(total[part]))
            if norm > limit:
                total[part] *= limit / norm
        step = total - self._carry
        self._carry = total
        first = problem.spline.window_indices(s, self.horizon)[0]
        self.theta[first:, :6] += step
        return step

    def _turn(self, state: np.ndarray, pose: np.ndarray, quat: np.ndarray, gain: float) -> np.ndarray:
        """(6,) the wrist's shift that turns the object at ``pose`` (position, quaternion w x y z) by
        ``gain`` x the rotation to ``quat``: hinge angles through the root body's rotational Jacobian at
        ``state``, and the translation that keeps the object where it is under that turn."""
        scene = self.problem.scene
        m = scene.planner_model
        if self._carry_data is None:
            self._carry_data = mujoco.MjData(m)
        d = self._carry_data
        d.qpos[:] = state[1 : 1 + m.nq]  # mjSTATE_FULLPHYSICS: the time, then qpos
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        jacr = np.zeros((3, m.nv))
        root = scene.index.root_body
        mujoco.mj_jacBody(m, d, None, jacr, root)
        hinges = scene.index.hand_dof[3:6]
        error, world = np.zeros(3), np.zeros(9)
        q = np.asarray(pose[3:7], float)
        q = q / np.linalg.norm(q)
        mujoco.mju_subQuat(error, np.asarray(quat, float), q)  # in the object's frame
        mujoco.mju_quat2Mat(world, q)
        omega = gain * world.reshape(3, 3) @ error  # the rotation to apply, world frame
        out = np.zeros(6)
        out[3:] = np.linalg.lstsq(jacr[:, hinges], omega, rcond=None)[0]
        out[:3] = -np.cross(jacr[:, hinges] @ out[3:], pose[:3] - d.xpos[root])
        return out

    def reset_approach(self) -> np.ndarray:
        """Put the committed control points whose support meets the rest of the trial after
        ``approach_reset`` seconds before the first expected contact to the reference's own
        (``problem.theta0``); done once.

        Returns:
            the indices of the control points reset.
        """
        spline, at = self.problem.spline, self._approach_at
        reset = spline.window_indices(at, max(0.0, spline.domain[1] - at))
        self.theta[reset] = self.problem.theta0[reset]
        self._approach_at = None
        return reset

    def window_std(self, window: np.ndarray) -> np.ndarray:
        """The sampling noise of the window's control points: (d,), or (Mw, d) where it varies per
        control point (``sampler.root_window``)."""
        return self.noise_std if self.noise_std.ndim == 1 else self.noise_std[window]

    def gaussian(self, rng: np.random.Generator, nominal: np.ndarray, std: np.ndarray) -> np.ndarray:
        """(S, Mw, d) samples: row 0 the nominal, the rest ``nominal + std * N(0, 1)``, the noise times
        :meth:`noise_scale`'s factor where there is one."""
        count = self._plan_samples or self.num_samples
        noise = rng.standard_normal((count - 1,) + nominal.shape) * std
        if self._noise_scale is not None:
            noise *= self._noise_scale
        return np.concatenate([nominal[None], nominal[None] + noise], axis=0)


def fingers_of(names, links) -> set[str]:
    """The fingers of the hand links ``links`` (indices into ``names``): the distinct ``<finger>`` of those
    named ``<finger>_*`` (a link without one, the palm, is no finger)."""
    return {names[i].split("_", 1)[0] for i in links if "_" in names[i]}


def expected_fingers(contact_active: np.ndarray, names) -> np.ndarray:
    """(N,) how many fingers (:func:`fingers_of`) the reference expects on the object at each step of its
    expected contacts ``contact_active`` (N, L), over the hand links ``names``."""
    return np.array([len(fingers_of(names, np.flatnonzero(row))) for row in np.asarray(contact_active, bool)])


def first_grasp(problem, fingers: int) -> float | None:
    """The reference time of ``problem``'s reference's first instant with at least ``fingers`` fingers
    (:func:`expected_fingers`) on the object; ``None`` where it never expects that many."""
    counts = expected_fingers(problem.track.contact_active, problem.scene.hand.link_names)
    grasped = np.flatnonzero(counts >= fingers)
    return float(grasped[0] * problem.track.dt) if grasped.size else None


def improvement(before: float, after: float) -> float:
    """The fraction by which the cost went down from ``before`` to ``after``: ``(before - after) /
    |before|``; ``inf`` from a diverged (infinite) cost to a finite one, 0 where neither is finite or
    ``before`` is 0."""
    if not np.isfinite(before):
        return float("inf") if np.isfinite(after) else 0.0
    return (before - after) / abs(before) if before else 0.0
