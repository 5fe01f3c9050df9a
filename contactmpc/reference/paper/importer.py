r"""The importer of the paper authors' task data: their four files of one task -> our :class:`Reference`.

A task of the authors' fork of MuJoCo MPC is four files under their ``mjpc/tasks`` directory (the
directory a user names; :class:`PaperFiles` finds them there):

- ``allegro/splinetrajectories/<demo>_hand.smexp``: 22 curves, the wrist translation (cm, the world
  position of their body ``allegro_wrist``), the wrist Euler angles (deg, ``R = Rz(z) Ry(y) Rx(x)``) and
  the 16 finger joints (deg) in the order of the joints of their ``right_hand_body.xml``;
- ``shared_spline_trajectories/<demo>_object.smexp``: the world pose of the object body (cm, deg);
- ``allegro/pcsplines/<demo>.pcmexp``: the PCA of the finger curves (radians);
- ``allegro/contacts/data/<demo>.xml``: the contact pairs per mocap frame.

plus their hand, ``allegro/right_hand_body.xml``, for the names behind their joint and body indices.

How each is turned into ours (:func:`import_reference`):

- **Time.** Frame ``k = 0 .. F-1`` of the reference is the mocap frame ``k`` at ``k / 120`` s of the
  demonstration (``F`` = the contact file's frame count, which must equal ``120 * time``). Its curves
  are evaluated as the C++ does at simulation time ``k * slowdown / 120``: the value column at
  ``u = k / (120 * time)`` (:func:`~contactmpc.reference.paper.evaluation.evaluate`, ``time`` from the hand
  file for every curve set), then wrapped and converted to metres and radians. The slowdown itself
  becomes the task's ``time_scale``.
- **Wrist.** Our wrist is three slides and three hinges on ``hand_root`` with ``R = Rx(rx) Ry(ry)
  Rz(rz)``; :class:`~contactmpc.hands.AllegroPaperHand` puts its palm 0.0942 m along ``hand_root``'s z
  axis as theirs is along ``allegro_wrist``'s. So ``hand_root`` takes their wrist's pose: the slides are
  the wrist position minus the scene's wrist zero (``mount``), the hinges the XYZ-Euler angles of their
  ``Rz Ry Rx`` (:func:`wrist_angles`), chosen per frame among the two Euler solutions and their
  ``2 pi`` shifts as the one nearest the previous frame (nearest zero at frame 0), so that the hinge
  angles stay continuous.
- **Fingers.** Their curves 6-21 follow their joint order (thumb, first, middle, ring); they are put in
  our joint order by name.
- **Object.** The world pose (position, quaternion w x y z) per frame; the task turns it into its
  object configuration (a free body keeps it; the doorknob projects it on its slide).
- **Contacts.** A hand point of body index ``i`` is in the frame of body ``i`` of their compiled model
  without the extra bodies that some scenes add before the hand (``allegro.h`` adds that offset, e.g. the
  stapler's table, at look-up): world, the object's mocap body, ``hand_startclamp``, then the bodies of
  ``right_hand_body.xml`` in document order (:func:`their_body_names`). Index 3 is ``allegro_wrist``,
  whose points lie on the palm: they are moved into the palm's frame. Every other body maps to our link
  of the same name without the ``allegro_`` prefix. A link with several contacts in a frame gets their
  mean (the reference keeps one point per link and frame, paper section II-A); the object points are
  in the frame of the task's object body.
- **Their cost's contacts.** Their contact residual keeps only the first ``floor(n / 3)`` of a frame's
  ``n`` contacts (in their file's order); ``meta["paper_code_contacts"]`` lists per frame the links those
  fall on, for :class:`~contactmpc.control.cost.TrackingCost`'s ``contact_subset="authors_code"``.
- **PCA.** Their ``center`` and components, columns put in our finger-joint order, are kept in
  ``meta["paper_pca"]`` (radians) so that a sampler can use their basis as well as one recomputed from
  the curves.
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from contactmpc.reference.data import Reference, ReferenceError
from contactmpc.reference.paper.contacts import ContactFrames, read_contacts
from contactmpc.reference.paper.evaluation import code_component_matrix, evaluate, to_mujoco_units
from contactmpc.reference.paper.splines import MOCAP_FPS, PCSplines, SplineCurves, read_pcmexp, read_smexp

__all__ = [
    "BODIES_BEFORE_HAND",
    "GET_THE_DATA",
    "PaperFiles",
    "TheirHand",
    "hand_configuration",
    "import_reference",
    "object_pose",
    "start_configuration",
    "their_body_names",
    "their_rotation",
    "wrist_angles",
]

GET_THE_DATA = (
    "get it by cloning the authors' repository (git clone https://github.com/lakshmipathyarjun6/mujoco_mpc) "
    "and set paper_data=<clone>/mjpc/tasks (or the environment variable CONTACTMPC_PAPER_DATA)"
)
"""How to get the paper's data: the end of every error about a missing data directory."""

BODIES_BEFORE_HAND = ("world", "<object>_mocap", "hand_startclamp")
"""The bodies of the authors' compiled model before ``allegro_wrist``, as the contact files count them."""

_NUM_HAND_CURVES = 22
_NUM_OBJECT_CURVES = 6
_NUM_FINGERS = 16
_PREFIX = "allegro_"
_WRIST = "allegro_wrist"
_PALM = "allegro_palm"


@dataclass(frozen=True)
class PaperFiles:
    """The authors' files of one demonstration under their ``mjpc/tasks`` directory.

    Attributes:
        root: the ``mjpc/tasks`` directory (holds ``allegro/``, ``shared_assets/``, ...).
        demo: the demonstration's name, e.g. ``apple_pass_1``.
    """

    root: Path
    demo: str

    @classmethod
    def locate(cls, root: str | os.PathLike | None, demo: str) -> PaperFiles:
        """The files of ``demo`` under ``root``, checked to exist.

        Raises:
            ReferenceError: one line: ``root`` unset, not a directory, or without one of the files
                (naming it), with how to get the data.
        """
        if root is None or str(root) == "":
            raise ReferenceError(f"the paper's data directory is not set; {GET_THE_DATA}")
        path = Path(root).expanduser()
        if not path.is_dir():
            raise ReferenceError(f"paper data directory {path} does not exist; {GET_THE_DATA}")
        files = cls(path, demo)
        for p in (files.hand, files.object, files.pcs, files.contacts, files.hand_xml):
            if not p.is_file():
                raise ReferenceError(
                    f"{p} not found: {path} is not the authors' mjpc/tasks directory; {GET_THE_DATA}"
                )
        return files

    @property
    def hand(self) -> Path:
        """The hand curves."""
        return self.root / "allegro" / "splinetrajectories" / f"{self.demo}_hand.smexp"

    @property
    def object(self) -> Path:
        """The object curves."""
        return self.root / "shared_spline_trajectories" / f"{self.demo}_object.smexp"

    @property
    def pcs(self) -> Path:
        """The PCA and PC-curves."""
        return self.root / "allegro" / "pcsplines" / f"{self.demo}.pcmexp"

    @property
    def contacts(self) -> Path:
        """The per-frame contacts."""
        return self.root / "allegro" / "contacts" / "data" / f"{self.demo}.xml"

    @property
    def hand_xml(self) -> Path:
        """Their hand's body tree."""
        return self.root / "allegro" / "right_hand_body.xml"

    def asset(self, name: str) -> Path:
        """A file of ``shared_assets/``, e.g. ``asset("apple/apple.obj")``."""
        return self.root / "shared_assets" / name


@dataclass(frozen=True)
class TheirHand:
    """What the importer needs of the authors' ``right_hand_body.xml``.

    Attributes:
        bodies: body names in document order (``allegro_wrist`` first).
        finger_joints: the non-root joint names in document order (their qpos / curve order).
        palm_pos: (3,) position of ``allegro_palm`` in ``allegro_wrist``'s frame.
        palm_quat: (4,) its orientation there (w x y z).
    """

    bodies: tuple[str, ...]
    finger_joints: tuple[str, ...]
    palm_pos: np.ndarray
    palm_quat: np.ndarray

    @classmethod
    def read(cls, path: str | os.PathLike) -> TheirHand:
        """Read the body tree.

        Raises:
            ReferenceError: one line naming the file and what is missing.
        """
        path = Path(path)
        try:
            root = ET.parse(path).getroot()
        except (ET.ParseError, OSError) as err:
            raise ReferenceError(f"not a readable XML file ({err})", path=path) from err
        bodies = [b for b in root.iter("body")]
        names = tuple(b.get("name", "") for b in bodies)
        if not names or names[0] != _WRIST or _PALM not in names:
            raise ReferenceError(f"expected bodies {_WRIST} (first) and {_PALM}, got {names[:3]}", path=path)
        wrist = bodies[0]
        joints = [j for j in root.iter("joint") if j.get("type") not in ("slide", "ball")]
        fingers = tuple(j.get("name", "") for j in joints)
        if len(fingers) != _NUM_FINGERS:
            raise ReferenceError(f"expected {_NUM_FINGERS} finger joints, got {len(fingers)}", path=path)
        palm = next(b for b in wrist if b.tag == "body" and b.get("name") == _PALM)

        def vec(text: str | None, default: list[float]) -> np.ndarray:
            try:
                return np.array([float(v) for v in text.split()] if text else default)
            except ValueError as err:
                raise ReferenceError(f"body {_PALM}: bad number ({err})", path=path) from err

        return cls(names, fingers, vec(palm.get("pos"), [0, 0, 0]), vec(palm.get("quat"), [1, 0, 0, 0]))


def their_body_names(hand: TheirHand, object_name: str) -> tuple[str, ...]:
    """Body index -> name in the authors' compiled model, as their contact files count (see
    :data:`BODIES_BEFORE_HAND`)."""
    before = tuple(n.replace("<object>", object_name) for n in BODIES_BEFORE_HAND)
    return before + hand.bodies


def their_rotation(euler: np.ndarray) -> Rotation:
    """The authors' ``ConvertEulerAnglesToQuat``: ``R = Rz(z) Ry(y) Rx(x)`` of angles ``(x, y, z)`` (rad).

    Args:
        euler: (N, 3) angles about x, y, z.
    """
    return Rotation.from_euler("xyz", np.asarray(euler, float))  # extrinsic x, y, z = Rz @ Ry @ Rx


def wrist_angles(rotation: Rotation, start: Sequence[float] = (0.0, 0.0, 0.0)) -> np.ndarray:
    """Our wrist hinges ``(rx, ry, rz)`` with ``R = Rx(rx) Ry(ry) Rz(rz)``, continuous over frames.

    Per frame both XYZ-Euler solutions ``(a, b, c)`` and ``(a + pi, pi - b, c + pi)`` are shifted by
    multiples of ``2 pi`` to lie nearest the previous frame's angles (``start`` for the first), and the
    nearer of the two is taken.

    Args:
        rotation: N rotations.
        start: (3,) the angles the first frame should lie nearest to.

    Returns:
        (N, 3) float64 angles in radians.
    """
    with np.errstate(all="ignore"):
        base = np.atleast_2d(rotation.as_euler("XYZ"))
    alt = np.stack([base[:, 0] + math.pi, math.pi - base[:, 1], base[:, 2] + math.pi], axis=1)
    out = np.empty_like(base)
    prev = np.asarray(start, float)
    two_pi = 2.0 * math.pi
    for i in range(base.shape[0]):
        best, best_d = None, math.inf
        for cand in (base[i], alt[i]):
            shifted = cand + two_pi * np.round((prev - cand) / two_pi)
            d = float(np.linalg.norm(shifted - prev))
            if d < best_d:
                best, best_d = shifted, d
        out[i] = prev = best
    return out


def hand_configuration(
    curves: SplineCurves,
    theirs: TheirHand,
    time: np.ndarray,
    joint_names: Sequence[str],
    mount: Sequence[float],
    files: PaperFiles,
) -> np.ndarray:
    """Our hand configuration of their hand curves at demonstration times ``time`` (see the module
    docstring: wrist from their wrist pose, fingers by name).

    Args:
        curves: their hand curves.
        theirs: their hand's joint and body names.
        time: (N,) demonstration times (s), evaluated as the C++ does (``u = t / curves.duration``).
        joint_names: (22,) our joints: 6 wrist joints, then 16 finger joints named like theirs.
        mount: (3,) world position of our wrist's zero.
        files: for error messages.

    Returns:
        (N, 22) float64.
    """
    values = to_mujoco_units(curves, evaluate(curves, time, 1.0, duration=curves.duration))
    trans, euler = _pose_columns(curves, files.hand)
    wrist = np.concatenate(
        [values[:, trans] - np.asarray(mount, float), wrist_angles(their_rotation(values[:, euler]))], axis=1
    )
    finger_cols = [i for i in range(curves.num_curves) if i not in trans + euler]
    their_fingers = dict(zip(theirs.finger_joints, finger_cols, strict=True))
    ours = list(joint_names)[6:]
    missing = [j for j in ours if j not in their_fingers]
    if missing or len(ours) != _NUM_FINGERS:
        raise ReferenceError(
            f"our finger joints {missing or ours} do not match theirs ({', '.join(theirs.finger_joints)})",
            path=files.hand_xml,
        )
    return np.concatenate([wrist, values[:, [their_fingers[j] for j in ours]]], axis=1)


def object_pose(
    curves: SplineCurves, time: np.ndarray, duration: float, path: Path
) -> tuple[np.ndarray, np.ndarray]:
    """The object body's world pose from their object curves at demonstration times ``time``.

    Args:
        curves: their object curves.
        time: (N,) demonstration times (s).
        duration: the *hand* file's ``time`` (the C++ loops every curve set on it).
        path: the object file, for error messages.

    Returns:
        pos (N, 3) metres and quat (N, 4) w x y z (``w >= 0`` at the first frame, then continuous).
    """
    values = to_mujoco_units(curves, evaluate(curves, time, 1.0, duration=duration))
    trans, euler = _pose_columns(curves, path)
    quat = their_rotation(values[:, euler]).as_quat(scalar_first=True)
    if quat[0, 0] < 0:
        quat[0] = -quat[0]
    for i in range(1, len(quat)):  # one hemisphere from frame to frame
        if np.dot(quat[i], quat[i - 1]) < 0:
            quat[i] = -quat[i]
    return values[:, trans], quat


def start_configuration(
    files: PaperFiles, joint_names: Sequence[str], mount: Sequence[float]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Frame 0 of a demonstration: our hand configuration (J,) and the object's world pose
    (pos (3,), quat (4,)), for a task to build its scene around."""
    hand = read_smexp(files.hand, expected_dofs=_NUM_HAND_CURVES)
    obj = read_smexp(files.object, expected_dofs=_NUM_OBJECT_CURVES)
    zero = np.zeros(1)
    pos, quat = object_pose(obj, zero, hand.duration, files.object)
    q = hand_configuration(hand, TheirHand.read(files.hand_xml), zero, joint_names, mount, files)
    return q[0], pos[0], quat[0]


def _curves_of(curves: SplineCurves, kind: str, path: Path) -> list[int]:
    found = [i for i, k in enumerate(curves.kind) if k == kind]
    if not found:
        raise ReferenceError(f"no curve of type {kind!r}", path=path)
    return found


def _pose_columns(curves: SplineCurves, path: Path) -> tuple[list[int], list[int]]:
    """Indices of the 3 translation and the X, Y, Z Euler curves of a free body's 6 curves."""
    trans = _curves_of(curves, "translation", path)[:3]
    euler = [_curves_of(curves, f"rotationBall{a}", path)[0] for a in "XYZ"]
    if len(trans) != 3:
        raise ReferenceError(f"expected 3 translation curves, got {len(trans)}", path=path)
    return trans, euler


def _mean_contacts(
    contacts: ContactFrames,
    link_of_body: dict[int, tuple[int, np.ndarray, np.ndarray]],
    num_links: int,
    path: Path,
    names: tuple[str, ...],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per frame and link: active, mean link-frame point, mean object point."""
    num_f = contacts.num_frames
    count = np.zeros((num_f, num_links))
    link_sum = np.zeros((num_f, num_links, 3))
    obj_sum = np.zeros((num_f, num_links, 3))
    frame_of = np.repeat(np.arange(num_f), contacts.frame_counts)
    for row, (f, b) in enumerate(zip(frame_of, contacts.body_index, strict=True)):
        if int(b) not in link_of_body:
            known = ", ".join(f"{i}={n}" for i, n in enumerate(names) if i in link_of_body)
            raise ReferenceError(
                f"frame {f}: body index {b} is not a hand link of their model (known: {known})",
                field=f"contact_pos_hand_data_{f}_*",
                path=path,
            )
        link, rot, offset = link_of_body[int(b)]
        count[f, link] += 1
        link_sum[f, link] += rot @ contacts.hand_point[row] + offset
        obj_sum[f, link] += contacts.object_point[row]
    active = count > 0
    safe = np.maximum(count, 1)[..., None]
    return active, link_sum / safe, obj_sum / safe


def import_reference(
    files: PaperFiles,
    *,
    task: str,
    object_name: str,
    slowdown: float,
    joint_names: Sequence[str],
    link_names: Sequence[str],
    mount: Sequence[float],
    object_qpos: Callable[[np.ndarray, np.ndarray], np.ndarray],
    object_bodies: Sequence[str],
    object_quat_index: int | None,
    joint_ranges: np.ndarray | None = None,
) -> Reference:
    """Import one of the authors' demonstrations as our reference (see the module docstring).

    Args:
        files: the demonstration's files.
        task: our task's name (``Reference.task``).
        object_name: the authors' object name (``apple``, ...), for their mocap body's name.
        slowdown: their slowdown factor of the task (``allegro.h``); stored as ``meta["time_scale"]``.
        joint_names: (J,) our hand's joints: 6 wrist joints (x, y, z slides, rx, ry, rz hinges), then
            16 finger joints named like theirs (``ffj0`` ... ``thj3``).
        link_names: (L,) our hand's contact links (their body names without ``allegro_``; ``palm``
            also takes their wrist's points).
        mount: (3,) world position of our wrist's zero (the scene's ``hand_root`` position).
        object_qpos: ``(pos (T, 3), quat (T, 4)) -> (T, n_o)``, the task's object configuration of the
            object body's world pose.
        object_bodies: the task's object bodies; the contact points are in the first one's frame.
        object_quat_index: ``meta["object_quat_index"]`` of the task's object configuration.
        joint_ranges: (J, 2) our hand's joint limits, if given: the retargeted finger angles leave
            their own hand's limits by up to about 0.02 rad; they are clipped to these, and
            ``meta["clipped"]`` says per joint how many frames and by how much at most.

    Returns:
        The reference (not yet validated against a scene: :meth:`Reference.validate` does that).

    Raises:
        ReferenceError: one line naming the file and what is wrong.
    """
    hand_curves = read_smexp(files.hand, expected_dofs=_NUM_HAND_CURVES)
    obj_curves = read_smexp(files.object, expected_dofs=_NUM_OBJECT_CURVES)
    pcs = read_pcmexp(files.pcs, expected_dofs=_NUM_FINGERS)
    contacts = read_contacts(files.contacts)
    theirs = TheirHand.read(files.hand_xml)

    num_f = contacts.num_frames
    expected_f = round(hand_curves.duration * MOCAP_FPS)
    if num_f != expected_f:
        raise ReferenceError(
            f"{num_f} contact frames, but the hand curves last {hand_curves.duration:.6g} s = {expected_f} "
            f"frames at {MOCAP_FPS:g} fps ({files.hand.name})",
            field="contact_numdata",
            path=files.contacts,
        )
    time = np.arange(num_f) / MOCAP_FPS
    hand_qpos = hand_configuration(hand_curves, theirs, time, joint_names, mount, files)
    pos, quat = object_pose(obj_curves, time, hand_curves.duration, files.object)
    object_q = np.asarray(object_qpos(pos, quat), dtype=np.float64)
    ours = list(joint_names)[6:]
    clipped: dict[str, dict[str, float]] = {}
    if joint_ranges is not None:
        ranges = np.asarray(joint_ranges, dtype=np.float64)
        inside = np.clip(hand_qpos, ranges[:, 0], ranges[:, 1])
        excess = np.abs(hand_qpos - inside)
        for j in np.flatnonzero(excess.max(axis=0) > 0):
            clipped[joint_names[j]] = {
                "frames": int(np.count_nonzero(excess[:, j])),
                "max_excess": float(excess[:, j].max()),
            }
        hand_qpos = inside

    # contacts, their body index -> our link (and the point into our link's frame)
    names = their_body_names(theirs, object_name)
    palm_rot = Rotation.from_quat(theirs.palm_quat, scalar_first=True).as_matrix()
    link_index = {n: i for i, n in enumerate(link_names)}
    link_of_body: dict[int, tuple[int, np.ndarray, np.ndarray]] = {}
    for i, name in enumerate(names):
        if name == _WRIST:  # wrist-frame point p -> palm frame: R_palm^T (p - palm_pos)
            link_of_body[i] = (link_index["palm"], palm_rot.T, -palm_rot.T @ theirs.palm_pos)
        elif name.startswith(_PREFIX) and name[len(_PREFIX) :] in link_index:
            link_of_body[i] = (link_index[name[len(_PREFIX) :]], np.eye(3), np.zeros(3))
    active, link_point, object_point = _mean_contacts(
        contacts, link_of_body, len(link_names), files.contacts, names
    )

    # the links of the contacts their residual keeps: the first floor(n / 3) of a frame's n, in file order
    code_contacts = []
    for f in range(num_f):
        kept = contacts.frame(f).body_index[: contacts.frame_counts[f] // 3]
        code_contacts.append(sorted({link_of_body[int(b)][0] for b in kept}))

    # their PCA, columns in our finger order
    order = [theirs.finger_joints.index(j) for j in ours]
    meta = {
        "source": "paper",
        "generator": f"{__name__}.import_reference",
        "demo": files.demo,
        "files": {k: str(getattr(files, k)) for k in ("hand", "object", "pcs", "contacts", "hand_xml")},
        "units": {"time": "s", "length": "m", "angle": "rad"},
        "time_scale": float(slowdown),
        "fps": MOCAP_FPS,
        "object_quat_index": object_quat_index,
        "num_control_points": hand_curves.num_control_points,
        "mount": [float(v) for v in mount],
        "paper_pca": _pca_meta(pcs, order),
        "clipped": clipped,
        "paper_code_contacts": code_contacts,
    }
    return Reference(
        time=time,
        hand_qpos=np.ascontiguousarray(hand_qpos, dtype=np.float64),
        object_qpos=object_q,
        contact_active=active,
        contact_link_point=link_point,
        contact_object_point=object_point,
        contact_object_body=np.zeros(active.shape, dtype=np.int64),
        link_names=np.array(list(link_names), dtype=str),
        joint_names=np.array(joint_names, dtype=str),
        object_bodies=np.array(list(object_bodies), dtype=str),
        task=task,
        meta=meta,
    )


def _pca_meta(pcs: PCSplines, order: list[int]) -> dict:
    """Their PCA (radians) with the joint columns in our finger-joint order: ``center`` (D,),
    ``components`` (k, D) (joints = center + p C, the paper's Eq. 3) and ``code_components`` (k, D), the
    matrix their code reconstructs with instead (the aliased transpose, mirrored in *their* joint order
    before the columns are reordered)."""
    code = code_component_matrix(pcs)  # (D, k), rows in their joint order
    return {
        "center": [float(v) for v in pcs.center[order]],
        "components": [[float(v) for v in row] for row in pcs.components[:, order]],
        "code_components": [[float(v) for v in row] for row in code[order, :].T],
        "num_control_points": pcs.curves.num_control_points,
    }
