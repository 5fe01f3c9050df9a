r"""The authors' curves and PCs evaluated as their C++ does it (``mjpc/spline/bspline.h``,
``basisfunction.h``; ``mjpc/tasks/allegro/allegro.cc``).

Curves: ``BSplineCurve`` builds an open uniform basis on ``u`` in ``[0, 1]``: ``M - d + 1`` unique knots
``i / (M - d)``, the end ones with multiplicity ``d + 1``, i.e. the knot vector ``[0]*d + linspace(0, 1,
M - d + 1) + [1]*d`` (``M + d + 1`` knots; for the cubic ``[0]*3 + linspace(0, 1, M - 2) + [1]*3``).
This is exactly the knot vector of ``UniformBSpline(M, (0, 1), d)``, which :func:`value_column` uses. At
simulation time ``t`` the C++ evaluates every curve (hand, object and PC-curves alike) at

.. math::  u = \operatorname{fmod}(t, L) / L, \qquad L = \texttt{time} \cdot \texttt{slowdown},

with ``time`` taken from the *hand* file, ``u`` clamped to ``[0, 1]`` by ``BasisFunction::GetIndex``, and
takes the *value* column; the time column is never inverted (it only divides the velocity). The value is
then wrapped and converted to MuJoCo units by ``GetPositionAndVelocityInMeasurementUnits``
(:func:`to_mujoco_units`). Contacts are looked up per frame ``floor(t * 120 / slowdown) mod F``
(:func:`contact_frame_index`).

PCs (paper Eq. 3): joint angles ``= center + C^T p``. The C++ builds ``C^T`` with ``mju_transpose`` on
an aliased buffer, which is not a transpose; :func:`reconstruct_as_code` reproduces what the code
computes, :func:`reconstruct` what the paper states.

The curves and PCs come from :mod:`contactmpc.reference.paper.splines`.
"""

from __future__ import annotations

import math

import numpy as np

from contactmpc.reference.paper.splines import (
    MOCAP_FPS,
    ROTATION_UNITS,
    TRANSLATION_UNITS,
    PCSplines,
    SplineCurves,
)

__all__ = [
    "aliased_transpose",
    "code_component_matrix",
    "contact_frame_index",
    "evaluate",
    "reconstruct",
    "reconstruct_as_code",
    "spline_parameter",
    "time_column",
    "to_mujoco_units",
    "value_column",
]

_WRAP = {"radians": 2.0 * math.pi, "degrees": 360.0}


# ------------------------------------------------------------------------------------------- curves
def _times(t: np.ndarray | float, name: str) -> np.ndarray:
    arr = np.atleast_1d(np.asarray(t, dtype=np.float64))
    if arr.ndim != 1 or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, shape (N,), got shape {arr.shape}")
    return arr


def spline_parameter(t: np.ndarray | float, duration: float, slowdown: float) -> np.ndarray:
    r"""The authors' spline parameter :math:`u = \operatorname{fmod}(t, L) / L`, ``L = duration * slowdown``.

    Args:
        t: simulation times in seconds, shape ``(N,)``.
        duration: the hand file's ``time`` (seconds of the demonstration).
        slowdown: the task's slowdown factor (``allegro.h``: 8, 8, 7, 5).

    Returns:
        ``u``, shape ``(N,)``; in ``[0, 1)`` for ``t >= 0`` (the motion loops every ``L`` seconds).
    """
    duration, slowdown = float(duration), float(slowdown)
    if not (math.isfinite(duration) and duration > 0 and math.isfinite(slowdown) and slowdown > 0):
        raise ValueError(f"duration and slowdown must be finite and > 0, got {duration}, {slowdown}")
    loop = duration * slowdown
    return np.fmod(_times(t, "t"), loop) / loop


def _column(curves: SplineCurves, column: np.ndarray, u: np.ndarray | float) -> np.ndarray:
    # UniformBSpline clips u to [0, 1], as BasisFunction::GetIndex clamps it.
    return curves.basis.evaluate(column.T, _times(u, "u"))


def value_column(curves: SplineCurves, u: np.ndarray | float) -> np.ndarray:
    """The curves' values at spline parameters ``u`` (clamped to ``[0, 1]``), in the file's units.

    Args:
        curves: the curves (``M`` control points each).
        u: shape ``(N,)``.

    Returns:
        ``(N, n_curves)`` float64.
    """
    return _column(curves, curves.values, u)


def time_column(curves: SplineCurves, u: np.ndarray | float) -> np.ndarray:
    """The curves' time column at spline parameters ``u``: the mocap frame each ``u`` stands for.

    The authors' code never uses it to place a value in time (only to scale velocities); it shows how
    ``u`` maps to the demonstration's frames: from 0 to ``F - 1``, along the line ``u * (F - 1)`` in the
    authors' object and PC files, while some hand curves of ``stapler_staple_2`` and
    ``waterbottle_pour_1`` bend off it by up to about 7 frames (edited control points).

    Returns:
        ``(N, n_curves)`` float64, in mocap frames (unscaled by any slowdown).
    """
    return _column(curves, curves.times, u)


def evaluate(
    curves: SplineCurves, t: np.ndarray | float, slowdown: float, *, duration: float | None = None
) -> np.ndarray:
    """The curves' values at simulation times ``t`` as the authors' C++ computes them (file units).

    ``value_column(curves, spline_parameter(t, duration, slowdown))``.

    Args:
        curves: the curves.
        t: simulation times in seconds, shape ``(N,)``.
        slowdown: the task's slowdown factor.
        duration: the loop length before slowdown; the C++ takes it from the *hand* file for every
            curve set. Default: ``curves.duration``.

    Returns:
        ``(N, n_curves)`` float64, in the curves' units (see :func:`to_mujoco_units`).
    """
    length = curves.duration if duration is None else duration
    return value_column(curves, spline_parameter(t, length, slowdown))


def to_mujoco_units(curves: SplineCurves, values: np.ndarray) -> np.ndarray:
    """Convert evaluated values to metres and radians as ``GetPositionAndVelocityInMeasurementUnits`` does.

    Rotations are first wrapped, literally as the C++ loops do: while above ``+360`` degrees (``2 pi``
    for radians) subtract ``360`` (``2 pi``), while below ``-360`` add it; degrees are then scaled by
    ``pi / 180``. Translations are scaled (cm: 0.01, mm: 0.001). The wrap keeps values in
    ``[-360, 360]`` degrees, not in ``(-180, 180]``.

    Args:
        curves: the curves the values came from (for ``kind`` and ``units``).
        values: ``(..., n_curves)``.

    Returns:
        ``(..., n_curves)`` float64, a new array.
    """
    out = np.array(values, dtype=np.float64, copy=True)
    if out.ndim == 0 or out.shape[-1] != curves.num_curves:
        raise ValueError(f"values must have shape (..., {curves.num_curves}), got {out.shape}")
    for i, (kind, units) in enumerate(zip(curves.kind, curves.units, strict=True)):
        col = out[..., i]
        if kind == "translation":
            col *= TRANSLATION_UNITS[units]
            continue
        limit = _WRAP[units]
        while np.any(over := col > limit):
            col[over] -= limit
        while np.any(under := col < -limit):
            col[under] += limit
        col *= ROTATION_UNITS[units]
    return out


def contact_frame_index(
    t: np.ndarray | float, slowdown: float, num_frames: int, fps: float = MOCAP_FPS
) -> np.ndarray:
    """The contact frame the authors' code uses at simulation time ``t``: ``floor(t * fps / slowdown) % F``.

    Note that this maps ``u = t / L`` to frame ``u * F``, while the curves' time column maps it to
    ``u * (F - 1)``: the two clocks drift apart by up to one frame over the demonstration.

    Args:
        t: simulation times, ``>= 0``, shape ``(N,)``.
        slowdown: the task's slowdown factor.
        num_frames: ``F``, the number of contact frames (``totalFrames`` in ``allegro.h``).
        fps: the mocap frame rate.

    Returns:
        ``(N,)`` int64 frame indices.
    """
    times = _times(t, "t")
    if np.any(times < 0):
        raise ValueError("t must be >= 0")
    return np.floor(times * (fps / float(slowdown))).astype(np.int64) % int(num_frames)


# ---------------------------------------------------------------------------------------------- PCs
def reconstruct(pcs: PCSplines, p: np.ndarray) -> np.ndarray:
    """Joint angles from PC coordinates as the paper states (Eq. 3): ``center + C^T p``.

    Args:
        pcs: the PCA.
        p: PC coordinates, shape ``(..., k)`` (e.g. evaluated PC-curves ``(N, k)``).

    Returns:
        ``(..., D)`` float64.
    """
    p = np.asarray(p, dtype=np.float64)
    if p.ndim == 0 or p.shape[-1] != pcs.num_components:
        raise ValueError(f"p must have shape (..., {pcs.num_components}), got {p.shape}")
    return pcs.center + p @ pcs.components


def aliased_transpose(flat: np.ndarray, nr: int, nc: int) -> np.ndarray:
    """MuJoCo's ``mju_transpose(buf, buf, nr, nc)`` on one buffer, run literally.

    ``mju_transpose(res, mat, nr, nc)`` loops ``for i < nr: for j < nc: res[j*nr+i] = mat[i*nc+j]``;
    with ``res == mat`` later reads see earlier writes. For a square matrix the result keeps the upper
    triangle and mirrors it onto the lower one (``triu(A) + triu(A, 1).T``), e.g.
    ``[[0,1,2],[3,4,5],[6,7,8]] -> [[0,1,2],[1,4,5],[2,5,8]]``.

    Args:
        flat: the ``nr * nc`` row-major entries of the ``(nr, nc)`` matrix (any shape; copied).
        nr: rows.
        nc: columns.

    Returns:
        The buffer afterwards, flat ``(nr * nc,)`` (read it row-major as ``(nc, nr)``).
    """
    buf = np.array(flat, dtype=np.float64, copy=True).ravel()
    if buf.size != nr * nc:
        raise ValueError(f"need {nr * nc} entries, got {buf.size}")
    for i in range(nr):
        for j in range(nc):
            buf[j * nr + i] = buf[i * nc + j]
    return buf


def code_component_matrix(pcs: PCSplines) -> np.ndarray:
    """The ``(D, k)`` matrix the authors' code multiplies PC values with, in place of ``C^T``.

    ``allegro.cc`` appends every ``componentData`` to one buffer (``C`` row-major, ``(k, D)``), calls
    ``mju_transpose(buf, buf, k, D)`` and then ``mju_mulMatVec(out, buf, p, D, k)``. For the authors'
    square ``C`` (``k = D = 16``) this is ``triu(C) + triu(C, 1).T``. The planner's policy
    (``pcbsplinesampling/policy.cc``) transposes it twice more, which leaves it unchanged when all
    ``k`` PCs are active (the default) because it is symmetric.

    Returns:
        ``(D, k)`` float64.
    """
    k, dofs = pcs.components.shape
    return aliased_transpose(pcs.components, k, dofs).reshape(dofs, k)


def reconstruct_as_code(pcs: PCSplines, p: np.ndarray) -> np.ndarray:
    """Joint angles from PC coordinates as the authors' code computes them: ``center + A p``.

    ``A`` is :func:`code_component_matrix` (the aliased in-place transpose), not ``C^T``.

    Args:
        pcs: the PCA.
        p: PC coordinates, shape ``(..., k)``.

    Returns:
        ``(..., D)`` float64.
    """
    p = np.asarray(p, dtype=np.float64)
    if p.ndim == 0 or p.shape[-1] != pcs.num_components:
        raise ValueError(f"p must have shape (..., {pcs.num_components}), got {p.shape}")
    return pcs.center + p @ code_component_matrix(pcs).T
