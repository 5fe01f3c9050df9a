r"""Readers of the paper authors' task files, and their curve evaluation as the authors' C++ does it.

Three formats (the authors' fork of MuJoCo MPC, ``mjpc/tasks/allegro/allegro.{h,cc}``):

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

``contacts/data/<task>.xml`` (MuJoCo ``<custom><numeric>``), read by :func:`read_contacts`:
``contact_numdata_<f> = [offset, count]`` per mocap frame ``f``; ``contact_pos_hand_data_<f>_<k> =
[bodyIndex, x, y, z]`` (metres, in the frame of body ``bodyIndex`` of the authors' compiled model) and
``contact_pos_object_data_<f>_<k> = [x, y, z]`` (metres, object body frame). ``offset`` is the number of
contacts of the frames before ``f``: the C++ finds contact ``k`` of frame ``f`` as the numeric element
``offset + k`` places after the first contact element. This reader goes by the element *names* instead
and checks that the offsets agree with them.

Evaluation (``mjpc/spline/bspline.h``, ``basisfunction.h``; ``allegro.cc``): ``BSplineCurve`` builds an
open uniform basis on ``u`` in ``[0, 1]``: ``M - d + 1`` unique knots ``i / (M - d)``, the end ones with
multiplicity ``d + 1``, i.e. the knot vector ``[0]*d + linspace(0, 1, M - d + 1) + [1]*d`` (``M + d + 1``
knots; for the cubic ``[0]*3 + linspace(0, 1, M - 2) + [1]*3``). This is exactly the knot vector of
``UniformBSpline(M, (0, 1), d)``, which :func:`value_column` uses. At simulation time ``t`` the C++
evaluates every curve (hand, object and PC-curves alike) at

.. math::  u = \operatorname{fmod}(t, L) / L, \qquad L = \texttt{time} \cdot \texttt{slowdown},

with ``time`` taken from the *hand* file, ``u`` clamped to ``[0, 1]`` by ``BasisFunction::GetIndex``, and
takes the *value* column; the time column is never inverted (it only divides the velocity). The value is
then wrapped and converted to MuJoCo units by ``GetPositionAndVelocityInMeasurementUnits``
(:func:`to_mujoco_units`). Contacts are looked up per frame ``floor(t * 120 / slowdown) mod F``
(:func:`contact_frame_index`).

PCs (``allegro.cc``, paper Eq. 3): joint angles ``= center + C^T p``. The C++ builds ``C^T`` with
``mju_transpose`` on an aliased buffer, which is not a transpose; :func:`reconstruct_as_code`
reproduces what the code computes, :func:`reconstruct` what the paper states.

Every problem with a file raises :class:`~contactmpc.reference.data.ReferenceError` with a one-line
message naming the file and the field (the JSON key path, e.g. ``data[3].controlPointData``, or the
XML element name).
"""

from __future__ import annotations

import json
import math
import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from contactmpc.reference.bspline import UniformBSpline
from contactmpc.reference.data import ReferenceError

__all__ = [
    "DOF_TYPES",
    "MOCAP_FPS",
    "ContactFrames",
    "FrameContacts",
    "PCSplines",
    "SplineCurves",
    "aliased_transpose",
    "code_component_matrix",
    "contact_frame_index",
    "evaluate",
    "read_contacts",
    "read_pcmexp",
    "read_smexp",
    "reconstruct",
    "reconstruct_as_code",
    "spline_parameter",
    "time_column",
    "to_mujoco_units",
    "value_column",
]

MOCAP_FPS = 120.0
"""Frame rate of the motion capture (``ALLEGRO_DEFAULT_MOCAP_FPS``): the unit of the time column."""

DOF_TYPES = ("rotation", "rotationBallX", "rotationBallY", "rotationBallZ", "translation")
"""The curve ``type`` values the authors' code knows."""

_ROTATION_UNITS = {"radians": 1.0, "degrees": math.pi / 180.0}
_TRANSLATION_UNITS = {"meters": 1.0, "centimeters": 0.01, "millimeters": 0.001}
_WRAP = {"radians": 2.0 * math.pi, "degrees": 360.0}

_NUMDATA = re.compile(r"contact_numdata_(\d+)")
_POS = re.compile(r"contact_pos_(hand|object)_data_(\d+)_(\d+)")
_POS_SIZE = {"hand": 4, "object": 3}

PathLike = str | os.PathLike


# ---------------------------------------------------------------------------------------------- data
def _frozen(value: Any, dtype: type) -> np.ndarray:
    arr = np.array(value, dtype=dtype, copy=True)
    arr.setflags(write=False)
    return arr


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
        times = _frozen(self.times, np.float64)
        values = _frozen(self.values, np.float64)
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
        center = _frozen(self.center, np.float64)
        components = _frozen(self.components, np.float64)
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


class FrameContacts(NamedTuple):
    """The contacts of one mocap frame (views into :class:`ContactFrames`)."""

    body_index: np.ndarray
    """``(n,)`` int64, hand body index in the authors' compiled model."""
    hand_point: np.ndarray
    """``(n, 3)`` metres, in that body's frame."""
    object_point: np.ndarray
    """``(n, 3)`` metres, in the object body's frame."""


@dataclass(frozen=True, eq=False)
class ContactFrames:
    """Per-frame hand/object contact pairs of a contacts XML, stored flat; arrays are read-only.

    Frame ``f`` owns the rows ``frame_offsets[f] : frame_offsets[f] + frame_counts[f]``, in the order of
    the names' ``_<k>``.

    Attributes:
        body_index: ``(N,)`` int64, the authors' compiled-model body index of the hand point.
        hand_point: ``(N, 3)`` float64, metres in that body's frame.
        object_point: ``(N, 3)`` float64, metres in the object body's frame.
        frame_offsets: ``(F,)`` int64, first row of each frame (the cumulative counts).
        frame_counts: ``(F,)`` int64, contacts per frame.
    """

    body_index: np.ndarray
    hand_point: np.ndarray
    object_point: np.ndarray
    frame_offsets: np.ndarray
    frame_counts: np.ndarray

    def __post_init__(self) -> None:
        arrays = {
            "body_index": _frozen(self.body_index, np.int64),
            "hand_point": _frozen(self.hand_point, np.float64).reshape(-1, 3),
            "object_point": _frozen(self.object_point, np.float64).reshape(-1, 3),
            "frame_offsets": _frozen(self.frame_offsets, np.int64),
            "frame_counts": _frozen(self.frame_counts, np.int64),
        }
        num = arrays["body_index"].shape[0]
        if arrays["hand_point"].shape[0] != num or arrays["object_point"].shape[0] != num:
            raise ValueError("body_index, hand_point and object_point must have the same length")
        counts = arrays["frame_counts"]
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
        if not np.array_equal(arrays["frame_offsets"], starts):
            raise ValueError("frame_offsets must be the cumulative frame_counts")
        if counts.size and (counts.min() < 0 or counts.sum() != num):
            raise ValueError(f"frame_counts must be >= 0 and sum to {num}")
        for name, arr in arrays.items():
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def num_frames(self) -> int:
        """``F``, the number of mocap frames."""
        return int(self.frame_counts.shape[0])

    @property
    def num_contacts(self) -> int:
        """``N``, the number of contact pairs over all frames."""
        return int(self.body_index.shape[0])

    @property
    def frames_with_contacts(self) -> np.ndarray:
        """``(n,)`` int64, the frames with at least one contact."""
        return np.flatnonzero(self.frame_counts > 0)

    def frame(self, f: int) -> FrameContacts:
        """The contacts of frame ``f`` (read-only views)."""
        f = int(f)
        if not 0 <= f < self.num_frames:
            raise IndexError(f"frame {f} out of range [0, {self.num_frames})")
        rows = slice(int(self.frame_offsets[f]), int(self.frame_offsets[f] + self.frame_counts[f]))
        return FrameContacts(self.body_index[rows], self.hand_point[rows], self.object_point[rows])


# ---------------------------------------------------------------------------------------------- JSON
def _json_type(value: Any) -> str:
    if isinstance(value, bool):
        return "a boolean"
    if value is None:
        return "null"
    names = {dict: "an object", list: "an array", str: "a string", int: "a number", float: "a number"}
    return names.get(type(value), type(value).__name__)


def _check_file(path: Path) -> None:
    if not path.exists():
        raise ReferenceError("no such file", path=path)
    if path.is_dir():
        raise ReferenceError("is a directory, not a file", path=path)


def _load_json(path: Path) -> dict[str, Any]:
    _check_file(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise ReferenceError(f"unreadable ({err})", path=path) from err
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as err:
        where = f"line {err.lineno} column {err.colno}"
        raise ReferenceError(f"not valid JSON ({err.msg} at {where}; truncated?)", path=path) from err
    if not isinstance(doc, dict):
        raise ReferenceError(f"expected a JSON object at the top level, got {_json_type(doc)}", path=path)
    return doc


def _key(where: str, key: str) -> str:
    return f"{where}.{key}" if where else key


def _get(obj: Mapping[str, Any], key: str, where: str, path: Path) -> Any:
    if key not in obj:
        raise ReferenceError("missing", field=_key(where, key), path=path)
    return obj[key]


def _object(value: Any, field: str, path: Path) -> Mapping[str, Any]:
    if not isinstance(value, dict):
        raise ReferenceError(f"expected a JSON object, got {_json_type(value)}", field=field, path=path)
    return value


def _list(value: Any, field: str, path: Path) -> list[Any]:
    if not isinstance(value, list):
        raise ReferenceError(f"expected an array, got {_json_type(value)}", field=field, path=path)
    return value


def _int(value: Any, field: str, path: Path, minimum: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise ReferenceError(f"expected an integer, got {value!r}", field=field, path=path)
    if minimum is not None and value < minimum:
        raise ReferenceError(f"must be >= {minimum}, got {value}", field=field, path=path)
    return value


def _float(value: Any, field: str, path: Path) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ReferenceError(f"expected a number, got {_json_type(value)}", field=field, path=path)
    if not math.isfinite(value):
        raise ReferenceError(f"not finite ({value})", field=field, path=path)
    return float(value)


def _floats(value: Any, field: str, path: Path) -> np.ndarray:
    items = _list(value, field, path)
    for i, item in enumerate(items):
        if isinstance(item, bool) or not isinstance(item, (int, float)):
            raise ReferenceError(f"entry {i} is {_json_type(item)}, not a number", field=field, path=path)
    arr = np.array(items, dtype=np.float64)
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        raise ReferenceError(f"entry {bad[0]} is not finite ({arr[bad[0]]})", field=field, path=path)
    return arr


def _header(doc: Mapping[str, Any], path: Path) -> tuple[int, float]:
    """``(degree, duration)`` of a ``.smexp``/``.pcmexp`` document (``dimension`` must be 2)."""
    degree = _int(_get(doc, "degree", "", path), "degree", path, minimum=1)
    dimension = _int(_get(doc, "dimension", "", path), "dimension", path)
    if dimension != 2:
        message = f"expected 2 (interleaved time, value control points), got {dimension}"
        raise ReferenceError(message, field="dimension", path=path)
    duration = _float(_get(doc, "time", "", path), "time", path)
    if duration <= 0:
        raise ReferenceError(f"must be > 0 seconds, got {duration}", field="time", path=path)
    return degree, duration


def _curve(entry: Any, where: str, path: Path, degree: int) -> tuple[str, str, np.ndarray, np.ndarray]:
    """``(type, units, times (M,), values (M,))`` of one curve entry."""
    entry = _object(entry, where, path)
    kind = _get(entry, "type", where, path)
    if kind not in DOF_TYPES:
        message = f"unknown curve type {kind!r} (known: {', '.join(DOF_TYPES)})"
        raise ReferenceError(message, field=_key(where, "type"), path=path)
    units = _get(entry, "units", where, path)
    table = _TRANSLATION_UNITS if kind == "translation" else _ROTATION_UNITS
    if units not in table:
        raise ReferenceError(
            f"{units!r} does not fit a {kind!r} curve (expected one of {', '.join(table)})",
            field=_key(where, "units"),
            path=path,
        )
    field = _key(where, "numControlPoints")
    count = _int(_get(entry, "numControlPoints", where, path), field, path, minimum=degree + 1)
    field = _key(where, "controlPointData")
    data = _floats(_get(entry, "controlPointData", where, path), field, path)
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
    doc = _load_json(path)
    num_dofs = _int(_get(doc, "numDofs", "", path), "numDofs", path, minimum=1)
    if expected_dofs is not None and num_dofs != expected_dofs:
        raise ReferenceError(f"{num_dofs}, expected {expected_dofs}", field="numDofs", path=path)
    degree, duration = _header(doc, path)
    data = _list(_get(doc, "data", "", path), "data", path)
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
    doc = _load_json(path)
    num = _int(_get(doc, "numComponents", "", path), "numComponents", path, minimum=1)
    degree, duration = _header(doc, path)
    data = _object(_get(doc, "data", "", path), "data", path)
    center = _floats(_get(data, "center", "data", path), "data.center", path)
    if center.size == 0 or (expected_dofs is not None and center.size != expected_dofs):
        want = "at least 1" if expected_dofs is None else str(expected_dofs)
        raise ReferenceError(f"has {center.size} entries, expected {want}", field="data.center", path=path)
    entries = _list(_get(data, "components", "data", path), "data.components", path)
    if len(entries) != num:
        raise ReferenceError(
            f"is {num} but data.components holds {len(entries)}", field="numComponents", path=path
        )
    rows = []
    for i, entry in enumerate(entries):
        where = f"data.components[{i}]"
        entry = _object(entry, where, path)
        if "originalDofDimension" in entry:
            field = _key(where, "originalDofDimension")
            dim = _int(entry["originalDofDimension"], field, path)
            if dim != center.size:
                raise ReferenceError(f"{dim}, but data.center has {center.size}", field=field, path=path)
        field = _key(where, "componentData")
        row = _floats(_get(entry, "componentData", where, path), field, path)
        if row.size != center.size:
            raise ReferenceError(
                f"has {row.size} entries, data.center has {center.size}", field=field, path=path
            )
        rows.append(row)
    curves = _curves(entries, "data.components", path, degree, duration)
    return PCSplines(center=center, components=np.stack(rows), curves=curves)


# ------------------------------------------------------------------------------------------ evaluation
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
            col *= _TRANSLATION_UNITS[units]
            continue
        limit = _WRAP[units]
        while np.any(over := col > limit):
            col[over] -= limit
        while np.any(under := col < -limit):
            col[under] += limit
        col *= _ROTATION_UNITS[units]
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


# ------------------------------------------------------------------------------------------ contacts
def _numeric(element: ET.Element, name: str, size: int, path: Path) -> np.ndarray:
    text = element.get("data")
    if text is None:
        raise ReferenceError("has no data attribute", field=name, path=path)
    try:
        values = np.array([float(v) for v in text.split()], dtype=np.float64)
    except ValueError as err:
        raise ReferenceError(f"data is not a list of numbers ({err})", field=name, path=path) from err
    if values.size != size:
        raise ReferenceError(f"data has {values.size} values, expected {size}", field=name, path=path)
    if not np.all(np.isfinite(values)):
        raise ReferenceError(f"data has a non-finite value ({text.strip()})", field=name, path=path)
    return values


def _count(value: float, what: str, name: str, path: Path) -> int:
    if not (value.is_integer() and value >= 0):
        raise ReferenceError(f"{what} {value} is not a non-negative integer", field=name, path=path)
    return int(value)


def read_contacts(path: PathLike) -> ContactFrames:
    """Read a contacts XML (``<custom><numeric>`` elements), by element name.

    ``contact_numdata_<f>`` must exist for every frame ``0 .. F-1``; frame ``f``'s ``count`` contacts
    must be exactly ``contact_pos_hand_data_<f>_<k>`` and ``contact_pos_object_data_<f>_<k>`` for
    ``k = 0 .. count-1``, and its ``offset`` the number of contacts of the frames before it. Numeric
    elements whose names do not start with ``contact_`` are ignored.

    Returns:
        The contacts, flat over frames in ``(f, k)`` order.

    Raises:
        ReferenceError: one line naming the file and the element at fault.
    """
    path = Path(path)
    _check_file(path)
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as err:
        raise ReferenceError(f"not valid XML ({err})", path=path) from err
    except OSError as err:
        raise ReferenceError(f"unreadable ({err})", path=path) from err

    numdata: dict[int, tuple[str, np.ndarray]] = {}
    points: dict[str, dict[int, dict[int, tuple[str, np.ndarray]]]] = {"hand": {}, "object": {}}
    seen: set[str] = set()
    for element in root.iter("numeric"):
        name = element.get("name", "")
        if not name.startswith("contact_"):
            continue
        if name in seen:
            raise ReferenceError("appears more than once", field=name, path=path)
        seen.add(name)
        if match := _NUMDATA.fullmatch(name):
            numdata[int(match[1])] = (name, _numeric(element, name, 2, path))
        elif match := _POS.fullmatch(name):
            side, f, k = match[1], int(match[2]), int(match[3])
            values = _numeric(element, name, _POS_SIZE[side], path)
            frame = points[side].setdefault(f, {})
            if k in frame:
                raise ReferenceError(f"repeats {frame[k][0]}", field=name, path=path)
            frame[k] = (name, values)
        else:
            raise ReferenceError(
                "unknown name (expected contact_numdata_<f>, contact_pos_hand_data_<f>_<k> or "
                "contact_pos_object_data_<f>_<k>)",
                field=name,
                path=path,
            )
    if not numdata:
        raise ReferenceError("no contact_numdata_<f> elements", field="contact_numdata", path=path)

    num_frames = max(numdata) + 1
    for frames in points.values():
        stray = sorted(f for f in frames if f >= num_frames)
        if stray:
            name = min(name for name, _ in frames[stray[0]].values())
            raise ReferenceError(
                f"frame {stray[0]} has no contact_numdata_{stray[0]} (frames 0..{num_frames - 1})",
                field=name,
                path=path,
            )
    offsets = np.zeros(num_frames, dtype=np.int64)
    counts = np.zeros(num_frames, dtype=np.int64)
    rows: list[tuple[np.ndarray, np.ndarray]] = []
    total = 0
    for f in range(num_frames):
        meta_name = f"contact_numdata_{f}"
        if f not in numdata:
            raise ReferenceError(f"missing (frames run 0..{num_frames - 1})", field=meta_name, path=path)
        meta_name, (raw_offset, raw_count) = numdata[f]
        offset = _count(raw_offset, "offset", meta_name, path)
        count = _count(raw_count, "count", meta_name, path)
        if offset != total:
            raise ReferenceError(
                f"offset {offset}, but the frames before it hold {total} contacts", field=meta_name, path=path
            )
        hand, obj = points["hand"].get(f, {}), points["object"].get(f, {})
        if len(hand) != len(obj):
            raise ReferenceError(
                f"frame {f} has {len(hand)} hand points but {len(obj)} object points",
                field=f"contact_pos_hand_data_{f}_*",
                path=path,
            )
        for side, found in (("hand", hand), ("object", obj)):
            missing = [k for k in range(count) if k not in found]
            if missing:
                raise ReferenceError(
                    f"missing; {meta_name} = [{offset}, {count}] announces {count} contacts",
                    field=f"contact_pos_{side}_data_{f}_{missing[0]}",
                    path=path,
                )
            extra = sorted(k for k in found if k >= count)
            if extra:
                raise ReferenceError(
                    f"beyond the {count} contacts that {meta_name} = [{offset}, {count}] announces",
                    field=found[extra[0]][0],
                    path=path,
                )
        for k in range(count):
            name, values = hand[k]
            _count(values[0], "body index", name, path)
            rows.append((values, obj[k][1]))
        offsets[f], counts[f] = offset, count
        total += count

    hand_rows = np.array([r[0] for r in rows], dtype=np.float64).reshape(-1, 4)
    object_rows = np.array([r[1] for r in rows], dtype=np.float64).reshape(-1, 3)
    return ContactFrames(
        body_index=hand_rows[:, 0].astype(np.int64),
        hand_point=hand_rows[:, 1:],
        object_point=object_rows,
        frame_offsets=offsets,
        frame_counts=counts,
    )
