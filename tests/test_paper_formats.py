"""Readers of the paper authors' file formats and their evaluation (``contactmpc.reference.paper``:
``splines``, ``contacts``, ``evaluation``).

Small files in the authors' formats are written into ``tmp_path`` by the helpers below (no authors'
data is stored in the repository). The real files are read only when ``CONTACTMPC_PAPER_DATA`` names
the authors' ``mjpc/tasks`` directory; ``pytest -s`` prints what they hold.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest
from scipy.interpolate import BSpline

from contactmpc.reference.bspline import UniformBSpline
from contactmpc.reference.data import ReferenceError
from contactmpc.reference.paper.contacts import read_contacts
from contactmpc.reference.paper.evaluation import (
    aliased_transpose,
    code_component_matrix,
    contact_frame_index,
    evaluate,
    reconstruct,
    reconstruct_as_code,
    spline_parameter,
    time_column,
    to_mujoco_units,
    value_column,
)
from contactmpc.reference.paper.splines import MOCAP_FPS, read_pcmexp, read_smexp

# ------------------------------------------------------------------------------------ file builders


def cpp_knots(num_controls: int, degree: int = 3) -> np.ndarray:
    """The knot vector exactly as ``BSplineCurve``'s constructor builds it (``mjpc/spline/bspline.h``)."""
    last = num_controls - degree  # numUniqueKnots - 1
    factor = 1.0 / last
    unique = [0.0] + [factor * i for i in range(1, last)] + [1.0]
    return np.array([unique[0]] * (degree + 1) + unique[1:-1] + [unique[-1]] * (degree + 1))


def greville_times(num_controls: int, num_frames: int, degree: int = 3) -> np.ndarray:
    """Time column whose curve is the straight line ``u * (F - 1)`` (as in the authors' files)."""
    knots = cpp_knots(num_controls, degree)
    return np.array([knots[j + 1 : j + degree + 1].mean() for j in range(num_controls)]) * (num_frames - 1)


def curve_entries(times: np.ndarray, values: np.ndarray, kinds: list[str], units: list[str]) -> list[dict]:
    return [
        {
            "type": kinds[i],
            "units": units[i],
            "numControlPoints": int(values.shape[1]),
            "controlPointData": np.column_stack([times[i], values[i]]).ravel().tolist(),
        }
        for i in range(values.shape[0])
    ]


def smexp_doc(
    values: np.ndarray,
    duration: float,
    kinds: list[str] | None = None,
    units: list[str] | None = None,
    num_frames: int | None = None,
) -> dict[str, Any]:
    """A ``.smexp`` document for curves with control-point values ``(n, M)``."""
    n, m = values.shape
    frames = round(duration * MOCAP_FPS) if num_frames is None else num_frames
    times = np.tile(greville_times(m, frames), (n, 1))
    return {
        "numDofs": n,
        "degree": 3,
        "dimension": 2,
        "time": duration,
        "data": curve_entries(times, values, kinds or ["rotation"] * n, units or ["degrees"] * n),
    }


def pcmexp_doc(center: np.ndarray, components: np.ndarray, values: np.ndarray, duration: float) -> dict:
    """A ``.pcmexp`` document: PCA centre ``(D,)``, components ``(k, D)``, PC-curve values ``(k, M)``."""
    k, m = values.shape
    times = np.tile(greville_times(m, round(duration * MOCAP_FPS)), (k, 1))
    entries = curve_entries(times, values, ["rotation"] * k, ["radians"] * k)
    for entry, row in zip(entries, components, strict=True):
        entry["componentData"] = row.tolist()
        entry["originalDofDimension"] = int(center.size)
    return {
        "numComponents": k,
        "degree": 3,
        "dimension": 2,
        "time": duration,
        "data": {"center": center.tolist(), "components": entries},
    }


def write_json(path: Path, doc: Any) -> Path:
    path.write_text(json.dumps(doc))
    return path


Contact = tuple[int, tuple[float, float, float], tuple[float, float, float]]


def contact_elements(frames: list[list[Contact]]) -> list[tuple[str, str]]:
    """``(name, data)`` of the numeric elements, in the authors' order (numdata, object, hand)."""
    numdata, objects, hands = [], [], []
    total = 0
    for f, contacts in enumerate(frames):
        numdata.append((f"contact_numdata_{f}", f"{total} {len(contacts)}"))
        for k, (body, hand, obj) in enumerate(contacts):
            objects.append((f"contact_pos_object_data_{f}_{k}", " ".join(repr(float(x)) for x in obj)))
            hands.append(
                (f"contact_pos_hand_data_{f}_{k}", " ".join([str(body)] + [repr(float(x)) for x in hand]))
            )
        total += len(contacts)
    return numdata + objects + hands


def write_contacts(path: Path, elements: list[tuple[str, str]]) -> Path:
    lines = ["<mujoco>", "    <custom>"]
    lines += [f'        <numeric name="{name}" data="{data}" />' for name, data in elements]
    path.write_text("\n".join(lines + ["    </custom>", "</mujoco>", ""]))
    return path


def assert_one_line(err: pytest.ExceptionInfo, path: Path, field: str | None) -> None:
    message = str(err.value)
    assert isinstance(err.value, ReferenceError)
    assert "\n" not in message and "\r" not in message, message
    assert str(path) in message, message
    if field is not None:
        assert err.value.field == field, message
        assert field in message, message


# ------------------------------------------------------------------------------------ curves


def cpp_value(knots: np.ndarray, degree: int, control: np.ndarray, t: float) -> float:
    """A literal port of ``BasisFunction::Evaluate`` (order 0) and ``BSplineCurve::Evaluate``."""
    num_controls = control.size
    tmin, tmax = knots[degree], knots[num_controls]
    if t <= tmin:
        t, i = tmin, degree
    elif t >= tmax:
        t, i = tmax, num_controls - 1
    else:
        keys, total = [], 0
        for value in dict.fromkeys(knots.tolist()):  # unique knots, in order
            keys.append((value, total - 1))
            total += int(np.sum(knots == value))
        i = next(index for value, index in keys if t < value)
    jet = np.zeros((degree + 1, num_controls + degree))
    jet[0][i] = 1.0
    n0, n1 = t - knots[i], knots[i + 1] - t
    for j in range(1, degree + 1):
        d0, d1 = knots[i + j] - knots[i], knots[i + 1] - knots[i - j + 1]
        inv0, inv1 = (1.0 / d0 if d0 > 0 else 0.0), (1.0 / d1 if d1 > 0 else 0.0)
        jet[j][i] = n0 * jet[j - 1][i] * inv0
        jet[j][i - j] = n1 * jet[j - 1][i - j + 1] * inv1
    for j in range(2, degree + 1):
        for k in range(i - j + 1, i):
            n0, n1 = t - knots[k], knots[k + j + 1] - t
            d0, d1 = knots[k + j] - knots[k], knots[k + j + 1] - knots[k + 1]
            inv0, inv1 = (1.0 / d0 if d0 > 0 else 0.0), (1.0 / d1 if d1 > 0 else 0.0)
            jet[j][k] = n0 * jet[j - 1][k] * inv0 + n1 * jet[j - 1][k + 1] * inv1
    return float(sum(jet[degree][m] * control[m] for m in range(i - degree, i + 1)))


def test_knot_vector_is_the_cpp_one() -> None:
    for m in (4, 5, 9, 40, 60, 70, 80):
        assert np.array_equal(UniformBSpline(m, (0.0, 1.0)).knots, cpp_knots(m)), m


def test_curve_round_trip_and_cpp_evaluation(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    values = rng.normal(scale=30.0, size=(3, 9))
    duration, slowdown = 2.5, 6.0
    kinds, units = ["translation", "rotationBallX", "rotation"], ["centimeters", "degrees", "radians"]
    path = write_json(tmp_path / "x_hand.smexp", smexp_doc(values, duration, kinds, units))
    curves = read_smexp(path, expected_dofs=3)
    assert (curves.num_curves, curves.num_control_points, curves.degree) == (3, 9, 3)
    assert curves.kind == tuple(kinds) and curves.units == tuple(units) and curves.duration == duration
    np.testing.assert_array_equal(curves.values, values)
    assert not curves.values.flags.writeable

    loop = duration * slowdown
    t = np.array([0.0, 0.37, 1.0, 7.3, loop * 0.5, loop - 1e-9, loop, loop + 2.2, 3 * loop + 0.1])
    u = np.fmod(t, loop) / loop
    knots = np.concatenate([np.zeros(4), np.arange(1, 6) / 6, np.ones(4)])  # 9 control points
    expected = BSpline(knots, values.T, 3)(u)
    got = evaluate(curves, t, slowdown)
    assert got.shape == (t.size, 3)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    for n, un in enumerate(u):
        for c in range(3):
            assert abs(got[n, c] - cpp_value(cpp_knots(9), 3, values[c], un)) < 1e-12
    # the knots themselves, and values clamped outside [0, 1] as GetIndex does
    for un in (0.0, 1.0, 1 / 6, 0.5, -0.2, 1.3):
        for c in range(3):
            assert abs(value_column(curves, un)[0, c] - cpp_value(cpp_knots(9), 3, values[c], un)) < 1e-12


def test_fmod_wraps_at_the_loop_length(tmp_path: Path) -> None:
    values = np.arange(14.0).reshape(2, 7) ** 2
    curves = read_smexp(write_json(tmp_path / "c.smexp", smexp_doc(values, 1.5)))
    loop = 1.5 * 4.0
    at = evaluate(curves, np.array([0.0, loop, 2 * loop, loop - 1e-12, loop + 0.9, 0.9]), 4.0)
    np.testing.assert_array_equal(at[0], values[:, 0])  # t = 0: the first control point
    np.testing.assert_array_equal(at[1], values[:, 0])  # t = L wraps to u = 0
    np.testing.assert_array_equal(at[2], values[:, 0])
    np.testing.assert_allclose(at[3], values[:, -1], atol=1e-9)  # just before L: the last point
    np.testing.assert_allclose(at[4], at[5], atol=1e-12)
    np.testing.assert_allclose(spline_parameter([loop, loop + 1.5], 1.5, 4.0), [0.0, 0.25], atol=1e-15)
    # the loop length can come from another file (the C++ takes the hand file's time for all curves)
    np.testing.assert_array_equal(evaluate(curves, [3.0], 4.0, duration=0.75), curves.values[:, :1].T)


def test_time_column_maps_u_to_mocap_frames(tmp_path: Path) -> None:
    duration = 50 / MOCAP_FPS  # 50 frames
    curves = read_smexp(write_json(tmp_path / "c.smexp", smexp_doc(np.zeros((2, 8)), duration)))
    u = np.linspace(0, 1, 33)
    np.testing.assert_allclose(time_column(curves, u), np.outer(u * 49, [1, 1]), atol=1e-10)
    assert contact_frame_index([0.0, 1.0 / 30, 50 / 30 - 1e-9, 50 / 30], 4.0, 50).tolist() == [0, 1, 49, 0]


def test_to_mujoco_units_wraps_like_the_cpp(tmp_path: Path) -> None:
    kinds = ["translation", "translation", "rotationBallZ", "rotation"]
    units = ["centimeters", "millimeters", "degrees", "radians"]
    curves = read_smexp(write_json(tmp_path / "c.smexp", smexp_doc(np.zeros((4, 4)), 1.0, kinds, units)))
    values = np.array([[150.0, 150.0, 431.0, 7.0], [-2.0, -2.0, -721.0, -2 * math.pi], [0, 0, 360.0, -13.0]])
    out = to_mujoco_units(curves, values)
    two_pi = 2 * math.pi
    expected = [
        [1.5, 0.15, 71.0 * math.pi / 180, 7.0 - two_pi],
        [-0.02, -0.002, -361.0 + 360.0, -two_pi],  # -721 -> -361 -> -1 (loop until >= -360)
        [0.0, 0.0, 2 * math.pi, -13.0 + 2 * two_pi],
    ]
    expected[1][2] *= math.pi / 180
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-12)


# ------------------------------------------------------------------------------------ PCs


def test_aliased_transpose_hand_worked() -> None:
    # 3 x 3: row 0 is written into column 0 first, so rows 1, 2 read the already mirrored entries.
    result = aliased_transpose(np.arange(9.0), 3, 3).reshape(3, 3)
    np.testing.assert_array_equal(result, [[0, 1, 2], [1, 4, 5], [2, 5, 8]])
    # 2 x 3 (non-square): [0,1,2,3,4,5] -> [0,1,1,3,4,5] -> [0,1,1,3,1,5] -> [0,3,1,3,1,5] -> [0,3,1,1,1,5]
    np.testing.assert_array_equal(aliased_transpose(np.arange(6.0), 2, 3), [0, 3, 1, 1, 1, 5])
    # MuJoCo itself, on an aliased buffer
    for nr, nc in ((3, 3), (2, 3), (16, 16), (5, 16)):
        buf = np.random.default_rng(nr * nc).normal(size=nr * nc)
        expected = aliased_transpose(buf, nr, nc)
        mujoco.mju_transpose(buf.reshape(nc, nr), buf.reshape(nr, nc))
        np.testing.assert_array_equal(buf, expected)


def test_pc_reconstruction(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    components = np.linalg.qr(rng.normal(size=(5, 5)))[0].T  # orthonormal rows
    center = rng.normal(size=5)
    pcs_values = rng.normal(size=(5, 6))
    path = write_json(tmp_path / "x.pcmexp", pcmexp_doc(center, components, pcs_values, 1.0))
    pcs = read_pcmexp(path, expected_dofs=5)
    assert (pcs.num_components, pcs.num_dofs, pcs.duration) == (5, 5, 1.0)
    np.testing.assert_array_equal(pcs.components, components)
    np.testing.assert_array_equal(pcs.curves.values, pcs_values)
    p = rng.normal(size=(4, 5))
    np.testing.assert_allclose(reconstruct(pcs, p), center + (components.T @ p.T).T, atol=1e-14)
    mirrored = np.triu(components) + np.triu(components, 1).T
    np.testing.assert_allclose(reconstruct_as_code(pcs, p), center + p @ mirrored.T, atol=1e-14)
    # evaluated PC-curves -> joints, as the C++'s GetDesiredAgentStateFromPCs (without the root)
    joints = reconstruct(pcs, evaluate(pcs.curves, [0.0], 2.0))
    np.testing.assert_allclose(joints[0], center + components.T @ pcs_values[:, 0], atol=1e-14)


def test_pc_reconstruction_as_code_hand_worked(tmp_path: Path) -> None:
    components = np.arange(9.0).reshape(3, 3)  # C; the code uses [[0,1,2],[1,4,5],[2,5,8]] for C^T
    center = np.array([0.5, -1.0, 2.0])
    path = write_json(tmp_path / "x.pcmexp", pcmexp_doc(center, components, np.zeros((3, 4)), 1.0))
    pcs = read_pcmexp(path)
    np.testing.assert_array_equal(code_component_matrix(pcs), [[0, 1, 2], [1, 4, 5], [2, 5, 8]])
    p = np.array([1.0, 10.0, 100.0])
    np.testing.assert_array_equal(reconstruct(pcs, p), center + [630.0, 741.0, 852.0])  # C^T p
    np.testing.assert_array_equal(reconstruct_as_code(pcs, p), center + [210.0, 541.0, 852.0])


# ------------------------------------------------------------------------------------ contacts

FRAMES: list[list[Contact]] = [
    [],
    [(7, (0.01, 0.02, 0.03), (0.1, 0.2, 0.3)), (22, (-0.01, 0.0, 0.005), (0.4, 0.5, 0.6))],
    [],
    [
        (3, (1e-3, 2e-3, 3e-3), (-0.1, -0.2, -0.3)),
        (9, (0.0, 0.0, 0.0), (1.0, 1.0, 1.0)),
        (24, (4, 5, 6), (7, 8, 9)),
    ],
    [],
]


def test_contacts_grouped_per_frame(tmp_path: Path) -> None:
    elements = contact_elements(FRAMES)
    np.random.default_rng(0).shuffle(elements)  # read by name, not by position
    contacts = read_contacts(write_contacts(tmp_path / "c.xml", elements))
    assert contacts.num_frames == 5 and contacts.num_contacts == 5
    assert contacts.frame_offsets.tolist() == [0, 0, 2, 2, 5]
    assert contacts.frame_counts.tolist() == [0, 2, 0, 3, 0]
    assert contacts.frames_with_contacts.tolist() == [1, 3]
    body, hand, obj = contacts.frame(3)
    assert body.tolist() == [3, 9, 24] and body.dtype == np.int64
    np.testing.assert_array_equal(hand, [c[1] for c in FRAMES[3]])
    np.testing.assert_array_equal(obj, [c[2] for c in FRAMES[3]])
    assert contacts.frame(0).hand_point.shape == (0, 3)
    assert not contacts.hand_point.flags.writeable
    with pytest.raises(IndexError):
        contacts.frame(5)


def _without(*names: str) -> Callable[[list], list]:
    return lambda els: [e for e in els if e[0] not in names]


def _set(name: str, data: str) -> Callable[[list], list]:
    return lambda els: [(n, data if n == name else d) for n, d in els]


def _plus(*extra: tuple[str, str]) -> Callable[[list], list]:
    return lambda els: els + list(extra)


BAD_CONTACTS = {
    "offset": (_set("contact_numdata_3", "1 3"), "contact_numdata_3"),
    "count_not_integer": (_set("contact_numdata_3", "2 2.5"), "contact_numdata_3"),
    "negative_count": (_set("contact_numdata_4", "5 -1"), "contact_numdata_4"),
    "numdata_size": (_set("contact_numdata_1", "0 2 1"), "contact_numdata_1"),
    "missing_frame": (_without("contact_numdata_2"), "contact_numdata_2"),
    "missing_k": (
        _without("contact_pos_hand_data_3_1", "contact_pos_object_data_3_1"),
        "contact_pos_hand_data_3_1",
    ),
    "extra_k": (
        _plus(("contact_pos_hand_data_1_2", "8 0 0 0"), ("contact_pos_object_data_1_2", "0 0 0")),
        "contact_pos_hand_data_1_2",
    ),
    "hand_object_disagree": (_without("contact_pos_object_data_3_2"), "contact_pos_hand_data_3_*"),
    "frame_without_numdata": (
        _plus(("contact_pos_hand_data_9_0", "8 0 0 0"), ("contact_pos_object_data_9_0", "0 0 0")),
        "contact_pos_hand_data_9_0",
    ),
    "body_not_integer": (_set("contact_pos_hand_data_1_1", "22.5 0 0 0"), "contact_pos_hand_data_1_1"),
    "hand_size": (_set("contact_pos_hand_data_1_0", "0.1 0.2 0.3"), "contact_pos_hand_data_1_0"),
    "not_finite": (_set("contact_pos_object_data_3_0", "nan 0 0"), "contact_pos_object_data_3_0"),
    "not_numbers": (_set("contact_pos_object_data_3_0", "a b c"), "contact_pos_object_data_3_0"),
    "duplicate": (_plus(("contact_numdata_0", "0 0")), "contact_numdata_0"),
    "unknown_name": (_plus(("contact_pos_hand_data_3", "1 2 3 4")), "contact_pos_hand_data_3"),
    "no_numdata": (lambda els: [], "contact_numdata"),
}


@pytest.mark.parametrize("case", sorted(BAD_CONTACTS))
def test_bad_contacts(tmp_path: Path, case: str) -> None:
    edit, field = BAD_CONTACTS[case]
    path = write_contacts(tmp_path / f"{case}.xml", edit(contact_elements(FRAMES)))
    with pytest.raises(ReferenceError) as err:
        read_contacts(path)
    assert_one_line(err, path, field)


def test_bad_contact_files(tmp_path: Path) -> None:
    truncated = tmp_path / "truncated.xml"
    truncated.write_text('<mujoco><custom><numeric name="contact_numdata_0" data="0 0" />')
    for path in (tmp_path / "missing.xml", tmp_path, truncated):
        with pytest.raises(ReferenceError) as err:
            read_contacts(path)
        assert_one_line(err, path, None)


# ------------------------------------------------------------------------------------ bad JSON files


def _smexp() -> dict:
    return smexp_doc(np.arange(15.0).reshape(3, 5), 1.0, ["translation", "rotationBallX", "rotation"],
                     ["centimeters", "degrees", "degrees"])  # fmt: skip


def _edit(key_path: str, value: Any = None, delete: bool = False) -> Callable[[dict], dict]:
    """Set (or delete) ``doc[k0][k1]...``; integer parts index lists."""

    def edit(doc: dict) -> dict:
        parts = [int(p) if p.isdigit() else p for p in key_path.split("/")]
        node = doc
        for part in parts[:-1]:
            node = node[part]
        if delete:
            del node[parts[-1]]
        else:
            node[parts[-1]] = value(node[parts[-1]]) if callable(value) else value
        return doc

    return edit


BAD_SMEXP = {
    "no_numDofs": (_edit("numDofs", delete=True), "numDofs"),
    "numDofs_float": (_edit("numDofs", 3.0), "numDofs"),
    "numDofs_vs_expected": (_edit("numDofs", 22), "numDofs"),  # also != len(data), expected checked first
    "numDofs_vs_data": (_edit("data", lambda d: d[:2]), "data"),
    "no_degree": (_edit("degree", delete=True), "degree"),
    "dimension": (_edit("dimension", 3), "dimension"),
    "time_zero": (_edit("time", 0.0), "time"),
    "time_string": (_edit("time", "5"), "time"),
    "time_nan": (_edit("time", float("nan")), "time"),
    "data_not_list": (_edit("data", {"a": 1}), "data"),
    "entry_not_object": (_edit("data/1", [1, 2]), "data[1]"),
    "no_type": (_edit("data/1/type", delete=True), "data[1].type"),
    "unknown_type": (_edit("data/2/type", "hinge"), "data[2].type"),
    "units_vs_type": (_edit("data/0/units", "degrees"), "data[0].units"),
    "no_control_points": (_edit("data/1/controlPointData", delete=True), "data[1].controlPointData"),
    "odd_length": (_edit("data/1/controlPointData", lambda c: c[:-1]), "data[1].controlPointData"),
    "count_mismatch": (_edit("data/1/numControlPoints", 6), "data[1].controlPointData"),
    "too_few_points": (
        _edit(
            "data/0", lambda e: {**e, "numControlPoints": 3, "controlPointData": e["controlPointData"][:6]}
        ),
        "data[0].numControlPoints",
    ),  # fmt: skip
    "not_finite": (_edit("data/0/controlPointData/3", float("inf")), "data[0].controlPointData"),
    "not_a_number": (_edit("data/2/controlPointData/0", "0"), "data[2].controlPointData"),
    "bool": (_edit("data/2/controlPointData/0", True), "data[2].controlPointData"),
    "shared_count": (
        _edit(
            "data/1", lambda e: {**e, "numControlPoints": 4, "controlPointData": e["controlPointData"][:8]}
        ),
        "data[1].numControlPoints",
    ),  # fmt: skip
}


@pytest.mark.parametrize("case", sorted(BAD_SMEXP))
def test_bad_smexp(tmp_path: Path, case: str) -> None:
    edit, field = BAD_SMEXP[case]
    path = write_json(tmp_path / f"{case}.smexp", edit(_smexp()))
    with pytest.raises(ReferenceError) as err:
        read_smexp(path, expected_dofs=3)
    assert_one_line(err, path, field)


def _pcmexp() -> dict:
    rng = np.random.default_rng(5)
    return pcmexp_doc(rng.normal(size=4), np.eye(4), rng.normal(size=(4, 5)), 1.0)


BAD_PCMEXP = {
    "numComponents": (_edit("numComponents", 5), "numComponents"),
    "data_not_object": (_edit("data", []), "data"),
    "no_center": (_edit("data/center", delete=True), "data.center"),
    "center_size": (_edit("data/center", lambda c: c[:3]), "data.center"),
    "component_size": (
        _edit("data/components/1/componentData", lambda c: c[:3]),
        "data.components[1].componentData",
    ),  # fmt: skip
    "original_dim": (
        _edit("data/components/0/originalDofDimension", 16),
        "data.components[0].originalDofDimension",
    ),  # fmt: skip
    "component_nan": (
        _edit("data/components/2/componentData/1", float("nan")),
        "data.components[2].componentData",
    ),  # fmt: skip
    "pc_curve_odd": (
        _edit("data/components/3/controlPointData", lambda c: c[:-1]),
        "data.components[3].controlPointData",
    ),  # fmt: skip
    "pc_curve_units": (_edit("data/components/0/units", "meters"), "data.components[0].units"),
}


@pytest.mark.parametrize("case", sorted(BAD_PCMEXP))
def test_bad_pcmexp(tmp_path: Path, case: str) -> None:
    edit, field = BAD_PCMEXP[case]
    path = write_json(tmp_path / f"{case}.pcmexp", edit(_pcmexp()))
    with pytest.raises(ReferenceError) as err:
        read_pcmexp(path, expected_dofs=4)
    assert_one_line(err, path, field)


@pytest.mark.parametrize("reader", [read_smexp, read_pcmexp])
def test_bad_json_files(tmp_path: Path, reader: Callable[[Path], Any]) -> None:
    truncated = tmp_path / "truncated.json"
    truncated.write_text(json.dumps(_smexp())[:200])
    empty = tmp_path / "empty.json"
    empty.write_text("")
    top_list = write_json(tmp_path / "list.json", [1, 2])
    binary = tmp_path / "binary.json"
    binary.write_bytes(b"\xff\xfe\x00garbage")
    for path in (tmp_path / "missing.smexp", tmp_path, truncated, empty, top_list, binary):
        with pytest.raises(ReferenceError) as err:
            reader(path)
        assert_one_line(err, path, None)


# ------------------------------------------------------------------------------------ the real data

PAPER_DATA = os.environ.get("CONTACTMPC_PAPER_DATA", "")
PAPER_TASKS = {  # allegro.h: slowdown, totalFrames, first contact frame (the contact start data name)
    "apple_pass_1": (8.0, 703, 215),
    "doorknob_use_1": (8.0, 1040, 252),
    "stapler_staple_2": (7.0, 877, 230),
    "waterbottle_pour_1": (5.0, 927, 185),
}


@pytest.mark.skipif(
    not (PAPER_DATA and Path(PAPER_DATA).is_dir()),
    reason="set CONTACTMPC_PAPER_DATA to the authors' mjpc/tasks directory",
)
@pytest.mark.parametrize("task", sorted(PAPER_TASKS))
def test_real_data(task: str) -> None:
    root = Path(PAPER_DATA)
    slowdown, total_frames, first_contact = PAPER_TASKS[task]
    hand = read_smexp(root / "allegro" / "splinetrajectories" / f"{task}_hand.smexp", expected_dofs=22)
    obj = read_smexp(root / "shared_spline_trajectories" / f"{task}_object.smexp", expected_dofs=6)
    pcs = read_pcmexp(root / "allegro" / "pcsplines" / f"{task}.pcmexp", expected_dofs=16)
    contacts = read_contacts(root / "allegro" / "contacts" / "data" / f"{task}.xml")

    assert hand.num_curves == 22 and obj.num_curves == 6 and pcs.num_components == 16
    assert hand.kind[:6] == ("translation",) * 3 + ("rotationBallX", "rotationBallY", "rotationBallZ")
    assert obj.kind == hand.kind[:6] and set(hand.kind[6:]) == {"rotation"}
    assert hand.duration == obj.duration == pcs.duration
    assert pcs.curves.num_control_points == hand.num_control_points
    orth = float(np.abs(pcs.components @ pcs.components.T - np.eye(16)).max())
    assert orth < 1e-6

    num_frames = contacts.num_frames
    assert num_frames == total_frames == round(hand.duration * MOCAP_FPS)
    with_contacts = contacts.frames_with_contacts
    assert with_contacts[0] == first_contact
    counts = contacts.frame_counts[with_contacts]
    assert counts.max() <= 21  # ALLEGRO_MAX_CONTACTS, the size of the C++ buffers

    # The time column runs from frame 0 to F - 1. It is the straight line u * (F - 1) (control points at
    # the Greville abscissae) in every object and PC file, but some hand curves of two tasks were edited:
    # their time columns bend by a few frames. The C++ ignores the time column, so it changes nothing there.
    u = np.linspace(0.0, 1.0, 2001)
    line = np.outer(u * (num_frames - 1), np.ones(22))
    frames = time_column(hand, u)
    bend = np.abs(frames - line).max(axis=0)
    assert np.allclose(frames[[0, -1]], [[0.0] * 22, [num_frames - 1.0] * 22], rtol=0, atol=1e-9)
    assert np.all(np.diff(hand.times, axis=1) > 0)
    for curves in (obj, pcs.curves):
        assert np.abs(time_column(curves, u) - line[:, : curves.num_curves]).max() < 1e-6
    bent = {int(i): round(float(bend[i]), 2) for i in np.flatnonzero(bend > 1e-6)}

    fingers = to_mujoco_units(hand, value_column(hand, u))[:, 6:]
    p = value_column(pcs.curves, u)
    paper_err = float(np.abs(reconstruct(pcs, p) - fingers).max())
    code_err = float(np.abs(reconstruct_as_code(pcs, p) - fingers).max())
    paper_rms = float(np.sqrt(np.mean((reconstruct(pcs, p) - fingers) ** 2)))
    code_rms = float(np.sqrt(np.mean((reconstruct_as_code(pcs, p) - fingers) ** 2)))

    print(
        f"\n{task}: duration {hand.duration:.4f} s = {hand.duration * MOCAP_FPS:.1f} frames, "
        f"slowdown {slowdown:g} (loop {hand.duration * slowdown:.2f} s); control points hand "
        f"{hand.num_control_points}, object {obj.num_control_points}, PC {pcs.curves.num_control_points}\n"
        f"  contacts: {num_frames} frames, {with_contacts.size} with contacts "
        f"({with_contacts[0]}..{with_contacts[-1]}), {contacts.num_contacts} pairs, per frame median "
        f"{np.median(counts):g} max {counts.max()}, frames with > 6: {(counts > 6).sum()}\n"
        f"  body indices: {sorted(set(contacts.body_index.tolist()))}\n"
        f"  time column: u=0 -> {frames[0, 0]:.6f}, u=1 -> {frames[-1, 0]:.6f} (F - 1 = {num_frames - 1}); "
        f"hand curves off the line u * (F-1) (curve: max frames): {bent or 'none'}; "
        f"the contact index uses u * F\n"
        f"  PCs: |C C^T - I| max {orth:.1e}; PC-curves vs hand finger curves (rad): "
        f"center + C^T p max {paper_err:.3f} rms {paper_rms:.3f}, "
        f"as code max {code_err:.3f} rms {code_rms:.3f}"
    )
