"""Sampler spaces: the coordinates in which control points are perturbed.

Both spaces describe the hand's ``J`` joint targets by ``M`` B-spline control points over the control
time of the slowed reference. A space's decision variable ``theta`` has shape (M, d): the first
``num_root`` columns are the wrist (root) DOFs in joint space; the remaining ``d - num_root`` columns
are the finger coordinates of the space:

- :class:`PCASplineSpace` (the paper): finger control points in the coordinates of the principal
  components of the reference finger curves, ``u = P^T z + p`` (Eq. 3). With ``whiten`` the PC
  coordinates are divided by each component's spread over the reference, so noise of a given sigma
  moves each synergy in proportion to how much it moves in the demonstration.
- :class:`JointSplineSpace` (the paper's ablation): finger control points in joint space.

Because a clamped B-spline's basis functions sum to one and the PC map is affine, mapping control
points through ``P^T z + p`` is exact: the curve of the mapped points is the mapped curve.
"""

from __future__ import annotations

from typing import Annotated

import numpy as np

from contactmpc.control.release import ReleaseSchedule, time_window
from contactmpc.reference.bspline import UniformBSpline
from contactmpc.reference.pca import PCABasis, PCACurves
from contactmpc.validate import ConfigError, Ge, Gt, OneOf, checked


class SplineSpace:
    """Base class: B-spline control points of root + finger coordinates.

    Args:
        sigma2: noise variance on every finger coordinate (PC or joint), in the space's units.
        root_sigma2: noise variance on the root (wrist) DOFs; the paper uses 0. With
            ``root_rotation_sigma2`` set, it is the variance of the wrist *slides* only (m^2).
        whiten: divide PC coordinates by their spread over the reference (PCA space only).
        num_components: number of PCs kept (PCA space only); ``None`` keeps one per finger joint.
        root_rotation_sigma2: noise variance on the wrist *hinges* (rad^2): the root DOFs after the first
            three (the floating wrist's x, y, z slides); ``None``: ``root_sigma2``, as for the slides.
        root_window: ``(start, end)`` seconds relative to the first expected contact: sample the wrist
            only on the control points whose support meets that interval (the paper's future work:
            the wrist free while contact is being acquired, the reference's afterwards); ``None``: on
            every control point.
        root_span: ``(start, end)`` seconds: sample the wrist also on the control points whose support
            meets the span from ``start`` after the first expected contact to ``end`` after the last (where
            the reference lets go; the end of the spline's domain where it ends held): the wrist free all
            the while the object is held, so the planner can move the palm onto it while it is carried
            (not the paper's). With it and no ``root_window`` the wrist is sampled only there; ``None``:
            no span.
        release: what the nominal and the noise do after the reference's last expected contact,
            where it lets go (:class:`~contactmpc.control.release.ReleaseSchedule`); ``None`` (the
            paper): the same as before it.
        noise_ramp: the noise grows along the planning horizon, linearly from 1x at the planning time
            to this factor at the horizon's end, at each control point's Greville abscissa (judo's
            noise ramp, :meth:`horizon_noise`); 1 (the paper): the same noise over the horizon.
    """

    @checked
    def __init__(
        self,
        sigma2: Annotated[float, Ge(0)],
        root_sigma2: Annotated[float, Ge(0)] = 0.0,
        whiten: bool = False,
        num_components: Annotated[int, Ge(1)] | None = None,
        root_rotation_sigma2: Annotated[float, Ge(0)] | None = None,
        root_window: tuple[float, float] | None = None,
        release: ReleaseSchedule | None = None,
        noise_ramp: Annotated[float, Gt(0)] = 1.0,
        root_span: tuple[float, float] | None = None,
    ) -> None:
        self.noise_ramp = float(noise_ramp)
        self.root_span = None if root_span is None else tuple(float(v) for v in root_span)
        if self.root_span is not None and len(self.root_span) != 2:
            raise ConfigError(f"sampler.root_span must be (start, end), got {root_span}")
        if release is not None and not isinstance(release, ReleaseSchedule):  # a node with no _target_
            raise ConfigError(
                f"sampler.release sets {', '.join(sorted(release)) or 'nothing'} but no release schedule is "
                "selected (place=wrist's window is one of its options): choose release=scheduled, flat, ..."
            )
        self.release = ReleaseSchedule() if release is None else release
        self.root_window = time_window("sampler.root_window", root_window)
        self.sigma2 = float(sigma2)
        self.root_sigma2 = float(root_sigma2)
        self.root_rotation_sigma2 = None if root_rotation_sigma2 is None else float(root_rotation_sigma2)
        self.whiten = bool(whiten)
        self.num_components = num_components
        self.ranges: np.ndarray | None = None
        self.num_root = 0
        self.num_fingers = 0

    # --- set-up -------------------------------------------------------------------------------
    def fit(
        self,
        spline: UniformBSpline,
        times: np.ndarray,
        hand_qpos: np.ndarray,
        ranges: np.ndarray,
        num_root: int,
        meta: dict | None = None,
        last_contact: float | None = None,
        release_direction: np.ndarray | None = None,
    ) -> np.ndarray:
        """Fit the space to the reference and return the nominal control points.

        Args:
            spline: the B-spline over control time.
            times: (T,) control times of the reference frames.
            hand_qpos: (T, J) reference hand configurations (root DOFs first).
            ranges: (J, 2) actuator control ranges; joint targets are clipped to them.
            num_root: number of root (wrist) DOFs, the first columns of ``hand_qpos``.
            meta: the reference's ``meta`` (a space may take more than the curves from it, e.g. the
                PCA that came with the paper's data).
            last_contact: control time (s) of the reference's last expected contact where it lets go
                (``None``: it ends held): the release schedule's nominal from there.
            release_direction: (3,) world unit vector the wrist backs off along with the schedule's
                ``backoff`` (the first three root DOFs are slides along world x, y, z); required then.

        Returns:
            (M, d) nominal control points ``theta``.
        """
        self.meta = {} if meta is None else meta
        self.ranges = np.asarray(ranges, float)
        self.num_root = int(num_root)
        self.num_fingers = hand_qpos.shape[1] - self.num_root
        root = hand_qpos[:, : self.num_root]
        root_cp = spline.fit(times, self.release.root_nominal(times, root, last_contact, release_direction))
        fingers = hand_qpos[:, self.num_root :]
        if self.release.opens(last_contact):
            # the nominal opens; the space (a PCA) stays the reference's own
            ranges = self.ranges[self.num_root :]
            opening = self.release.finger_nominal(times, fingers, last_contact, ranges)
            finger_cp = self._fit_fingers(spline, times, opening, fingers)
        else:
            finger_cp = self._fit_fingers(spline, times, fingers)
        return np.concatenate([root_cp, finger_cp], axis=-1)

    def _fit_fingers(
        self, spline: UniformBSpline, times: np.ndarray, fingers: np.ndarray, space: np.ndarray | None = None
    ) -> np.ndarray:
        """(M, d - num_root) finger control points of the curves ``fingers`` (T, F), in the coordinates
        fitted to ``space`` (T, F; ``None``: to ``fingers`` themselves)."""
        raise NotImplementedError

    def finger_joints(self, finger_theta: np.ndarray) -> np.ndarray:
        """Map finger coordinates (..., d - num_root) to finger joint values (..., num_fingers)."""
        raise NotImplementedError

    @property
    def dim(self) -> int:
        """Number of columns ``d`` of ``theta``."""
        raise NotImplementedError

    @property
    def noise_std(self) -> np.ndarray:
        """(d,) standard deviation of the sampling noise per column of ``theta``."""
        std = np.full(self.dim, np.sqrt(self.sigma2))
        std[: self.num_root] = np.sqrt(self.root_sigma2)
        if self.root_rotation_sigma2 is not None:
            std[3 : self.num_root] = np.sqrt(self.root_rotation_sigma2)
        return std

    def point_noise_std(
        self, spline: UniformBSpline, first_contact: float | None, last_contact: float | None = None
    ) -> np.ndarray:
        """The noise per control point: :attr:`noise_std` (d,), or with ``root_window`` or the release
        schedule's ``window`` an (M, d) array whose root columns are 0 on the control points that touch
        neither the root window around ``first_contact`` nor the release window around
        ``last_contact`` nor the ``root_span`` between them (s, control time; ``first_contact`` ``None``: no
        contact expected, the wrist is never sampled);
        with the schedule's ``noise`` the rows of the control points whose support lies after
        ``last_contact`` scaled by it (``last_contact`` ``None``: the reference ends held, no change)."""
        std = self.noise_std
        release_window, release_noise = self.release.window, self.release.noise
        quieter = release_noise != 1.0 and last_contact is not None
        windowed = self.root_window is not None or release_window is not None or self.root_span is not None
        if not windowed and not quieter:
            return std
        out = np.tile(std, (spline.num_control_points, 1))
        if windowed:
            keep = np.zeros(spline.num_control_points, bool)
            for window, at in ((self.root_window, first_contact), (release_window, last_contact)):
                if window is not None and at is not None:
                    start, end = (at + w for w in window)
                    keep[spline.window_indices(start, end - start)] = True
            if self.root_span is not None and first_contact is not None:
                start = first_contact + self.root_span[0]
                end = (spline.domain[1] if last_contact is None else last_contact) + self.root_span[1]
                if end > start:
                    keep[spline.window_indices(start, end - start)] = True
            out[~keep, : self.num_root] = 0.0
        if quieter:  # the control points whose support lies after the last contact
            out[spline.knots[: spline.num_control_points] >= last_contact - 1e-9] *= release_noise
        return out

    def horizon_noise(
        self, spline: UniformBSpline, window: np.ndarray, t: float, horizon: float
    ) -> np.ndarray | None:
        """(Mw, 1) the factor :attr:`noise_ramp` puts on the noise of the control points ``window``
        (Mw,) when planning at control time ``t`` over ``horizon`` seconds: ``1 + (noise_ramp - 1) x``,
        ``x`` the control point's Greville abscissa (the mean of its ``degree`` inner knots: where it
        pulls the curve most) as a fraction of the horizon, clipped to [0, 1]; ``None`` for
        ``noise_ramp`` 1."""
        if self.noise_ramp == 1.0:
            return None
        x = np.clip((spline.greville(window) - t) / horizon, 0.0, 1.0)
        return (1.0 + (self.noise_ramp - 1.0) * x)[:, None]

    # --- evaluation ---------------------------------------------------------------------------
    def joint_control_points(self, theta: np.ndarray) -> np.ndarray:
        """Control points in joint space.

        Args:
            theta: (..., M, d) control points of this space.

        Returns:
            (..., M, J) joint-space control points.
        """
        root, fingers = theta[..., : self.num_root], theta[..., self.num_root :]
        return np.concatenate([root, self.finger_joints(fingers)], axis=-1)

    def controls(self, theta: np.ndarray, basis: np.ndarray) -> np.ndarray:
        """Joint targets from control points through a precomputed basis.

        Args:
            theta: (..., M, d) control points.
            basis: (H, M) B-spline basis at the H query times (``spline.basis(times)``).

        Returns:
            (..., H, J) joint targets, clipped to the actuators' ranges.
        """
        u = basis @ self.joint_control_points(theta)
        return np.clip(u, self.ranges[:, 0], self.ranges[:, 1], out=u)


class JointSplineSpace(SplineSpace):
    """Finger control points in joint space (the paper's ablation, sigma^2 = 60 deg per DOF)."""

    def _fit_fingers(
        self, spline: UniformBSpline, times: np.ndarray, fingers: np.ndarray, space: np.ndarray | None = None
    ) -> np.ndarray:
        return spline.fit(times, fingers)

    def finger_joints(self, finger_theta: np.ndarray) -> np.ndarray:
        return finger_theta

    @property
    def dim(self) -> int:
        return self.num_root + self.num_fingers


class PCASplineSpace(SplineSpace):
    """Finger control points in the principal components of the reference finger curves (paper).

    Args:
        basis: ``fit``: the PCA of the reference's finger curves (computed here); ``reference``: the
            PCA that came with the reference (``meta["paper_pca"]``: the authors' ``center`` and
            components, imported from their ``.pcmexp``), used as it is (the PC-curves are still fitted
            to the reference's finger curves in it); ``reference_as_code``: the same, but PC coordinates
            are mapped back to joints as the authors' code does, with the mirrored upper triangle of
            their component matrix (``meta["paper_pca"]["code_components"]``), so even the nominal
            fingers leave the reference (by up to 1.2 rad on their data).
        frozen_components: the first this many PCs get no noise. The authors' code lays its noise out
            over all 22 DOFs and adds block ``k`` to PC ``k``, so the six root blocks (zero noise) land on
            PCs 0-5: ``frozen_components=6`` reproduces it; 0 (the paper) perturbs every PC.
        sigma2, root_sigma2, whiten, num_components, root_rotation_sigma2, root_window, release,
            noise_ramp, root_span: see
            :class:`SplineSpace`.
    """

    pca: PCABasis

    @checked
    def __init__(
        self,
        sigma2: Annotated[float, Ge(0)],
        root_sigma2: Annotated[float, Ge(0)] = 0.0,
        whiten: bool = False,
        num_components: Annotated[int, Ge(1)] | None = None,
        basis: Annotated[str, OneOf("fit", "reference", "reference_as_code")] = "fit",
        frozen_components: Annotated[int, Ge(0)] = 0,
        root_rotation_sigma2: Annotated[float, Ge(0)] | None = None,
        root_window: tuple[float, float] | None = None,
        release: ReleaseSchedule | None = None,
        noise_ramp: Annotated[float, Gt(0)] = 1.0,
        root_span: tuple[float, float] | None = None,
    ) -> None:
        super().__init__(
            sigma2,
            root_sigma2,
            whiten,
            num_components,
            root_rotation_sigma2,
            root_window,
            release,
            noise_ramp,
            root_span,
        )
        self.basis = basis
        self.frozen_components = int(frozen_components)

    @property
    def noise_std(self) -> np.ndarray:
        std = super().noise_std
        std[self.num_root : self.num_root + self.frozen_components] = 0.0
        return std

    def _fit_fingers(
        self, spline: UniformBSpline, times: np.ndarray, fingers: np.ndarray, space: np.ndarray | None = None
    ) -> np.ndarray:
        if self.basis != "fit":
            self.pca = self._reference_basis(fingers if space is None else space)
            return spline.fit(times, self.pca.to_pc(fingers))
        # PC-curves fitted with the same M (paper §II-A).
        base = fingers if space is None else space
        curves = PCACurves.fit(spline, times, base, num_components=self.num_components, whiten=self.whiten)
        self.pca = curves.pca
        if space is None:
            return curves.pc_control_points
        return spline.fit(times, self.pca.to_pc(fingers))

    def _reference_basis(self, fingers: np.ndarray) -> PCABasis:
        given = self.meta.get("paper_pca")
        if not given:
            raise ValueError(
                f"sampler.basis={self.basis}: the reference has no PCA of its own (meta['paper_pca'], "
                "which the paper tasks' references carry); use sampler.basis=fit"
            )
        center = np.asarray(given["center"], float)
        components = np.asarray(given["components"], float)[: self.num_components]
        if center.shape != (fingers.shape[1],) or components.shape[1:] != center.shape:
            raise ValueError(
                f"the reference's PCA has centre {center.shape} and components {components.shape}, "
                f"but the hand has {fingers.shape[1]} finger joints"
            )
        spread = np.maximum(((fingers - center) @ components.T).std(axis=0), 1e-6)
        decoder = None
        if self.basis == "reference_as_code":
            decoder = np.asarray(given["code_components"], float)[: self.num_components]
        return PCABasis(center, components, spread, whiten=self.whiten, decoder=decoder)

    def finger_joints(self, finger_theta: np.ndarray) -> np.ndarray:
        return self.pca.from_pc(finger_theta)

    @property
    def dim(self) -> int:
        return self.num_root + self.pca.num_components
