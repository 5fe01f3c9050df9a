"""Contact guidance in the planning model only (not the paper's): a virtual object controller, annealed
over a plan's iterations.

DexMachina (arXiv 2505.24853) helps a learning hand with a virtual controller that pulls the object along
its demonstrated trajectory and decays it as training goes on; SPIDER (arXiv 2511.09484) anneals its
contact guidance from stiff to soft over its optimisation's iterations. Here the pull is a soft weld
between the object's free body and a mocap body that follows the reference's object trajectory over the
planning horizon, in a copy of the planning model only (the plant never feels it), active where the
reference expects contact. Its strength falls over a plan's iterations (``planner.iterations``, at least
2): iteration ``i`` of ``N`` pulls with the weld's time constant ``timeconst / (1 - i / (N - 1))``, so the
first iteration is the stiffest and the last runs without it, on the planning model's own dynamics. The
committed plan is then the one the last, unguided iteration chose: the guided iterations only move the
nominal it samples around toward controls that would do the task with help.
"""

from __future__ import annotations

import copy
from typing import Annotated

import mujoco
import numpy as np

from contactmpc.scene import Scene, SceneError, set_options
from contactmpc.validate import ConfigError, Gt, OneOf, checked

#: The rollout's inputs with guidance: the actuators' controls, then every equality's active flag and the
#: mocap bodies' poses (``mujoco.rollout`` takes them in this order, the order of the ``mjtState`` bits).
CONTROL_SPEC = int(
    mujoco.mjtState.mjSTATE_CTRL
    | mujoco.mjtState.mjSTATE_EQ_ACTIVE
    | mujoco.mjtState.mjSTATE_MOCAP_POS
    | mujoco.mjtState.mjSTATE_MOCAP_QUAT
)
GUIDE = "contactmpc_guide"  # the mocap body the object is welded to
WELD = "contactmpc_guidance"


class ObjectGuidance:
    """A soft weld from the object to the reference's object pose in the planning model, annealed over a
    plan's iterations (see the module's docstring).

    Args:
        timeconst: the weld's time constant (s) in the first, stiffest iteration (MuJoCo's ``solref``: a
            spring-damper that closes the gap in about this time); larger is softer.
        dampratio: the weld's damping ratio (``solref``'s second entry).
        during: ``contact``: the weld acts at the planning steps where the reference expects any contact
            (the object is being moved); ``always``: at every step.
    """

    @checked
    def __init__(
        self,
        timeconst: Annotated[float, Gt(0)] = 0.05,
        dampratio: Annotated[float, Gt(0)] = 1.0,
        during: Annotated[str, OneOf("contact", "always")] = "contact",
    ) -> None:
        self.timeconst = float(timeconst)
        self.dampratio = float(dampratio)
        self.during = during
        self.models: list[mujoco.MjModel] = []

    def weights(self, iterations: int) -> np.ndarray:
        """(N,) the guidance's strength in each of a plan's ``iterations``: 1 falling to 0."""
        return 1.0 - np.arange(iterations) / max(iterations - 1, 1)

    def bind(self, scene: Scene, track, iterations: int) -> mujoco.MjModel:
        """Build the guided planning models, one per guided iteration, for a planner of ``iterations``.

        Args:
            scene: the composed scene (its spec, planning timestep and options).
            track: the reference track (:class:`~contactmpc.control.track.ReferenceTrack`): the object
                configuration and the expected contacts per planning step.
            iterations: the planner's iterations per plan.

        Returns:
            The guided model with the weld at its stiffest: the rollout engine's model (its sizes are the
            planning model's, plus one mocap body and one equality).

        Raises:
            ConfigError: fewer than 2 iterations, planning cuts, or a task whose object has no single free
                body.
        """
        if iterations < 2:
            raise ConfigError(
                f"planner.guidance needs planner.iterations >= 2 (the last iteration plans without it); "
                f"got {iterations}"
            )
        if scene.planning_cuts:
            raise ConfigError("planner.guidance: not with scene.planning_cuts (the guided model is compiled "
                              "from the scene's spec)")  # fmt: skip
        layout = scene.task.layout
        free = [j for j in layout.joints if j.kind == "free"]
        if len(free) != 1:
            raise ConfigError(
                f"planner.guidance: task {scene.task.name!r} has {len(free)} free object bodies; the weld "
                "needs exactly one"
            )
        base = scene.planner_model
        joint = mujoco.mj_name2id(base, mujoco.mjtObj.mjOBJ_JOINT, free[0].name)
        body = mujoco.mj_id2name(base, mujoco.mjtObj.mjOBJ_BODY, int(base.jnt_bodyid[joint]))
        spec = scene.spec.copy()
        spec.worldbody.add_body(name=GUIDE, mocap=True)
        weld = spec.add_equality(
            name=WELD,
            type=mujoco.mjtEq.mjEQ_WELD,
            objtype=mujoco.mjtObj.mjOBJ_BODY,
            name1=GUIDE,
            name2=body,
            active=False,
            solref=[self.timeconst, self.dampratio],
        )
        # the object's frame on the guide's: anchor 0, relative pose identity, torques at full scale (the
        # weld's data: anchor 3, relative position 3, relative quaternion 4, torque scale 1, then padding)
        data = np.zeros(len(weld.data))
        data[6], data[10] = 1.0, 1.0
        weld.data = data
        spec.option.timestep = scene.planner_timestep
        try:
            model = spec.compile()
        except Exception as err:  # MjSpec raises ValueError for compile errors
            raise SceneError(f"planner.guidance: the guided model failed to compile: {err}") from err
        set_options(model.opt, scene.planner_options)
        same = ("nq", "nv", "na", "nu", "nsensordata")
        if any(getattr(model, k) != getattr(base, k) for k in same):
            raise SceneError("planner.guidance: the guided model's sizes differ from the planning model's")
        self.weld = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_EQUALITY, WELD)
        self.guide = int(model.body_mocapid[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, GUIDE)])
        self.models = []
        for w in self.weights(iterations):
            m = copy.copy(model)
            m.eq_solref[self.weld, 0] = self.timeconst / w if w > 0 else self.timeconst
            self.models.append(m)
        self.columns = int(layout.free_columns[0])
        self.track = track
        self.active0 = model.eq_active0.astype(float)
        mocap = np.flatnonzero(model.body_mocapid >= 0)
        order = np.argsort(model.body_mocapid[mocap])
        self.mocap_pos0 = model.body_pos[mocap[order]].copy()
        self.mocap_quat0 = model.body_quat[mocap[order]].copy()
        self._off = np.concatenate([self.active0, self.mocap_pos0.ravel(), self.mocap_quat0.ravel()])
        return model

    def off(self) -> np.ndarray:
        """(k,) the rollout's extra inputs with the weld off (every other equality as the model has it)."""
        return self._off

    def inputs(self, window: slice, steps: int, weight: float) -> np.ndarray:
        """(steps, k) the extra inputs of the planning steps from ``window.start``: the weld active (at
        ``weight`` > 0, where :attr:`during` says) and the guide at the reference's object pose."""
        out = np.tile(self._off, (steps, 1))
        if weight <= 0:
            return out
        rows = np.minimum(window.start + np.arange(steps), len(self.track.object_qpos) - 1)
        c = self.columns
        pose = self.track.object_qpos[rows, c : c + 7]
        neq, nmocap = len(self.active0), len(self.mocap_pos0)
        if self.during == "contact":
            active = self.track.contact_active[rows].any(axis=1)
        else:
            active = np.ones(steps, dtype=bool)
        out[:, self.weld] = active.astype(float)
        out[:, neq + 3 * self.guide : neq + 3 * self.guide + 3] = pose[:, :3]
        q0 = neq + 3 * nmocap + 4 * self.guide
        out[:, q0 : q0 + 4] = pose[:, 3:7]
        return out
