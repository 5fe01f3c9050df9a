r"""The authors' curve files: ``.smexp`` (B-spline curves) and ``.pcmexp`` (a PCA and its PC-curves).

Both are read as the authors' fork of MuJoCo MPC reads them (``mjpc/tasks/allegro/allegro.{h,cc}``).

``<task>_hand.smexp`` / ``<task>_object.smexp`` (JSON), read by :func:`read_smexp`::

    {"numDofs": n, "degree": 3, "dimension": 2, "time": seconds,
     "data": [{"type": ..., "units": ..., "numControlPoints": M,
               "controlPointData": [t0, v0, t1, v1, ...]}, ...]}

Each curve is a 2-D B-spline whose control points interleave a *time* (mocap frames at 120 fps) and a
*value* (in the curve's ``units``). ``type`` is one of ``rotation``, ``rotationBallX/Y/Z`` (Euler angles
of a free body) and ``translation``; ``units`` one of ``radians``, ``degrees``, ``meters``,
``centimeters``, ``millimeters``. ``time`` is the demonstration's length in seconds.

``<task>.pcmexp`` (JSON), read by :func:`read_pcmexp`: ``numComponents``, ``degree``, ``dimension``,
``time`` as above and ``data = {"center": [D], "components": [...]}``, where component ``k`` holds
``componentData`` (row ``k`` of the component matrix ``C (k, D)``), ``originalDofDimension`` (``D``)
and its PC-curve in the ``.smexp`` curve fields (``type``, ``units``, ``numControlPoints``,
``controlPointData``).

Every problem raises :class:`~contactmpc.reference.data.ReferenceError`, one line naming the file and
the field (the checks are :mod:`contactmpc.reference.paper.fields`). How the curves are evaluated is
:mod:`contactmpc.reference.paper.evaluation`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from contactmpc.reference.bspline import UniformBSpline
from contactmpc.reference.data import ReferenceError
from contactmpc.reference.paper.fields import (
    PathLike,
    as_float,
    as_floats,
    as_int,
    as_list,
    as_object,
    frozen,
    get,
    key_path,
    load_json,
)

__all__ = [
    "DOF_TYPES",
    "MOCAP_FPS",
    "ROTATION_UNITS",
    "TRANSLATION_UNITS",
    "PCSplines",
    "SplineCurves",
    "read_pcmexp",
    "read_smexp",
]

MOCAP_FPS = 120.0
"""Frame rate of the motion capture (``ALLEGRO_DEFAULT_MOCAP_FPS``): the unit of the time column."""

DOF_TYPES = ("rotation", "rotationBallX", "rotationBallY", "rotationBallZ", "translation")
"""The curve ``type`` values the authors' code knows."""

ROTATION_UNITS = {"radians": 1.0, "degrees": math.pi / 180.0}
"""A rotation curve's ``units`` -> radians per unit."""
TRANSLATION_UNITS = {"meters": 1.0, "centimeters": 0.01, "millimeters": 0.001}
"""A translation curve's ``units`` -> metres per unit."""


# ---------------------------------------------------------------------------------------------- data
@dataclass(frozen=True, eq=False)
class SplineCurves:
    """The curves of one ``.smexp`` file (or the PC-curves of a ``.pcmexp``); arrays are read-only.

    Attributes:
        duration: the file's ``time``, the demonstration's length in seconds (before any slowdown).
        degree: spline degree ``d`` (3 in the authors' files).
        kind: ``(n,)`` each curve's ``type`` (one of :data:`DOF_TYPES`).
        units: ``(n,)`` each curve's ``units``.
        times: ``(n, M)`` float64, the control points' time column (mocap frames).
        values: ``(n, M)`` float64, the control points' value column (in ``units``).
    """

    duration: float
    degree: int
    kind: tuple[str, ...]
    units: tuple[str, ...]
    times: np.ndarray
    values: np.ndarray

    def __post_init__(self) -> None:
        times = frozen(self.times, np.float64)
        values = frozen(self.values, np.float64)
        if times.ndim != 2 or times.shape != values.shape:
            raise ValueError(f"times and values must share a 2-D shape, got {times.shape}, {values.shape}")
        if len(self.kind) != times.shape[0] or len(self.units) != times.shape[0]:
            raise ValueError(f"kind and units must have {times.shape[0]} entries")
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "kind", tuple(str(k) for k in self.kind))
        object.__setattr__(self, "units", tuple(str(u) for u in self.units))
        object.__setattr__(self, "duration", float(self.duration))
        object.__setattr__(self, "degree", int(self.degree))

    @property
    def num_curves(self) -> int:
        """Number of curves ``n``."""
        return int(self.values.shape[0])

    @property
    def num_control_points(self) -> int:
        """Control points per curve ``M``."""
        return int(self.values.shape[1])

    @property
    def basis(self) -> UniformBSpline:
        """The curves' basis on ``u`` in ``[0, 1]``: the knot vector of the authors' ``BSplineCurve``."""
        return UniformBSpline(self.num_control_points, (0.0, 1.0), self.degree)


@dataclass(frozen=True, eq=False)
class PCSplines:
    """A ``.pcmexp`` file: the PCA of the ``D`` finger curves and its ``k`` PC-curves.

    Attributes:
        center: ``(D,)`` the mean (radians in the authors' files).
        components: ``(k, D)``, row ``k`` = ``components[k].componentData`` (orthonormal rows).
        curves: the ``k`` PC-curves (``values (k, M)``, units as in the file).
    """

    center: np.ndarray
    components: np.ndarray
    curves: SplineCurves

    def __post_init__(self) -> None:
        center = frozen(self.center, np.float64)
        components = frozen(self.components, np.float64)
        if center.ndim != 1 or components.ndim != 2 or components.shape[1] != center.shape[0]:
            shapes = f"{center.shape}, {components.shape}"
            raise ValueError(f"need center (D,) and components (k, D), got {shapes}")
        if self.curves.num_curves != components.shape[0]:
            raise ValueError(f"{components.shape[0]} components but {self.curves.num_curves} PC-curves")
        object.__setattr__(self, "center", center)
        object.__setattr__(self, "components", components)

    @property
    def duration(self) -> float:
        """The file's ``time`` in seconds."""
        return self.curves.duration

    @property
    def num_components(self) -> int:
        """``k``."""
        return int(self.components.shape[0])

    @property
    def num_dofs(self) -> int:
        """``D``, the number of reconstructed joints."""
        return int(self.center.shape[0])


# ------------------------------------------------------------------------------------------- readers
def _header(doc: Mapping[str, Any], path: Path) -> tuple[int, float]:
    """``(degree, duration)`` of a ``.smexp``/``.pcmexp`` document (``dimension`` must be 2)."""
    degree = as_int(get(doc, "degree", "", path), "degree", path, minimum=1)
    dimension = as_int(get(doc, "dimension", "", path), "dimension", path)
    if dimension != 2:
        message = f"expected 2 (interleaved time, value control points), got {dimension}"
        raise ReferenceError(message, field="dimension", path=path)
    duration = as_float(get(doc, "time", "", path), "time", path)
    if duration <= 0:
        raise ReferenceError(f"must be > 0 seconds, got {duration}", field="time", path=path)
    return degree, duration


def _curve(entry: Any, where: str, path: Path, degree: int) -> tuple[str, str, np.ndarray, np.ndarray]:
    """``(type, units, times (M,), values (M,))`` of one curve entry."""
    entry = as_object(entry, where, path)
    kind = get(entry, "type", where, path)
    if kind not in DOF_TYPES:
        message = f"unknown curve type {kind!r} (known: {', '.join(DOF_TYPES)})"
        raise ReferenceError(message, field=key_path(where, "type"), path=path)
    units = get(entry, "units", where, path)
    table = TRANSLATION_UNITS if kind == "translation" else ROTATION_UNITS
    if units not in table:
        raise ReferenceError(
            f"{units!r} does not fit a {kind!r} curve (expected one of {', '.join(table)})",
            field=key_path(where, "units"),
            path=path,
        )
    field = key_path(where, "numControlPoints")
    count = as_int(get(entry, "numControlPoints", where, path), field, path, minimum=degree + 1)
    field = key_path(where, "controlPointData")
    data = as_floats(get(entry, "controlPointData", where, path), field, path)
    if data.size % 2:
        raise ReferenceError(
            f"odd length {data.size}; expected interleaved [t0, v0, t1, v1, ...]", field=field, path=path
        )
    if data.size != 2 * count:
        message = f"holds {data.size // 2} (time, value) pairs but numControlPoints is {count}"
        raise ReferenceError(message, field=field, path=path)
    return kind, units, data[0::2], data[1::2]


def _curves(entries: list[Any], where: str, path: Path, degree: int, duration: float) -> SplineCurves:
    parsed = [_curve(entry, f"{where}[{i}]", path, degree) for i, entry in enumerate(entries)]
    first = parsed[0][2].size
    for i, (_, _, times, _) in enumerate(parsed):
        if times.size != first:
            raise ReferenceError(
                f"{times.size} control points, {where}[0] has {first}; the curves of one file must share it",
                field=f"{where}[{i}].numControlPoints",
                path=path,
            )
    return SplineCurves(
        duration=duration,
        degree=degree,
        kind=tuple(p[0] for p in parsed),
        units=tuple(p[1] for p in parsed),
        times=np.stack([p[2] for p in parsed]),
        values=np.stack([p[3] for p in parsed]),
    )


def read_smexp(path: PathLike, expected_dofs: int | None = None) -> SplineCurves:
    """Read a ``.smexp`` curve file (a hand's 22 curves or an object's 6).

    Args:
        path: the file.
        expected_dofs: when given, ``numDofs`` must equal it.

    Returns:
        The curves, ``times``/``values`` of shape ``(numDofs, M)``.

    Raises:
        ReferenceError: one line naming the file and the field at fault.
    """
    path = Path(path)
    doc = load_json(path)
    num_dofs = as_int(get(doc, "numDofs", "", path), "numDofs", path, minimum=1)
    if expected_dofs is not None and num_dofs != expected_dofs:
        raise ReferenceError(f"{num_dofs}, expected {expected_dofs}", field="numDofs", path=path)
    degree, duration = _header(doc, path)
    data = as_list(get(doc, "data", "", path), "data", path)
    if len(data) != num_dofs:
        raise ReferenceError(f"holds {len(data)} curves but numDofs is {num_dofs}", field="data", path=path)
    return _curves(data, "data", path, degree, duration)


def read_pcmexp(path: PathLike, expected_dofs: int | None = None) -> PCSplines:
    """Read a ``.pcmexp`` file: PCA centre, component matrix and PC-curves.

    Args:
        path: the file.
        expected_dofs: when given, the number of reconstructed joints ``D`` (length of ``center``).

    Returns:
        ``center (D,)``, ``components (k, D)`` and the ``k`` PC-curves.

    Raises:
        ReferenceError: one line naming the file and the field at fault.
    """
    path = Path(path)
    doc = load_json(path)
    num = as_int(get(doc, "numComponents", "", path), "numComponents", path, minimum=1)
    degree, duration = _header(doc, path)
    data = as_object(get(doc, "data", "", path), "data", path)
    center = as_floats(get(data, "center", "data", path), "data.center", path)
    if center.size == 0 or (expected_dofs is not None and center.size != expected_dofs):
        want = "at least 1" if expected_dofs is None else str(expected_dofs)
        raise ReferenceError(f"has {center.size} entries, expected {want}", field="data.center", path=path)
    entries = as_list(get(data, "components", "data", path), "data.components", path)
    if len(entries) != num:
        raise ReferenceError(
            f"is {num} but data.components holds {len(entries)}", field="numComponents", path=path
        )
    rows = []
    for i, entry in enumerate(entries):
        where = f"data.components[{i}]"
        entry = as_object(entry, where, path)
        if "originalDofDimension" in entry:
            field = key_path(where, "originalDofDimension")
            dim = as_int(entry["originalDofDimension"], field, path)
            if dim != center.size:
                raise ReferenceError(f"{dim}, but data.center has {center.size}", field=field, path=path)
        field = key_path(where, "componentData")
        row = as_floats(get(entry, "componentData", where, path), field, path)
        if row.size != center.size:
            raise ReferenceError(
                f"has {row.size} entries, data.center has {center.size}", field=field, path=path
            )
        rows.append(row)
    curves = _curves(entries, "data.components", path, degree, duration)
    return PCSplines(center=center, components=np.stack(rows), curves=curves)
