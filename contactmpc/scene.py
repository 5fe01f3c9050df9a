"""Scene composition: one ``MjSpec`` (hand + task) compiled into the plant and the planning model.

The plant runs at a fine physics step (paper: 1 ms); the planning model used for rollouts is the same
model compiled at the agent timestep (paper: 10 ms). Everything else is identical. All MuJoCo names
the rest of the library needs are resolved to ids and array addresses once, here.
"""

from __future__ import annotations

import copy
import functools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Annotated, Any

import mujoco
import numpy as np

from contactmpc.hands.base import Hand
from contactmpc.tasks.base import Task
from contactmpc.validate import Ge, Gt, checked


class SceneError(RuntimeError):
    """A scene that cannot be built or compiled; the message is one line naming the task."""


@dataclass(frozen=True)
class SceneIndex:
    """Ids and addresses resolved once from names (identical in the plant and planning models).

    ``J`` is the hand's number of joints, ``L`` its number of contact links, ``B`` the task's number
    of object bodies, ``n_o`` the width of ``q_o`` and ``A`` its number of articulations.

    Attributes:
        hand_qpos: (J,) qpos addresses of the hand joints, in the hand's joint order.
        hand_dof: (J,) qvel addresses of the hand joints.
        actuators: (J,) actuator ids, in the hand's joint order.
        root_body: body id of the hand's root (the wrist's moving body).
        object_qpos: (n_o,) qpos addresses of ``q_o``.
        object_dof: (nv_o,) qvel addresses of the object joints.
        link_bodies: (L,) body ids of the hand's contact links.
        link_geoms: (L,) id of each link's collision geom.
        link_pos: (L, 3) sensordata addresses of each link's world position.
        link_quat: (L, 4) sensordata addresses of each link's world orientation (w x y z).
        object_bodies: (B,) body ids of the task's object bodies.
        object_pos: (B, 3) sensordata addresses of each object body's world position.
        object_quat: (B, 4) sensordata addresses of each object body's world orientation.
        object_joint_pos: (A,) sensordata addresses of the object's articulation angles (hinge/slide
            joints of ``q_o``, in ``q_o`` order).
        hand_vel: (J,) sensordata addresses of the hand joint velocities.
        object_qo: (n_o,) sensordata addresses that read ``q_o`` directly: a free joint's body
            position and quaternion, then articulation angles, in ``q_o`` order.
        hand_object_contact: (K,) sensordata addresses of the number of hand-object contacts, one
            per outermost object body.
        object_body_mask: (nbody,) True for the object bodies and their descendants.
        object_geom_mask: (ngeom,) True for geoms that belong to the object (object bodies and
            their descendants).
        link_of_geom: (ngeom,) index into the links of the hand link owning each geom, -1 if none.
        link_object_dist: (L, G) sensordata address of the distance between each link's collision geom
            and each of the object bodies' ``G`` colliding geoms (``geomdist`` sensors, up to the scene's
            ``link_distance_cutoff``); (L, 0) when the scene has none.
        dist_object_body: (G,) index into ``object_bodies`` of each of those geoms' body.
    """

    hand_qpos: np.ndarray
    hand_dof: np.ndarray
    actuators: np.ndarray
    root_body: int
    object_qpos: np.ndarray
    object_dof: np.ndarray
    link_bodies: np.ndarray
    link_geoms: np.ndarray
    link_pos: np.ndarray
    link_quat: np.ndarray
    object_bodies: np.ndarray
    object_pos: np.ndarray
    object_quat: np.ndarray
    object_joint_pos: np.ndarray
    hand_vel: np.ndarray
    object_qo: np.ndarray
    hand_object_contact: np.ndarray
    object_body_mask: np.ndarray
    object_geom_mask: np.ndarray
    link_of_geom: np.ndarray
    link_object_dist: np.ndarray
    dist_object_body: np.ndarray

    @classmethod
    def resolve(cls, m: mujoco.MjModel, hand: Hand, task: Task) -> SceneIndex:
        """Resolve every name of ``hand`` and ``task`` in the compiled model ``m``.

        Raises:
            SceneError: naming what is missing.
        """
        body, joint, geom = mujoco.mjtObj.mjOBJ_BODY, mujoco.mjtObj.mjOBJ_JOINT, mujoco.mjtObj.mjOBJ_GEOM
        jid = ids(m, joint, hand.joint_names, "hand joint")
        links = ids(m, body, hand.link_names, "hand link")
        obj = ids(m, body, task.object_bodies, "object body")
        # Object bodies and their descendants (e.g. the door's bolt) count as "the object".
        is_object = np.zeros(m.nbody, bool)
        is_object[obj] = True
        for b in range(1, m.nbody):  # parents precede children in MuJoCo's body order
            is_object[b] |= is_object[m.body_parentid[b]]
        link_index = -np.ones(m.nbody, int)
        link_index[links] = np.arange(len(links))
        try:
            object_qpos = task.layout.qpos_indices(m)
            object_dof = task.layout.dof_indices(m)
            qo_sensors = task.layout.sensors(m)
        except ValueError as err:
            raise SceneError(f"task {task.name!r}: {err}") from err
        return cls(
            hand_qpos=m.jnt_qposadr[jid].copy(),
            hand_dof=m.jnt_dofadr[jid].copy(),
            actuators=ids(m, mujoco.mjtObj.mjOBJ_ACTUATOR, hand.actuator_names, "actuator"),
            root_body=int(ids(m, body, [hand.root_body], "hand root body")[0]),
            object_qpos=object_qpos,
            object_dof=object_dof,
            link_bodies=links,
            link_geoms=ids(m, geom, hand.link_geoms, "hand link geom"),
            link_pos=np.stack([_sensor_adr(m, f"{n}_pos", 3) for n in hand.link_names]),
            link_quat=np.stack([_sensor_adr(m, f"{n}_quat", 4) for n in hand.link_names]),
            object_bodies=obj,
            object_pos=np.stack([_sensor_adr(m, f"{n}_pos", 3) for n in task.object_bodies]),
            object_quat=np.stack([_sensor_adr(m, f"{n}_quat", 4) for n in task.object_bodies]),
            object_joint_pos=np.asarray(
                [_sensor_adr(m, f"{j}_pos", 1)[0] for j in task.layout.articulation_joints], dtype=int
            ),
            hand_vel=np.concatenate([_sensor_adr(m, f"{n}_vel", 1) for n in hand.joint_names]),
            object_qo=np.concatenate([_sensor_adr(m, name, w) for name, w in qo_sensors]).astype(int),
            hand_object_contact=np.asarray(
                [
                    m.sensor_adr[k]
                    for k in range(m.nsensor)
                    if m.sensor_type[k] == mujoco.mjtSensor.mjSENS_CONTACT
                    and mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_SENSOR, k).endswith("_hand_contact")
                ],
                dtype=int,
            ),
            object_body_mask=is_object,
            object_geom_mask=is_object[m.geom_bodyid],
            link_of_geom=link_index[m.geom_bodyid],
            **_link_object_dist(m, hand, obj),
        )


def ids(model: mujoco.MjModel, kind: mujoco.mjtObj, names: Sequence[str], what: str) -> np.ndarray:
    """Resolve MuJoCo names to ids.

    Args:
        model: compiled model.
        kind: object type, e.g. ``mujoco.mjtObj.mjOBJ_BODY``.
        names: (n,) names.
        what: what the names are, for the error message.

    Returns:
        (n,) int array of ids, in the order of ``names``.

    Raises:
        SceneError: naming every missing name.
    """
    out = np.array([mujoco.mj_name2id(model, kind, n) for n in names], dtype=int)
    missing = [n for n, i in zip(names, out, strict=True) if i < 0]
    if missing:
        raise SceneError(f"{what} {', '.join(map(repr, missing))} not found in the compiled scene")
    return out


# Planning-model options that save time without moving the plant-vs-planning-model agreement (the
# Scene's default): convex collisions (ellipsoids, cylinders, boxes, meshes) stop after 10 iterations
# instead of MuJoCo's 35, at the same tolerance. Measured by ``job=benchmark`` (README "Speed"): 8-10 %
# less CPU per rollout step while the hand holds the apple or the bottle, 3-4 % on the doorknobs, nothing
# measurable on the stapler and the other paper tasks; the object gap unchanged (tests/test_agreement.py).
# Not free, so opt-in: ``cone: pyramidal`` (0-54 % less in contact; the apple's gap grows from 0.4 to
# 13 mm) and ``iterations: 20`` (no saving, except 9 % on the held stapler, which then slips out: a
# 246 mm gap).
FREE_PLANNER_OPTIONS: dict[str, Any] = {"ccd_iterations": 10, "ccd_tolerance": 1e-6}

_OPTION_ENUMS = {
    "cone": mujoco.mjtCone,
    "integrator": mujoco.mjtIntegrator,
    "jacobian": mujoco.mjtJacobian,
    "solver": mujoco.mjtSolver,
}


def set_options(opt: mujoco.MjOption, options: dict[str, Any], what: str = "scene.planner_options") -> None:
    """Set ``mjOption`` fields by name (enum fields by their value's name, e.g. ``cone: pyramidal``);
    the timestep is not among them (the scene owns it).

    Args:
        opt: the model's options, changed in place.
        options: field name -> value.
        what: the options' name in error messages.

    Raises:
        SceneError: an unknown field, or a value it does not take.
    """
    for key, value in options.items():
        if key == "timestep" or not hasattr(opt, key) or key.startswith("_"):
            raise SceneError(f"{what}: {key!r} is not an mjOption field it may set")
        if key in _OPTION_ENUMS and isinstance(value, str):
            prefix = {"cone": "mjCONE_", "integrator": "mjINT_", "jacobian": "mjJAC_", "solver": "mjSOL_"}[
                key
            ]
            member = getattr(_OPTION_ENUMS[key], f"{prefix}{value.upper()}", None)
            if member is None:
                raise SceneError(f"{what}: {key}={value!r} is not a {_OPTION_ENUMS[key].__name__}")
            value = member
        try:
            setattr(opt, key, value)
        except (TypeError, ValueError) as err:
            raise SceneError(f"{what}: {key}={value!r}: {err}") from err


def planning_model(
    scene: Scene,
    options: dict[str, Any] | None = None,
    hand_pairs: str = "all",
    distance_cutoff: float | None = None,
) -> mujoco.MjModel:
    """A copy of the scene's exact planning model (the one without ``scene.planning_cuts``) with cuts that
    make a rollout step cheaper (the plant and the scene's planning model unchanged); no cut: an equal copy.

    Args:
        scene: the scene.
        options: ``mjOption`` fields set on top of the scene's (:func:`set_options`), e.g.
            ``{iterations: 20, tolerance: 1e-6}``.
        hand_pairs: which contacts between two links of the hand the planning model keeps: ``all`` (the
            plant's), ``across_fingers`` (none between two links of one finger, i.e. a link and its
            ancestor below the palm, the link every other link hangs from; palm-finger and finger-finger
            pairs kept) or ``none`` (the hand's geoms take a contact bit no geom has, which every geom
            that collided with the hand accepts, so hand-world and hand-object pairs are the old ones).
            Measured on the paper tasks (``studies/plan_cost``): ``across_fingers`` changes no contact
            and saves nothing (1.00x); ``none`` saves 1.27-1.44x per sample-step but moves the planning
            model's object away from the plant's (fingers pressing on each other and on the palm).
        distance_cutoff: the link-object distance sensors (``scene.link_distance_cutoff``) read only this
            far (m), e.g. the clearance term's margin, which changes none of its costs; ``None``: as far as
            the scene reads them. Prices what reading them less far saves (``job=profile``).

    Raises:
        SceneError: an option the model does not take, an unknown ``hand_pairs``, or (``none``) a hand
            whose colliding geoms differ in their contact bits.
    """
    if hand_pairs not in ("all", "across_fingers", "none"):
        raise SceneError(f"planning_model.hand_pairs = {hand_pairs!r}: expected all, across_fingers or none")
    if hand_pairs == "across_fingers":
        m = _without_finger_pairs(scene)
    else:
        m = copy.copy(scene.exact_planner_model)
    if scene.planner_options and hand_pairs == "across_fingers":
        set_options(m.opt, scene.planner_options)
    if options:
        set_options(m.opt, dict(options), what="planning_model.options")
    if distance_cutoff is not None:
        if not distance_cutoff > 0:
            raise SceneError(f"planning_model.distance_cutoff = {distance_cutoff!r}: expected > 0")
        m.sensor_cutoff[m.sensor_type == mujoco.mjtSensor.mjSENS_GEOMDIST] = float(distance_cutoff)
    if hand_pairs == "none":
        hand = (scene.index.link_of_geom >= 0) & ((m.geom_contype | m.geom_conaffinity) > 0)
        bits = {(int(a), int(b)) for a, b in zip(m.geom_contype[hand], m.geom_conaffinity[hand], strict=True)}
        used = int(np.bitwise_or.reduce(m.geom_contype | m.geom_conaffinity))
        free = next((1 << k for k in range(32) if not used & (1 << k)), 0)
        if len(bits) != 1 or not free:
            raise SceneError(
                f"task {scene.task.name!r}: hand_pairs=none needs one pair of contact bits on every hand "
                f"geom and a free bit (found {sorted(bits)})"
            )
        ((contype, _),) = bits
        m.geom_conaffinity[~hand & ((m.geom_conaffinity & contype) > 0)] |= free  # they accept the hand
        m.geom_contype[hand] = free
    return m


def finger_pairs(m: mujoco.MjModel, link_bodies: np.ndarray) -> list[tuple[int, int]]:
    """(ancestor, descendant) body ids of the hand links of one finger: pairs of links, one below the
    other, neither of them the palm (the link that is an ancestor of every other link)."""

    def ancestors(b: int) -> set[int]:
        out = set()
        while b > 0:
            b = int(m.body_parentid[b])
            out.add(b)
        return out

    links = [int(b) for b in link_bodies]
    above = {b: ancestors(b) for b in links}
    palms = {a for a in links if all(a in above[b] for b in links if b != a)}
    return [(a, b) for b in links for a in links if a in above[b] and a not in palms]


def _without_finger_pairs(scene: Scene) -> mujoco.MjModel:
    """The planning model compiled with contact excludes between the links of each finger."""
    spec = scene.spec.copy()
    m = scene.exact_planner_model
    name = functools.partial(mujoco.mj_id2name, m, mujoco.mjtObj.mjOBJ_BODY)
    for a, b in finger_pairs(m, scene.index.link_bodies):
        spec.add_exclude(bodyname1=name(a), bodyname2=name(b))
    spec.option.timestep = scene.planner_timestep
    return spec.compile()


def _link_object_dist(m: mujoco.MjModel, hand: Hand, bodies: np.ndarray) -> dict[str, np.ndarray]:
    """The addresses of the ``<link geom>__<object geom>_dist`` sensors (none: (L, 0), (0,))."""
    geoms = colliding_geoms(m, bodies)
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) for g in geoms]
    if (
        not names
        or mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SENSOR, f"{hand.link_geoms[0]}__{names[0]}_dist") < 0
    ):
        return {
            "link_object_dist": np.zeros((len(hand.link_geoms), 0), int),
            "dist_object_body": np.zeros(0, int),
        }
    adr = [[_sensor_adr(m, f"{lg}__{n}_dist", 1)[0] for n in names] for lg in hand.link_geoms]
    at = {int(b): i for i, b in enumerate(bodies)}
    body = [at[int(m.geom_bodyid[g])] for g in geoms]
    return {"link_object_dist": np.array(adr, int), "dist_object_body": np.asarray(body, int)}


def colliding_geoms(m: mujoco.MjModel, bodies: Sequence[int]) -> np.ndarray:
    """(G,) ids of the geoms of ``bodies`` that can collide (``contype`` or ``conaffinity`` set), in
    ``bodies`` order, then geom order."""
    return np.array(
        [
            g
            for b in bodies
            for g in range(m.ngeom)
            if m.geom_bodyid[g] == b and (m.geom_contype[g] or m.geom_conaffinity[g])
        ],
        int,
    )


def _sensor_adr(model: mujoco.MjModel, name: str, width: int) -> np.ndarray:
    adr = model.sensor_adr[ids(model, mujoco.mjtObj.mjOBJ_SENSOR, [name], "sensor")[0]]
    return np.arange(adr, adr + width)


class Scene:
    """A hand and a task composed into the plant model and the planning model.

    Args:
        hand: the hand (any :class:`~contactmpc.hands.base.Hand`).
        task: the task (fixtures, objects, ``q_o``).
        plant_timestep: physics step of the plant (s); paper 1 ms.
        planner_timestep: physics step of the planning model (s); paper 10 ms.
        integrator: MuJoCo integrator name (``implicitfast`` suits damped position servos).
        cone: friction cone, ``elliptic`` or ``pyramidal``.
        impratio: frictional-to-normal impedance ratio (higher resists slip in grasps).
        hand_root: (3,) offset of the wrist's zero from the task's ``hand_mount`` (world frame; most
            tasks mount the hand at the origin).
        planner_options: fields of ``mjOption`` set on the planning model only (the plant keeps the
            scene's), e.g. ``{cone: pyramidal}`` (enum fields by name: ``cone``, ``integrator``,
            ``jacobian``, ``solver``). Default :data:`FREE_PLANNER_OPTIONS`, the savings that cost no
            agreement; ``{}`` or ``None``: the planning model differs from the plant only in its
            timestep.
        link_distance_cutoff: > 0 adds one ``geomdist`` sensor per (hand link collision geom, colliding
            geom of an object body): the distance between them, read up to this cutoff (m), for the
            cost's surface and clearance terms (``cost.surface_weight``, ``cost.clearance_weight``); 0
            (default) adds none. Sensors do not act on the physics.
        planning_cuts: cuts of the planning model only (keyword arguments of :func:`planning_model`,
            e.g. ``{hand_pairs: none}``); ``None`` or ``{}`` (default): none, the planning model as
            before. Measured in ``studies/plan_cost`` (``job=profile``), none is free: the one that
            saves (``hand_pairs: none``, 1.27-1.44x less per sample-step) moves the object in the
            planning model away from the plant's (tests/test_agreement.py: +0.07 to +8.3 mm at the
            median contact state).

    Raises:
        SceneError: if the scene does not compile or a name does not resolve.
    """

    @checked
    def __init__(
        self,
        hand: Hand,
        task: Task,
        plant_timestep: Annotated[float, Gt(0)] = 0.001,
        planner_timestep: Annotated[float, Gt(0)] = 0.01,
        integrator: str = "implicitfast",
        cone: str = "elliptic",
        impratio: Annotated[float, Gt(0)] = 10.0,
        hand_root: tuple[float, float, float] = (0.0, 0.0, 0.0),
        planner_options: dict[str, Any] | None = FREE_PLANNER_OPTIONS,
        link_distance_cutoff: Annotated[float, Ge(0)] = 0.0,
        planning_cuts: dict[str, Any] | None = None,
    ) -> None:
        if not 0 < plant_timestep <= planner_timestep:
            raise SceneError(
                f"timesteps must satisfy 0 < plant ({plant_timestep}) <= planner ({planner_timestep})"
            )
        if len(task.hand_home) != hand.num_joints:
            raise SceneError(
                f"task {task.name!r}: hand_home has {len(task.hand_home)} entries, but hand {hand.name!r} "
                f"has {hand.num_joints} joints ({', '.join(hand.joint_names)})"
            )
        self.hand = hand
        self.task = task
        self.plant_timestep = plant_timestep
        self.planner_timestep = planner_timestep
        self.spec = mujoco.MjSpec()
        self.spec.modelname = f"{task.name}_{hand.name}"
        self.spec.compiler.degree = False  # every angle in this project is in radians
        opt = self.spec.option
        try:
            opt.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
            opt.cone = getattr(mujoco.mjtCone, f"mjCONE_{cone.upper()}")
        except AttributeError as err:
            raise SceneError(f"unknown integrator {integrator!r} or cone {cone!r}") from err
        opt.impratio = impratio
        self.spec.visual.global_.offwidth = 1280
        self.spec.visual.global_.offheight = 960
        self.spec.visual.quality.shadowsize = 4096
        self._add_look()
        self.spec.worldbody.add_light(
            name="key", pos=[0.4, -0.8, 1.6], dir=[-0.3, 0.5, -1.0], diffuse=[0.8, 0.8, 0.8], castshadow=True
        )
        self.spec.worldbody.add_light(
            name="fill", pos=[-0.6, 0.6, 1.2], dir=[0.4, -0.4, -1.0], diffuse=[0.3] * 3
        )
        try:
            self.hand_root = np.add(task.hand_mount, hand_root)
            hand.add_to(self.spec, root_pos=self.hand_root)
            for joint in hand.joint_names:  # hand velocities for the cost, vectorised over rollouts
                self.spec.add_sensor(
                    name=f"{joint}_vel",
                    type=mujoco.mjtSensor.mjSENS_JOINTVEL,
                    objtype=mujoco.mjtObj.mjOBJ_JOINT,
                    objname=joint,
                )
            task.add_to(self.spec)
            self._add_hand_object_contact()
            self._add_link_distance(link_distance_cutoff)
            self.plant_model = self._compile(plant_timestep)
        except SceneError:
            raise
        except Exception as err:  # MjSpec raises ValueError for compile errors
            msg = " ".join(str(err).split())
            raise SceneError(f"task {task.name!r}: scene failed to compile: {msg}") from err
        self.index = SceneIndex.resolve(self.plant_model, hand, task)
        self.planner_options = dict(planner_options or {})
        self.planning_cuts = dict(planning_cuts or {})
        unknown = set(self.planning_cuts) - {"options", "hand_pairs", "distance_cutoff"}
        if unknown:
            raise SceneError(
                f"scene.planning_cuts: {sorted(unknown)} not among options, hand_pairs, distance_cutoff"
            )
        self._set_planning_model(planner_timestep)

    def _add_hand_object_contact(self) -> None:
        """One contact sensor per outermost object body (the subtree of the hand's root against the
        body's subtree, ``data="found"``): the number of hand-object contacts, for the cost's release
        term. Sensors do not act on the physics."""
        names = set(self.task.object_bodies)
        for name in self.task.object_bodies:
            parent = self.spec.body(name).parent
            while parent is not None and parent.name not in names and parent.name != "world":
                parent = parent.parent
            if parent is not None and parent.name in names:
                continue  # inside another object body's subtree: counted there
            self.spec.add_sensor(
                name=f"{name}_hand_contact",
                type=mujoco.mjtSensor.mjSENS_CONTACT,
                objtype=mujoco.mjtObj.mjOBJ_XBODY,
                objname=self.hand.root_body,
                reftype=mujoco.mjtObj.mjOBJ_XBODY,
                refname=name,
                intprm=[1, 0, 1],  # data: found; reduce: none; num: 1
            )

    def _add_link_distance(self, cutoff: float) -> None:
        """``<link geom>__<object geom>_dist``: the distance between a hand link's collision geom and one
        colliding geom of an object body (``mj_geomDistance``; negative when they overlap), read up to
        ``cutoff`` (m); none at 0. The object's geoms come from a first compile of the spec."""
        if cutoff <= 0.0:
            return
        m = self.spec.compile()
        bodies = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in self.task.object_bodies]
        names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) for g in colliding_geoms(m, bodies)]
        if any(not n for n in names):
            raise SceneError(f"task {self.task.name!r}: the surface distance needs every object geom named")
        for link_geom in self.hand.link_geoms:
            for name in names:
                self.spec.add_sensor(
                    name=f"{link_geom}__{name}_dist",
                    type=mujoco.mjtSensor.mjSENS_GEOMDIST,
                    objtype=mujoco.mjtObj.mjOBJ_GEOM,
                    objname=link_geom,
                    reftype=mujoco.mjtObj.mjOBJ_GEOM,
                    refname=name,
                    cutoff=cutoff,
                )

    def _add_look(self) -> None:
        """Skybox and a checkered floor material (``floor_mat``) that tasks may use."""
        self.spec.add_texture(
            name="sky",
            type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
            builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
            rgb1=[0.75, 0.82, 0.90],
            rgb2=[0.25, 0.28, 0.33],
            width=256,
            height=256,
        )
        self.spec.add_texture(
            name="floor_tex",
            type=mujoco.mjtTexture.mjTEXTURE_2D,
            builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
            rgb1=[0.32, 0.34, 0.37],
            rgb2=[0.26, 0.28, 0.30],
            width=256,
            height=256,
        )
        mat = self.spec.add_material(name="floor_mat", texrepeat=[6, 6], reflectance=0.1)
        mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "floor_tex"

    def stepped(self, timestep: float) -> Scene:
        """This scene with its planning model compiled at another ``timestep`` (s), with the same planner
        options and planning cuts; the plant model, the spec and the index are shared.

        Args:
            timestep: the planning model's step (s), at least the plant's.

        Raises:
            SceneError: a step below the plant's.
        """
        if not self.plant_timestep <= timestep:
            raise SceneError(f"planning step {timestep:g} s is below the plant's ({self.plant_timestep:g} s)")
        other = copy.copy(self)
        other._set_planning_model(timestep)
        return other

    def _set_planning_model(self, timestep: float) -> None:
        """Compile the planning model at ``timestep`` with the planner options
        (:attr:`exact_planner_model`), then its planning cuts (:attr:`planner_model`)."""
        self.planner_timestep = timestep
        self.exact_planner_model = self.planner_model = self._compile(timestep)
        set_options(self.planner_model.opt, self.planner_options)
        if self.planning_cuts:
            self.planner_model = planning_model(self, **self.planning_cuts)

    def _compile(self, timestep: float) -> mujoco.MjModel:
        self.spec.option.timestep = timestep
        return self.spec.compile()

    # --- state ---------------------------------------------------------------------------------
    def reset(
        self,
        data: mujoco.MjData,
        hand_qpos: np.ndarray | None = None,
        object_qpos: np.ndarray | None = None,
    ) -> None:
        """Put ``data`` at rest in a configuration, with the servos holding the hand there.

        Args:
            data: data of the plant or the planning model.
            hand_qpos: (J,) hand configuration; defaults to the task's ``hand_home``.
            object_qpos: (n_o,) object configuration; defaults to the task's initial one.
        """
        m = data.model
        mujoco.mj_resetData(m, data)
        hq = self.task.hand_home if hand_qpos is None else np.asarray(hand_qpos, float)
        oq = self.task.initial_object_qpos(m) if object_qpos is None else np.asarray(object_qpos, float)
        data.qpos[self.index.hand_qpos] = hq
        data.qpos[self.index.object_qpos] = oq
        data.ctrl[self.index.actuators] = hq
        mujoco.mj_forward(m, data)

    def make_data(self, model: mujoco.MjModel | None = None) -> mujoco.MjData:
        """A fresh ``MjData`` of ``model`` (default: the plant), reset to the task's initial state."""
        data = mujoco.MjData(self.plant_model if model is None else model)
        self.reset(data)
        return data

    def hand_qpos(self, data: mujoco.MjData) -> np.ndarray:
        """(J,) the hand configuration of ``data``."""
        return data.qpos[self.index.hand_qpos].copy()

    def object_qpos(self, data: mujoco.MjData) -> np.ndarray:
        """(n_o,) the object configuration ``q_o`` of ``data``."""
        return data.qpos[self.index.object_qpos].copy()

    def link_contacts(self, data: mujoco.MjData) -> np.ndarray:
        """(L,) bool: which hand links touch the object (any object body) in ``data``."""
        touching = np.zeros(len(self.index.link_bodies), bool)
        if data.ncon == 0:
            return touching
        g1, g2 = data.contact.geom1[: data.ncon], data.contact.geom2[: data.ncon]
        dist = data.contact.dist[: data.ncon]
        live = dist <= 0.0
        idx = self.index
        for ga, gb in ((g1, g2), (g2, g1)):
            hit = live & idx.object_geom_mask[gb] & (idx.link_of_geom[ga] >= 0)
            touching[idx.link_of_geom[ga[hit]]] = True
        return touching
