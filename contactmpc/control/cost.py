"""The paper's running cost (Eq. 2), vectorised over (samples, horizon).

.. math::
    l(x_t) = \\lambda_o \\|\\hat q_o(t) - q_o(t)\\|^2 + \\lambda_c \\sum_{l \\in A(t)}
             \\|c_l(q_a(t)) - c_l(q_o(t))\\|^2 + \\lambda_v \\|\\dot q_a(t)\\|^2

The object distance is ``|dp|^2 + w_rot * angle^2 + w_art * |d angles|^2``; the contact term sums,
over the links whose contact is expected at that reference time, the squared world-frame distance
between the link's contact point and the corresponding point on the object. The optional *release*
term (not the paper's; ``release_weight`` > 0) is the contact term's complement after the reference
has let go: once the reference's last expected contact has passed, every hand-object contact ``n_c``
costs as much as ``release_weight`` m^2 of squared object position error. Two optional terms (not the
paper's either) read the scene's link-object distances (``geomdist`` sensors, ``d_l`` the distance from
link ``l``'s collision geom to the nearest object geom): the *surface* term (``surface_weight`` > 0),
``lambda_c * surface_weight * sum_{l in A(t)} max(d_l, 0)^2``, pulls every expected link onto the
object's surface wherever it touches it, not only at the reference's point; the *clearance* term
(``clearance_weight`` > 0), ``lambda_c * clearance_weight * sum_{l before its first contact}
max(clearance - d_l, 0)^2``, keeps each link off the object until the reference first expects that
link's contact, so a finger does not tap the object over before the grasp it belongs to. Every input
comes from the rollout's ``sensordata``, so no Python runs per simulated step.
"""

from __future__ import annotations

from typing import Annotated

import mujoco
import numba
import numpy as np

from contactmpc.control.track import ReferenceTrack
from contactmpc.reference.data import Reference
from contactmpc.scene import Scene
from contactmpc.validate import Ge, OneOf, checked


@numba.njit(cache=True, parallel=True)
def _contact_sq_dist(
    sd, steps, link_pos, link_quat, obj_pos, obj_quat, link_pt, obj_pt, out
):  # pragma: no cover
    """Accumulate ``|p_l + R(q_l) a - (p_o + R(q_o) b)|^2`` per (sample, step) over expected pairs.

    Args:
        sd: (S, H, nsensordata) rollout sensors.
        steps: (P,) step of each expected (step, link) pair.
        link_pos, link_quat: (P, 3), (P, 4) sensordata addresses of the pair's link pose.
        obj_pos, obj_quat: (P, 3), (P, 4) sensordata addresses of the pair's object-body pose.
        link_pt, obj_pt: (P, 3) link-local and object-local points.
        out: (S, H) accumulator.
    """
    for s in numba.prange(sd.shape[0]):
        for p in range(steps.shape[0]):
            h = steps[p]
            acc = 0.0
            xs = np.empty(3)
            for side in range(2):
                pa = link_pos[p] if side == 0 else obj_pos[p]
                qa = link_quat[p] if side == 0 else obj_quat[p]
                v = link_pt[p] if side == 0 else obj_pt[p]
                w, x, y, z = sd[s, h, qa[0]], sd[s, h, qa[1]], sd[s, h, qa[2]], sd[s, h, qa[3]]
                tx = 2.0 * (y * v[2] - z * v[1])
                ty = 2.0 * (z * v[0] - x * v[2])
                tz = 2.0 * (x * v[1] - y * v[0])
                px = sd[s, h, pa[0]] + v[0] + w * tx + (y * tz - z * ty)
                py = sd[s, h, pa[1]] + v[1] + w * ty + (z * tx - x * tz)
                pz = sd[s, h, pa[2]] + v[2] + w * tz + (x * ty - y * tx)
                if side == 0:
                    xs[0], xs[1], xs[2] = px, py, pz
                else:
                    acc = (xs[0] - px) ** 2 + (xs[1] - py) ** 2 + (xs[2] - pz) ** 2
            out[s, h] += acc


def as_index(adr: np.ndarray) -> slice | np.ndarray:
    """A slice for a run of consecutive addresses (a view, no copy), else the addresses themselves."""
    adr = np.asarray(adr)
    if adr.size and np.array_equal(adr, np.arange(adr[0], adr[0] + adr.size)):
        return slice(int(adr[0]), int(adr[0]) + adr.size)
    return adr


class TrackingCost:
    """Object tracking + contact correspondence + hand velocity, with separately logged terms.

    Args:
        lambda_o: weight of the object term.
        lambda_c: weight of the contact term (0 = the paper's ``object_only`` ablation).
        lambda_v: weight of the hand-velocity term.
        rotation_weight: weight of the squared orientation angle (rad^2) against position (m^2).
        articulation_weight: weight of squared articulation errors (rad^2).
        velocity_joints: ``all`` hand joints in the velocity term, or the ``fingers`` only (the
            authors' code: ``qvel + 6``, the 16 finger DOFs).
        contact_subset: which expected contacts enter the contact term: every ``expected`` one (the
            paper), or ``authors_code``: those of the authors' residual, which copies only the first
            ``n`` scalars of the ``3n`` stacked differences of a frame's ``n`` contacts, i.e. its first
            ``floor(n / 3)`` contacts in their file's order (the partial next one is left out); the
            links they fall on per frame come with the reference (``meta["paper_code_contacts"]``, from
            the importer of the paper's data).
        release_weight: the release term's weight (m^2 of squared object position error per hand-object
            contact, so it is weighted by ``lambda_o`` too), on the steps after the reference's last
            expected contact; 0 (the paper) leaves the hand free to touch the object there.
        surface_weight: the surface term's weight relative to the contact term's (so it is weighted by
            ``lambda_c`` too): the squared distance (m^2) from each expected link to the object's surface;
            needs the scene's distance sensors (``scene.link_distance_cutoff`` > 0). 0: the paper.
        clearance_weight: the clearance term's weight relative to the contact term's: the squared depth
            (m^2) by which a link comes within ``clearance`` of the object before the reference first
            expects that link's contact (the same sensors). 0: the paper.
        clearance: the margin (m) of the clearance term.
        clearance_links: the clearance term holds every link off the object at least until the reference
            first expects this many links in contact at once (each link's own first expected contact,
            if later), so a grasp that the reference forms over time with one finger first (the
            stapler's index alone for 0.3 s) starts once it has that many (a count it never reaches
            keeps every link off throughout); 0 (the default): each link until its own first expected
            contact. Not the paper's.

    The authors' weights (``task_template.xml``: object position 1000, orientation 10, contact 5000,
    hand velocity 1, each ``0.5 w |r|^2``) are ``lambda_o = 500``, ``rotation_weight = 0.01``,
    ``lambda_c = 2500``, ``lambda_v = 0.5`` with ``velocity_joints = fingers``; their orientation
    residual (``mju_subQuat``) is the rotation vector, so ``|r|^2`` is the squared angle, as ours.
    """

    terms = ("object", "contact", "velocity", "release", "surface", "clearance", "rest")

    @checked
    def __init__(
        self,
        lambda_o: Annotated[float, Ge(0)] = 1.0,
        lambda_c: Annotated[float, Ge(0)] = 1.0,
        lambda_v: Annotated[float, Ge(0)] = 0.01,
        rotation_weight: Annotated[float, Ge(0)] = 0.1,
        articulation_weight: Annotated[float, Ge(0)] = 1.0,
        velocity_joints: Annotated[str, OneOf("all", "fingers")] = "all",
        contact_subset: Annotated[str, OneOf("expected", "authors_code")] = "expected",
        release_weight: Annotated[float, Ge(0)] = 0.0,
        surface_weight: Annotated[float, Ge(0)] = 0.0,
        clearance_weight: Annotated[float, Ge(0)] = 0.0,
        clearance: Annotated[float, Ge(0)] = 0.01,
        clearance_links: Annotated[int, Ge(0)] = 0,
        rest_weight: Annotated[float, Ge(0)] = 0.0,
    ) -> None:
        self.rest_weight = float(rest_weight)
        self.clearance_weight = float(clearance_weight)
        self.clearance = float(clearance)
        self.clearance_links = int(clearance_links)
        self.release_weight = float(release_weight)
        self.surface_weight = float(surface_weight)
        self.lambda_o = float(lambda_o)
        self.lambda_c = float(lambda_c)
        self.lambda_v = float(lambda_v)
        self.rotation_weight = float(rotation_weight)
        self.articulation_weight = float(articulation_weight)
        self.velocity_joints = velocity_joints
        self.contact_subset = contact_subset
        self.scene: Scene | None = None
        self.track: ReferenceTrack | None = None

    def bind(self, scene: Scene, track: ReferenceTrack, reference: Reference | None = None) -> None:
        """Attach the scene (sensor addresses, object layout) and the reference track (and the reference
        the track was built from, which ``contact_subset="authors_code"`` needs).

        Raises:
            ValueError: ``contact_subset="authors_code"`` for a reference without the authors' contact
                order (``meta["paper_code_contacts"]``); ``surface_weight`` or ``clearance_weight`` > 0
                in a scene without distance sensors; ``clearance_weight`` > 0 with the sensors read less
                far than ``clearance`` (a cutoff of ``clearance`` is enough: a link farther adds nothing).
        """
        for name in ("surface_weight", "clearance_weight"):
            if getattr(self, name) > 0.0 and scene.index.link_object_dist.shape[1] == 0:
                raise ValueError(
                    f"cost.{name} > 0 needs the scene's link-object distance sensors: set "
                    "scene.link_distance_cutoff > 0 (e.g. 0.05)"
                )
        m = scene.planner_model
        cutoffs = m.sensor_cutoff[m.sensor_type == mujoco.mjtSensor.mjSENS_GEOMDIST]
        if self.clearance_weight > 0.0 and cutoffs.size and cutoffs.min() < self.clearance:
            raise ValueError(
                f"cost.clearance = {self.clearance} m needs the link-object distances read at least that "
                f"far: scene.link_distance_cutoff is {cutoffs.min():g} m"
            )
        self.scene = scene
        self.track = track
        self._qo = as_index(scene.index.object_qo)
        vel = scene.index.hand_vel
        self._vel = as_index(vel[scene.hand.num_root :] if self.velocity_joints == "fingers" else vel)
        self._active = track.contact_active
        expected = np.flatnonzero(track.contact_active.any(axis=1))
        self._release = np.zeros(len(track.contact_active), bool)  # (N,) after the last expected contact
        if expected.size:
            self._release[expected[-1] + 1 :] = True
        self._found = scene.index.hand_object_contact
        n = len(track.contact_active)
        first = np.where(track.contact_active.any(axis=0), track.contact_active.argmax(axis=0), n)  # (L,)
        if self.clearance_links > 0:  # no link before the reference's grasp has that many links
            enough = track.contact_active.sum(axis=1) >= self.clearance_links
            first = np.maximum(first, int(enough.argmax()) if enough.any() else n)
        self._before_first = np.arange(n)[:, None] < first[None, :]  # (N, L) link not yet expected
        if self.contact_subset == "authors_code":
            links = None if reference is None else reference.meta.get("paper_code_contacts")
            if links is None:
                raise ValueError(
                    "cost.contact_subset=authors_code: the reference has no record of the authors' contact "
                    "order (meta['paper_code_contacts'], which the paper tasks' references carry)"
                )
            mask = np.zeros(reference.contact_active.shape, bool)
            for f, ls in enumerate(links):
                mask[f, ls] = True
            self._active = track.contact_active & mask[track.frame]

    def object_qpos(self, sensordata: np.ndarray) -> np.ndarray:
        """(..., n_o) the object configuration read from sensordata (..., nsensordata)."""
        return sensordata[..., self._qo]

    def contact_term(self, sensordata: np.ndarray, window: slice) -> np.ndarray:
        """Unweighted contact term: summed squared distances of the expected pairs.

        ``sum_l active_l * |p_l + R_l a_l - (p_o + R_o b_l)|^2`` over the expected links ``l`` at each
        step (link pose ``p_l, R_l`` and the pose ``p_o, R_o`` of the object body holding the link's
        object point, from sensordata), computed by a compiled kernel over the expected (step, link)
        pairs only.

        Args:
            sensordata: (S, H, nsensordata) with H equal to the window's length.
            window: grid slice of the reference track.

        Returns:
            (S, H) contact term.
        """
        idx, tr = self.scene.index, self.track
        out = np.zeros(sensordata.shape[:2])
        h, link = np.nonzero(self._active[window])
        if h.size == 0:
            return out
        body = tr.contact_object_body[window][h, link]
        _contact_sq_dist(
            np.ascontiguousarray(sensordata),
            h,
            idx.link_pos[link],
            idx.link_quat[link],
            idx.object_pos[body],
            idx.object_quat[body],
            tr.contact_link_point[window][h, link],
            tr.contact_object_point[window][h, link],
            out,
        )
        return out

    def surface_term(self, sensordata: np.ndarray, window: slice) -> np.ndarray:
        """Unweighted surface term: ``sum_l active_l * max(d_l, 0)^2`` over the expected links ``l``,
        ``d_l`` the smallest distance between the link's collision geom and the geoms of the object body
        its contact is expected on (read up to the scene's cutoff).

        Args:
            sensordata: (S, H, nsensordata) with H equal to the window's length.
            window: grid slice of the reference track.

        Returns:
            (S, H) surface term.
        """
        idx = self.scene.index
        out = np.zeros(sensordata.shape[:2])
        h, link = np.nonzero(self._active[window])
        if h.size == 0:
            return out
        body = self.track.contact_object_body[window][h, link]  # (P,)
        dist = sensordata[:, h[:, None], idx.link_object_dist[link]]  # (S, P, G)
        on_body = idx.dist_object_body[None, :] == body[:, None]  # (P, G)
        d = np.where(on_body, dist, np.inf).min(axis=-1)  # (S, P)
        np.add.at(out.T, h, (np.maximum(d, 0.0) ** 2).T)
        return out

    def distances_read(self, window: slice) -> np.ndarray:
        """(L,) the links whose link-object distances (the scene's ``geomdist`` sensors) a term reads
        somewhere in ``window``: the clearance term's before their first expected contact, the surface
        term's where their contact is expected; none without either term."""
        read = np.zeros(self._before_first.shape[1], bool)
        if self.clearance_weight > 0.0:
            read |= self._before_first[window].any(axis=0)
        if self.surface_weight > 0.0:
            read |= self._active[window].any(axis=0)
        return read

    def clearance_term(self, sensordata: np.ndarray, window: slice) -> np.ndarray:
        """Unweighted clearance term: ``sum_l max(clearance - d_l, 0)^2`` over the links ``l`` whose first
        expected contact (in the reference) is still to come, ``d_l`` the link's smallest distance to any
        object geom.

        Args:
            sensordata: (S, H, nsensordata) with H equal to the window's length.
            window: grid slice of the reference track.

        Returns:
            (S, H) clearance term.
        """
        out = np.zeros(sensordata.shape[:2])
        h, link = np.nonzero(self._before_first[window])
        if h.size == 0:
            return out
        d = sensordata[:, h[:, None], self.scene.index.link_object_dist[link]].min(axis=-1)  # (S, P)
        np.add.at(out.T, h, (np.maximum(self.clearance - d, 0.0) ** 2).T)
        return out

    def squared(self, err) -> np.ndarray:
        """An object error (:class:`~contactmpc.tasks.layout.ObjectError`) squared and weighted as the object
        term weighs it: ``position^2 + rotation_weight rotation^2 + articulation_weight articulation^2``."""
        sq = err.position**2 + self.rotation_weight * err.rotation**2
        return sq + self.articulation_weight * err.articulation**2

    def rest_term(self, sensordata: np.ndarray, window: slice) -> np.ndarray:
        """Unweighted rest term: the object's squared configuration speed from the step before to each step
        after the reference's last expected contact, ``(|dp|^2 + rotation_weight |dr|^2 + articulation_weight
        |da|^2) / dt^2`` (``dt`` the track's step); 0 on the window's first step, which has none before it
        in the rollout.

        Args:
            sensordata: (S, H, nsensordata) with H equal to the window's length.
            window: grid slice of the reference track.

        Returns:
            (S, H) rest term.
        """
        out = np.zeros(sensordata.shape[:2])
        after = self._release[window]
        if sensordata.shape[1] < 2 or not after[1:].any():
            return out
        qo = self.object_qpos(sensordata)
        step = self.scene.task.layout.error(qo[:, 1:], qo[:, :-1])
        out[:, 1:] = after[None, 1:] * self.squared(step) / self.track.dt**2
        return out

    def __call__(self, sensordata: np.ndarray, window: slice) -> dict[str, np.ndarray]:
        """Weighted cost terms per sample and step.

        Args:
            sensordata: (S, H, nsensordata) rollout sensors; row h is the state after h steps.
            window: the reference-track slice of the same H steps.

        Returns:
            dict of the weighted terms ``object``, ``contact``, ``velocity``, ``release``, ``surface``,
            ``clearance``, ``rest``, each (S, H).
        """
        tr = self.track
        obj = self.squared(self.scene.task.layout.error(self.object_qpos(sensordata), tr.object_qpos[window]))
        v = sensordata[..., self._vel]
        vel = np.einsum("shi,shi->sh", v, v)
        con = self.contact_term(sensordata, window) if self.lambda_c > 0.0 else np.zeros_like(obj)
        release = np.zeros_like(obj)
        if self.release_weight > 0.0:
            found = sensordata[..., self._found].sum(axis=-1)
            release = self.lambda_o * self.release_weight * found * self._release[window]
        surface = np.zeros_like(obj)
        if self.surface_weight > 0.0:
            surface = self.lambda_c * self.surface_weight * self.surface_term(sensordata, window)
        clearance = np.zeros_like(obj)
        if self.clearance_weight > 0.0:
            clearance = self.lambda_c * self.clearance_weight * self.clearance_term(sensordata, window)
        rest = np.zeros_like(obj)
        if self.rest_weight > 0.0:
            rest = self.lambda_o * self.rest_weight * self.rest_term(sensordata, window)
        return {
            "object": self.lambda_o * obj,
            "contact": self.lambda_c * con,
            "velocity": self.lambda_v * vel,
            "release": release,
            "surface": surface,
            "clearance": clearance,
            "rest": rest,
        }
