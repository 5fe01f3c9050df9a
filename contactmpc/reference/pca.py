r"""PCA of the finger joint curves and B-spline "PC-curves" (paper §II-A, Eq. 3).

With the data mean :math:`p \in \mathbb{R}^D`, the orthonormal components
:math:`P \in \mathbb{R}^{k \times D}` (rows ordered by decreasing variance) and the per-component
spread :math:`s \in \mathbb{R}^k`, a joint vector :math:`q` and its PC coordinates :math:`z` are related by

.. math::  z = (q - p) P^\top \oslash s, \qquad q = (z \odot s) P + p,

where the division/multiplication by :math:`s` happens only when whitening (otherwise :math:`s`
is replaced by ones). The paper's control law :math:`u(t) = P^\top [B_M(PC_i)(t)]_i + p` is
:meth:`PCACurves.joint_curves`.

Because both the spline map (:math:`C \mapsto B C`) and the PCA map are affine and the basis
functions of a clamped B-spline sum to one, mapping PC *control points* to joint control points with
the same affine map is exact: :math:`B\,((Z \odot s) P + \mathbf{1} p^\top) = (B Z \odot s) P + \mathbf{1}
p^\top`, since :math:`B \mathbf{1} = \mathbf{1}`. The sampler can therefore perturb PC control points
and hand joint control points to the policy with no refit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from contactmpc.reference.bspline import UniformBSpline

__all__ = ["PCABasis", "PCACurves"]


class PCABasis:
    """Principal components of joint configurations (rows = time samples).

    Build it with :meth:`fit`; the constructor takes the fitted arrays as they are.

    Args:
        mean: ``p``, shape ``(D,)``.
        components: ``P``, shape ``(k, D)``, orthonormal rows ordered by decreasing variance.
        spread: per-component standard deviation over the data, shape ``(k,)``, already floored
            at a small positive value (used to whiten).
        whiten: if True, PC coordinates are divided by ``spread`` (unit variance over the data), so
            an isotropic noise in PC coordinates is shaped like the demonstration's synergies.
        variance: raw (unfloored) per-component variance over the data, shape ``(k,)``; defaults to
            ``spread**2``.
        decoder: ``(k, D)``, the matrix :meth:`from_pc` maps PC coordinates with in place of the
            components (``to_pc`` keeps the components). Default: the components. The paper authors' code
            reconstructs with the mirrored upper triangle of its component matrix, not its transpose
            (:func:`contactmpc.reference.paper.evaluation.code_component_matrix`); this reproduces that.
    """

    def __init__(
        self,
        mean: np.ndarray,
        components: np.ndarray,
        spread: np.ndarray,
        whiten: bool = False,
        variance: np.ndarray | None = None,
        decoder: np.ndarray | None = None,
    ) -> None:
        mean = np.asarray(mean, dtype=np.float64)
        components = np.asarray(components, dtype=np.float64)
        spread = np.asarray(spread, dtype=np.float64)
        if mean.ndim != 1 or components.ndim != 2 or components.shape[1] != mean.shape[0]:
            raise ValueError(
                f"expected mean (D,) and components (k, D), got {mean.shape} and {components.shape}"
            )
        if spread.shape != (components.shape[0],) or not np.all(spread > 0):
            raise ValueError(f"spread must be positive with shape ({components.shape[0]},)")
        self._mean = mean
        self._components = components
        self._spread = spread
        self._whiten = bool(whiten)
        self._variance = spread**2 if variance is None else np.asarray(variance, dtype=np.float64)
        self._decoder = components if decoder is None else np.asarray(decoder, dtype=np.float64)
        if self._decoder.shape != components.shape:
            raise ValueError(f"decoder must have the components' shape {components.shape}")
        for arr in (self._mean, self._components, self._spread, self._variance, self._decoder):
            arr.setflags(write=False)

    @classmethod
    def fit(
        cls,
        curves: np.ndarray,
        num_components: int | None = None,
        whiten: bool = False,
        min_spread: float = 1e-6,
    ) -> PCABasis:
        """Fit the PCA of sampled joint curves by SVD.

        The spread is the population standard deviation (``ddof = 0``) of each PC coordinate over the
        samples. Components of zero variance (more components than samples, or joints that never
        move) are still an orthonormal completion of the basis from the full SVD; their spread is
        floored at ``min_spread`` so that whitening neither divides by zero nor lets noise move
        directions the demonstration never uses by more than ``min_spread`` per unit of noise.
        Signs are fixed so that the entry of largest magnitude of each component is positive
        (first such entry on ties), which makes the result reproducible.

        Args:
            curves: ``Q``, shape ``(N, D)``, rows are time samples.
            num_components: ``k`` in ``[1, D]``; default all ``D`` components.
            whiten: see the class docstring.
            min_spread: floor of ``spread`` (in the units of ``curves``, radians for joints).

        Returns:
            The fitted basis.
        """
        q = np.asarray(curves, dtype=np.float64)
        if q.ndim != 2 or q.shape[0] < 1 or q.shape[1] < 1:
            raise ValueError(f"curves must have shape (N, D) with N, D >= 1, got {q.shape}")
        if not np.all(np.isfinite(q)):
            raise ValueError("curves must be finite")
        num_samples, dim = q.shape
        k = dim if num_components is None else int(num_components)
        if not 1 <= k <= dim:
            raise ValueError(f"num_components must be in [1, {dim}], got {num_components}")
        if min_spread <= 0:
            raise ValueError(f"min_spread must be > 0, got {min_spread}")
        mean = q.mean(axis=0)
        _, sing, vt = np.linalg.svd(q - mean, full_matrices=True)
        sing = np.concatenate([sing, np.zeros(dim - sing.shape[0])])
        variance = sing**2 / num_samples
        pivot = np.argmax(np.abs(vt), axis=1)
        signs = np.where(vt[np.arange(dim), pivot] < 0, -1.0, 1.0)
        vt = vt * signs[:, None]
        spread = np.maximum(np.sqrt(variance), min_spread)
        return cls(mean, vt[:k], spread[:k], whiten=whiten, variance=variance[:k])

    # ------------------------------------------------------------------ properties
    @property
    def mean(self) -> np.ndarray:
        """Mean ``p``, shape ``(D,)``."""
        return self._mean

    @property
    def components(self) -> np.ndarray:
        """Components ``P``, shape ``(k, D)``, orthonormal rows."""
        return self._components

    p = mean
    P = components

    @property
    def spread(self) -> np.ndarray:
        """Per-component standard deviation over the data (floored), shape ``(k,)``."""
        return self._spread

    @property
    def variance(self) -> np.ndarray:
        """Raw per-component variance over the data, shape ``(k,)``."""
        return self._variance

    @property
    def whiten(self) -> bool:
        """Whether PC coordinates are divided by ``spread``."""
        return self._whiten

    @property
    def num_components(self) -> int:
        """Number of components ``k``."""
        return self._components.shape[0]

    @property
    def dim(self) -> int:
        """Joint space dimension ``D``."""
        return self._components.shape[1]

    @property
    def scaled_components(self) -> np.ndarray:
        """Linear part ``W`` of :meth:`from_pc` (``from_pc(z) = z @ W + p``), shape ``(k, D)``.

        ``W = diag(spread) P`` when whitening, else ``P`` (``P`` = the ``decoder``, by default the
        components). A PC-space perturbation ``dz`` moves the joints by ``dz @ W``.
        """
        if self._whiten:
            return self._spread[:, None] * self._decoder
        return self._decoder

    def __repr__(self) -> str:
        return f"PCABasis(dim={self.dim}, num_components={self.num_components}, whiten={self._whiten})"

    # ------------------------------------------------------------------ maps
    def to_pc(self, q: np.ndarray) -> np.ndarray:
        """Joint configurations to PC coordinates.

        Args:
            q: shape ``(..., D)``.

        Returns:
            ``z = (q - p) @ P.T`` (divided by ``spread`` when whitening), shape ``(..., k)``.
        """
        q = np.asarray(q, dtype=np.float64)
        if q.ndim < 1 or q.shape[-1] != self.dim:
            raise ValueError(f"expected shape (..., {self.dim}), got {q.shape}")
        z = (q - self._mean) @ self._components.T
        return z / self._spread if self._whiten else z

    def from_pc(self, z: np.ndarray) -> np.ndarray:
        """PC coordinates to joint configurations.

        Args:
            z: shape ``(..., k)``.

        Returns:
            ``q = z @ W + p`` with ``W`` = :attr:`scaled_components`, shape ``(..., D)``.
        """
        z = np.asarray(z, dtype=np.float64)
        if z.ndim < 1 or z.shape[-1] != self.num_components:
            raise ValueError(f"expected shape (..., {self.num_components}), got {z.shape}")
        return z @ self.scaled_components + self._mean


@dataclass(frozen=True)
class PCACurves:
    """B-spline PC-curves of the finger motion: the paper's nominal policy (Eq. 3).

    Attributes:
        spline: the shared basis (``M`` control points, the reference's time domain).
        pca: the PCA of the sampled finger curves.
        pc_control_points: PC control points, shape ``(M, k)``.
    """

    spline: UniformBSpline
    pca: PCABasis
    pc_control_points: np.ndarray

    @classmethod
    def fit(
        cls,
        spline: UniformBSpline,
        times: np.ndarray,
        curves: np.ndarray,
        num_components: int | None = None,
        whiten: bool = False,
        smoothing: float = 0.0,
        min_spread: float = 1e-6,
    ) -> PCACurves:
        """Fit the PCA of ``curves``, project them to PC-curves and fit their control points.

        Args:
            spline: basis with ``M`` control points (the same ``M`` as the joint curves).
            times: sample times, shape ``(N,)``.
            curves: finger joint curves, shape ``(N, D)``.
            num_components: ``k``; default ``D``.
            whiten: divide PC coordinates by their spread over the data.
            smoothing: ridge weight of the spline fit (:meth:`UniformBSpline.fit`). The identity
                ``joint_control_points(fit) == spline.fit(curves)`` holds exactly only for ``0``.
            min_spread: floor of the PC spread.

        Returns:
            The fitted PC-curves.
        """
        pca = PCABasis.fit(curves, num_components=num_components, whiten=whiten, min_spread=min_spread)
        pc_curves = pca.to_pc(curves)
        pc_cp = spline.fit(times, pc_curves, smoothing=smoothing)
        pc_cp.setflags(write=False)
        return cls(spline=spline, pca=pca, pc_control_points=pc_cp)

    def _cp(self, pc_control_points: np.ndarray | None) -> np.ndarray:
        return self.pc_control_points if pc_control_points is None else np.asarray(pc_control_points)

    def joint_control_points(self, pc_control_points: np.ndarray | None = None) -> np.ndarray:
        """Joint-space control points of PC control points (exact, see the module docstring).

        Args:
            pc_control_points: shape ``(..., M, k)``; default the fitted ones.

        Returns:
            Shape ``(..., M, D)``: ``pca.from_pc`` applied to every control point.
        """
        return self.pca.from_pc(self._cp(pc_control_points))

    def pc_curves(self, times: np.ndarray, pc_control_points: np.ndarray | None = None) -> np.ndarray:
        """Evaluate the PC-curves ``B_M(PC_i)(t)``.

        Args:
            times: shape ``(N,)``, clipped to the domain.
            pc_control_points: shape ``(..., M, k)``; default the fitted ones.

        Returns:
            Shape ``(..., N, k)``.
        """
        return self.spline.evaluate(self._cp(pc_control_points), times)

    def joint_curves(self, times: np.ndarray, pc_control_points: np.ndarray | None = None) -> np.ndarray:
        """Evaluate the joint curves ``u(t) = P^T [B_M(PC_i)(t)] + p`` (Eq. 3).

        Args:
            times: shape ``(N,)``, clipped to the domain.
            pc_control_points: shape ``(..., M, k)``; default the fitted ones.

        Returns:
            Shape ``(..., N, D)``.
        """
        return self.spline.evaluate(self.joint_control_points(pc_control_points), times)
