"""The Allegro right hand with the paper authors' kinematics, on our floating 6-DOF wrist.

The authors' hand (``mjpc/tasks/allegro/right_hand_body.xml`` and ``right_hand_template.xml`` of their
MJPC fork) follows an older Menagerie Allegro model and differs from :class:`AllegroHand` (DESIGN §3) in:

- the palm sits 0.0942 m along the wrist body's z axis, unrotated (ours: at the wrist, rotated by quat
  (0, 1, 0, 1)/sqrt(2));
- the thumb base orientation, and joint ``thj0``: axis +x, range +-0.6981 (ours: -x, 0.263..1.396);
- fingertip bodies 26.7 mm (fingers) and 42.3 mm (thumb) beyond the distal joint (ours: at it);
- a middle-finger distal link tilted by quat (0.999095, 0, -0.0425433, 0) in its parent;
- the ff/rf base tilt 0.0436212 (ours 0.0436194);
- finger joints damping 0.1 and position gains kp 1 (ours 1 and 10).

Their joint angles and their link-frame contact points only mean what they meant on their hand, so the
paper's tasks run on this one. Everything else is :class:`AllegroHand`'s: names (``allegro_`` prefix
dropped), collision primitives (the authors' boxes have our sizes and positions; their fingertips are
meshes, which are not available: our capsules are kept where they sit on the distal link, so they are
shifted by the tip body's offset), link masses (their collision geoms are massless and the masses come
from the meshes; their palm's inertial mass is ours, 0.4154 kg), contact excludes, finger armature and
force limits (their XML sets neither) and the wrist. Their wrist (``allegro_wrist``: three slides and a
ball joint) maps onto ours directly: a wrist pose ``(x, y, z, rx, ry, rz)`` is their ``RootTx, RootTy,
RootTz`` and the ball quaternion of ``Rx(rx) @ Ry(ry) @ Rz(rz)``.

Example:
    >>> spec = mujoco.MjSpec()
    >>> AllegroPaperHand().add_to(spec)
    >>> spec.compile().nu
    22
"""

from __future__ import annotations

from typing import Annotated

from contactmpc.hands.allegro import (
    _IDQ,
    _TH_BASE_GEOM,
    _TH_DIST_GEOM,
    _TH_MED_GEOM,
    _TH_PROX_GEOM,
    _TH_TIP_GEOM,
    _TIP_GEOM,
    _Y,
    _Z,
    AllegroHand,
    _Geom,
    _Link,
)
from contactmpc.hands.allegro import _finger as allegro_finger
from contactmpc.validate import Ge, checked

__all__ = ["AllegroPaperHand"]

_TIP_OFFSET = 0.0267  # fingertip body beyond the distal joint (fingers)
_TH_TIP_OFFSET = 0.0423  # and for the thumb


def _shifted(geom: _Geom, dz: float) -> _Geom:
    """``geom`` moved by ``dz`` along the body's z axis."""
    return _Geom(geom.type, geom.size, (geom.pos[0], geom.pos[1], geom.pos[2] + dz), geom.mass)


# Our fingertip capsules, kept where they sit on the distal link, in the authors' tip body frames.
_PAPER_TIP_GEOM = _shifted(_TIP_GEOM, -_TIP_OFFSET)
_PAPER_TH_TIP_GEOM = _shifted(_TH_TIP_GEOM, -_TH_TIP_OFFSET)


def _finger(prefix: str, pos: tuple, quat: tuple, distal_quat: tuple = _IDQ) -> list[_Link]:
    """One long finger in the authors' model: :func:`~contactmpc.hands.allegro._finger` with their
    fingertip body offset and our capsule kept where it sits."""
    return allegro_finger(prefix, pos, quat, distal_quat, _TIP_OFFSET, _PAPER_TIP_GEOM)


# Transcribed from right_hand_body.xml (bodies allegro_<name>) and the joint classes of
# right_hand_template.xml (base, proximal, medial, distal, thumb_*).
_PAPER_TREE: tuple[_Link, ...] = (
    *_finger("ff", (0.0, 0.0435, -0.001542), (0.999048, -0.0436212, 0.0, 0.0)),
    *_finger("mf", (0.0, 0.0, 0.0007), _IDQ, distal_quat=(0.999095, 0.0, -0.0425433, 0.0)),
    *_finger("rf", (0.0, -0.0435, -0.001542), (0.999048, 0.0436212, 0.0, 0.0)),
    _Link("th_base", "palm", (-0.0182, 0.019333, -0.045987), (-0.396524, 0.599668, 0.445978, 0.533171),
          "thj0", (1.0, 0.0, 0.0), (-0.6981, 0.6981), _TH_BASE_GEOM),
    _Link("th_proximal", "th_base", (-0.027, 0.005, 0.0399), _IDQ, "thj1", _Z, (-0.105, 1.163),
          _TH_PROX_GEOM),
    _Link("th_medial", "th_proximal", (0, 0, 0.0177), _IDQ, "thj2", _Y, (-0.189, 1.644), _TH_MED_GEOM),
    _Link("th_distal", "th_medial", (0, 0, 0.0514), _IDQ, "thj3", _Y, (-0.162, 1.719), _TH_DIST_GEOM),
    _Link("th_tip", "th_distal", (0, 0, _TH_TIP_OFFSET), _IDQ, None, _Z, (0, 0), _PAPER_TH_TIP_GEOM),
)  # fmt: skip


class AllegroPaperHand(AllegroHand):
    """:class:`AllegroHand` built from the paper authors' kinematic table and finger gains.

    Same joint, link, geom and actuator names as :class:`AllegroHand`; the palm hangs 0.0942 m along
    the wrist root's z axis, as their ``allegro_palm`` under ``allegro_wrist``.

    Args:
        kp_finger: position gain of the finger actuators (N·m/rad); theirs, 1.
        damping_finger: finger joint damping (N·m·s/rad); theirs, 0.1.
        name: identifier of this hand (for records).
        slide_range: limits of the wrist slides (m) about the mount; their wrist slides are unlimited
            and the retargeted wrists travel up to 1.32 m from where they start.
        **kwargs: see :class:`AllegroHand` (finger armature and force limit: ours) and the wrist.
    """

    TREE = _PAPER_TREE
    PALM_POS = (0.0, 0.0, 0.0942)
    PALM_QUAT = (1.0, 0.0, 0.0, 0.0)

    @checked
    def __init__(
        self,
        kp_finger: Annotated[float, Ge(0)] = 1.0,
        damping_finger: Annotated[float, Ge(0)] = 0.1,
        name: str = "allegro_paper_right",
        slide_range: tuple[float, float] = (-2.0, 2.0),
        **kwargs,
    ) -> None:
        super().__init__(
            kp_finger=kp_finger, damping_finger=damping_finger, name=name, slide_range=slide_range, **kwargs
        )
