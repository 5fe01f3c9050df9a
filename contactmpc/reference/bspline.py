r"""Uniform clamped B-splines evaluated through a basis matrix.

A curve with ``M`` control points :math:`c_j \in \mathbb{R}^D` on the domain :math:`[t_0, t_1]` is

.. math::  x(t) = \sum_{j=0}^{M-1} N_{j,k}(t)\, c_j,

with :math:`N_{j,k}` the degree-``k`` B-spline basis functions of a *clamped uniform* knot vector:
``k + 1`` copies of :math:`t_0`, ``M - k - 1`` interior knots equally spaced with step
:math:`h = (t_1 - t_0) / (M - k)`, and ``k + 1`` copies of :math:`t_1`. The curve interpolates its first
and last control points and is :math:`C^{k-1}` everywhere (:math:`C^2` for the default cubic).

Because the curve is linear in its control points, sampling it at ``N`` times is one matrix product
with the basis matrix ``B (N, M)``; a whole batch of perturbed control points ``(S, M, D)`` becomes a
batch of curves ``(S, N, D)`` with one ``B @ C``. The basis functions of a clamped spline also sum to
one at every time (partition of unity), so adding the same vector to every control point adds that
vector to the curve.

Control point ``j`` is supported on :math:`[\tau_j, \tau_{j+k+1}]` (:math:`\tau` the knot vector), i.e. on
at most ``k + 1`` knot spans, which is what makes the planner's search space small: only the control
points whose support meets the planning window ``[t, t + T]`` are perturbed
(:meth:`UniformBSpline.window_indices`).
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import BSpline

__all__ = ["UniformBSpline"]


class UniformBSpline:
    """Clamped uniform B-spline basis of a given degree on a time domain.

    The object holds only the knot vector; control points are passed to each call, so one instance
    serves every curve (joint, PC or batch of samples) that shares ``M`` and the domain.

    Times outside ``[t0, t1]`` are **clipped** to the domain by :meth:`basis` and :meth:`evaluate`:
    the curve holds its end values before ``t0`` and after ``t1``. The controller relies on this when
    its planning window runs past the end of the reference.

    Args:
        num_control_points: ``M``, the number of control points per curve; at least ``degree + 1``.
        domain: ``(t0, t1)`` time domain in seconds, ``t0 < t1``.
        degree: spline degree ``k`` (3 = cubic, the default); at least 1.

    Raises:
        ValueError: on a degree below 1, too few control points or an empty/non-finite domain.
    """

    def __init__(self, num_control_points: int, domain: tuple[float, float], degree: int = 3) -> None:
        degree = int(degree)
        num_control_points = int(num_control_points)
        t0, t1 = (float(v) for v in domain)
        if degree < 1:
            raise ValueError(f"degree must be >= 1, got {degree}")
        if num_control_points < degree + 1:
            raise ValueError(
                f"num_control_points must be >= degree + 1 = {degree + 1}, got {num_control_points}"
            )
        if not (np.isfinite(t0) and np.isfinite(t1) and t0 < t1):
            raise ValueError(f"domain must be finite with t0 < t1, got ({t0}, {t1})")
        self._degree = degree
        self._num_control_points = num_control_points
        self._domain = (t0, t1)
        # linspace gives both ends once plus the M - k - 1 interior knots; pad each end to k + 1 copies.
        breaks = np.linspace(t0, t1, num_control_points - degree + 1)
        knots = np.concatenate([np.full(degree, t0), breaks, np.full(degree, t1)])
        knots.setflags(write=False)
        self._knots = knots

    # ------------------------------------------------------------------ properties
    @property
    def degree(self) -> int:
        """Spline degree ``k``."""
        return self._degree

    @property
    def num_control_points(self) -> int:
        """Number of control points ``M`` per curve."""
        return self._num_control_points

    @property
    def domain(self) -> tuple[float, float]:
        """Time domain ``(t0, t1)``."""
        return self._domain

    @property
    def knots(self) -> np.ndarray:
        """Clamped knot vector, shape ``(M + k + 1,)``, read-only."""
        return self._knots

    @property
    def knot_spacing(self) -> float:
        """Uniform interior knot step ``h = (t1 - t0) / (M - k)``."""
        t0, t1 = self._domain
        return (t1 - t0) / (self._num_control_points - self._degree)

    def __repr__(self) -> str:
        return (
            f"UniformBSpline(num_control_points={self._num_control_points}, "
            f"domain={self._domain}, degree={self._degree})"
        )

    # ------------------------------------------------------------------ evaluation
    def _clip(self, times: np.ndarray | float) -> np.ndarray:
        times = np.atleast_1d(np.asarray(times, dtype=np.float64))
        if times.ndim != 1:
            raise ValueError(f"times must be 1-D, got shape {times.shape}")
        if not np.all(np.isfinite(times)):
            raise ValueError("times must be finite")
        return np.clip(times, self._domain[0], self._domain[1])

    def basis(self, times: np.ndarray | float) -> np.ndarray:
        """Basis matrix ``B[n, j] = N_j(clip(times[n]))``.

        Built with :meth:`scipy.interpolate.BSpline.design_matrix`. Times outside the domain are
        clipped to it (the curve holds its end values). Each row sums to 1.

        Args:
            times: sample times, shape ``(N,)`` (a scalar is treated as ``(1,)``).

        Returns:
            Dense basis matrix, shape ``(N, M)``, float64.
        """
        x = self._clip(times)
        return BSpline.design_matrix(x, self._knots, self._degree).toarray()

    def derivative_basis(self, times: np.ndarray | float, nu: int = 1) -> np.ndarray:
        """Matrix of the ``nu``-th time derivatives of the basis functions.

        ``derivative_basis(times, nu) @ C`` is the ``nu``-th derivative of the curve with control
        points ``C``. Consistently with the clipping of :meth:`basis`, the rows of times strictly
        outside the domain are zero for ``nu >= 1`` (the clipped curve is constant there). At an
        interior knot the value is the one of the span that starts at the knot (right limit).

        Args:
            times: sample times, shape ``(N,)``.
            nu: derivative order, ``>= 0`` (0 gives :meth:`basis`).

        Returns:
            Shape ``(N, M)``, float64.
        """
        nu = int(nu)
        if nu < 0:
            raise ValueError(f"nu must be >= 0, got {nu}")
        if nu == 0:
            return self.basis(times)
        raw = np.atleast_1d(np.asarray(times, dtype=np.float64))
        x = self._clip(raw)
        num = self._num_control_points
        if nu > self._degree:
            return np.zeros((x.shape[0], num))
        spline = BSpline(self._knots, np.eye(num), self._degree, extrapolate=False)
        out = np.asarray(spline.derivative(nu)(x), dtype=np.float64)
        outside = (raw < self._domain[0]) | (raw > self._domain[1])
        out[outside] = 0.0
        return out

    def evaluate(self, control_points: np.ndarray, times: np.ndarray | float) -> np.ndarray:
        """Evaluate curves at ``times`` by one matrix product with the basis.

        Args:
            control_points: shape ``(..., M, D)``, batched over any leading axes (e.g. samples); a
                1-D ``(M,)`` array is one scalar curve.
            times: sample times, shape ``(N,)``; clipped to the domain.

        Returns:
            Curve values, shape ``(..., N, D)`` (``(N,)`` for 1-D control points).
        """
        cp = np.asarray(control_points, dtype=np.float64)
        self._check_control_points(cp)
        basis = self.basis(times)
        if cp.ndim == 1:
            return basis @ cp
        return np.matmul(basis, cp)

    def fit(self, times: np.ndarray, values: np.ndarray, smoothing: float = 0.0) -> np.ndarray:
        r"""Least-squares control points of the curve(s) through sampled values.

        Solves :math:`\min_C \|B C - V\|^2 + s \|C\|^2` with ``np.linalg.lstsq`` (the ridge term only
        when ``smoothing = s > 0``). With ``s = 0`` and at least one sample in the interior of every
        basis function's support (Schoenberg-Whitney, e.g. dense uniform samples with ``N >= M``), the
        solution is unique and data generated from a spline are recovered exactly (to rounding).

        Args:
            times: sample times, shape ``(N,)``; clipped to the domain.
            values: sampled values, shape ``(N, D)`` or ``(N,)``.
            smoothing: ridge weight ``s >= 0`` (a tiny value regularises under-determined fits).

        Returns:
            Control points, shape ``(M, D)`` (``(M,)`` for 1-D values).
        """
        basis = self.basis(times)
        vals = np.asarray(values, dtype=np.float64)
        if vals.shape[0] != basis.shape[0] or vals.ndim not in (1, 2):
            raise ValueError(
                f"values must have shape (N,) or (N, D) with N = {basis.shape[0]}, got {vals.shape}"
            )
        if smoothing < 0:
            raise ValueError(f"smoothing must be >= 0, got {smoothing}")
        if smoothing > 0:
            num = self._num_control_points
            basis = np.vstack([basis, np.sqrt(smoothing) * np.eye(num)])
            pad = np.zeros((num,) + vals.shape[1:])
            vals = np.concatenate([vals, pad], axis=0)
        cp, *_ = np.linalg.lstsq(basis, vals, rcond=None)
        return cp

    # ------------------------------------------------------------------ locality
    def support(self, j: int) -> tuple[float, float]:
        """Support interval of control point ``j``: ``(knots[j], knots[j + k + 1])``.

        ``N_j`` is positive on the open interval and zero outside the closed one; at the clamped
        ends ``N_0(t0) = N_{M-1}(t1) = 1``.

        Args:
            j: control point index in ``[0, M)``.

        Returns:
            ``(t_start, t_end)`` in seconds.
        """
        j = int(j)
        if not 0 <= j < self._num_control_points:
            raise IndexError(f"control point index {j} out of range [0, {self._num_control_points})")
        return float(self._knots[j]), float(self._knots[j + self._degree + 1])

    def greville(self, indices: np.ndarray) -> np.ndarray:
        """The Greville abscissae (s) of the control points ``indices``: the mean of each one's ``degree``
        inner knots, where it pulls the curve most."""
        k = self._degree
        return np.array([self._knots[j + 1 : j + k + 1].mean() for j in indices])

    def window_indices(self, t: float, horizon: float) -> np.ndarray:
        """Indices of the control points that influence the curve on ``[t, t + horizon]``.

        The window is first clipped to the domain (consistent with the clipping of :meth:`basis`).
        For a window of positive length ``[a, b]`` these are the ``j`` whose support meets it with
        non-zero measure, ``knots[j] < b`` and ``knots[j + k + 1] > a``: exactly the ``j`` whose basis
        function is non-zero somewhere on the window. A support that only touches the window at an
        interior knot is excluded (its basis function is zero there). A window of zero length (``horizon
        = 0``, or a window lying entirely past an end of the domain) reduces to the point ``a``, and
        the result is the ``j`` with ``N_j(a) != 0``: ``knots[j] < a < knots[j + k + 1]``, or ``{0}``
        at ``t0`` and ``{M - 1}`` at ``t1``.

        Args:
            t: window start in seconds.
            horizon: window length ``T >= 0`` in seconds.

        Returns:
            Sorted, contiguous control point indices, int64, shape ``(n,)`` with ``n >= 1``.
        """
        t = float(t)
        horizon = float(horizon)
        if not (np.isfinite(t) and np.isfinite(horizon)) or horizon < 0:
            raise ValueError(f"window must be finite with horizon >= 0, got t={t}, horizon={horizon}")
        t0, t1 = self._domain
        a = min(max(t, t0), t1)
        b = min(max(t + horizon, t0), t1)
        starts = self._knots[: self._num_control_points]
        ends = self._knots[self._degree + 1 :]
        if b > a:
            mask = (starts < b) & (ends > a)
        elif a <= t0:
            return np.array([0], dtype=np.int64)
        elif a >= t1:
            return np.array([self._num_control_points - 1], dtype=np.int64)
        else:
            mask = (starts < a) & (ends > a)
        return np.flatnonzero(mask).astype(np.int64)

    # ------------------------------------------------------------------ helpers
    def _check_control_points(self, cp: np.ndarray) -> None:
        m_axis = 0 if cp.ndim == 1 else cp.ndim - 2
        if cp.ndim == 0 or cp.shape[m_axis] != self._num_control_points:
            raise ValueError(
                f"control_points must have shape (..., M, D) or (M,) with M = "
                f"{self._num_control_points}, got {cp.shape}"
            )
