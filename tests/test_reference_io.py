"""The ``Reference`` npz format: exact round trip and one clear error per malformed case."""

from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pytest

from contactmpc.reference import Reference, ReferenceError
from contactmpc.reference.data import JOINT_LIMIT_TOLERANCE

JOINTS = [f"wrist_{a}" for a in ("x", "y", "z", "rx", "ry", "rz")] + [
    f"{f}j{i}" for f in ("ff", "mf", "rf", "th") for i in range(4)
]
LINKS = ["palm", "ff_distal", "ff_tip", "mf_tip", "rf_tip", "th_tip", "th_distal"]


def _reference(num_frames: int = 30) -> Reference:
    rng = np.random.default_rng(0)
    num_links = len(LINKS)
    quat = rng.normal(size=(num_frames, 4))
    quat /= np.linalg.norm(quat, axis=1, keepdims=True)
    object_qpos = np.concatenate(
        [rng.normal(size=(num_frames, 3)), quat, rng.normal(size=(num_frames, 1))], 1
    )
    return Reference(
        time=np.linspace(0.0, 2.9, num_frames),
        hand_qpos=rng.normal(size=(num_frames, 22)),
        object_qpos=object_qpos,
        contact_active=rng.random((num_frames, num_links)) < 0.5,
        contact_link_point=rng.normal(size=(num_frames, num_links, 3)),
        contact_object_point=rng.normal(size=(num_frames, num_links, 3)),
        contact_object_body=rng.integers(0, 2, size=(num_frames, num_links)),
        link_names=np.array(LINKS),
        joint_names=np.array(JOINTS),
        object_bodies=np.array(["stapler_base", "stapler_top"]),
        task="stapler",
        meta={
            "source": "synthetic",
            "units": "m, rad, s",
            "version": 1,
            "time_scale": 5.0,
            "object_quat_index": 3,
        },
    )


def _assert_one_line_error(err: pytest.ExceptionInfo, field: str, path: Path | None = None) -> None:
    message = str(err.value)
    assert field in message, message
    assert "\n" not in message and "\r" not in message, message
    if path is not None:
        assert str(path) in message, message
    assert isinstance(err.value, ValueError)


def test_round_trip_is_exact(tmp_path: Path) -> None:
    ref = _reference()
    written = ref.save(tmp_path / "ref.npz")
    assert written == tmp_path / "ref.npz"
    loaded = Reference.load(written, joint_names=JOINTS, link_names=LINKS)
    for f in fields(Reference):
        a, b = getattr(ref, f.name), getattr(loaded, f.name)
        if f.name in ("task", "meta"):
            assert a == b
        else:
            assert np.array_equal(a, b), f.name
            assert np.asarray(a).dtype == b.dtype, f.name
    assert loaded.num_links == len(LINKS)
    assert loaded.num_frames == 30
    assert loaded.duration == pytest.approx(2.9)
    # No pickles inside: numpy can read it with allow_pickle=False.
    with np.load(written, allow_pickle=False) as archive:
        assert sorted(archive.files) == sorted(f.name for f in fields(Reference))
    # Suffix appended like numpy does; no free body is allowed.
    ref2 = replace(ref, meta={"object_quat_index": None})
    assert ref2.save(tmp_path / "noext") == tmp_path / "noext.npz"
    assert Reference.load(tmp_path / "noext.npz").meta == {"object_quat_index": None}


def _write(path: Path, **overrides) -> Path:
    arrays = _reference().as_arrays()
    for key, value in overrides.items():
        if value is None:
            arrays.pop(key)
        else:
            arrays[key] = value
    np.savez(path, **arrays)
    return path


def _bad_quat() -> np.ndarray:
    qpos = _reference().object_qpos.copy()
    qpos[7, 3:7] *= 1.01
    return qpos


def _nan(name: str, index: tuple) -> np.ndarray:
    arr = getattr(_reference(), name).astype(np.float64, copy=True)
    arr[index] = np.inf if len(index) == 1 else np.nan
    return arr


REF = _reference()
T, L = REF.contact_active.shape
MALFORMED = {
    "missing_time": ("time", {"time": None}),
    "missing_meta": ("meta", {"meta": None}),
    "missing_contact_object_body": ("contact_object_body", {"contact_object_body": None}),
    "hand_qpos_21": ("hand_qpos", {"hand_qpos": REF.hand_qpos[:, :21]}),
    "hand_qpos_T": ("hand_qpos", {"hand_qpos": REF.hand_qpos[:-1]}),
    "hand_qpos_int": ("hand_qpos", {"hand_qpos": REF.hand_qpos.astype(np.int64)}),
    "time_2d": ("time", {"time": REF.time[:, None]}),
    "object_qpos_T": ("object_qpos", {"object_qpos": REF.object_qpos[1:]}),
    "contact_active_T": ("contact_active", {"contact_active": REF.contact_active[1:]}),
    "contact_active_L": ("contact_active", {"contact_active": REF.contact_active[:, 1:]}),
    "contact_active_float": ("contact_active", {"contact_active": REF.contact_active.astype(float)}),
    "contact_link_point_L": ("contact_link_point", {"contact_link_point": REF.contact_link_point[:, :-1]}),
    "contact_object_point_2": (
        "contact_object_point",
        {"contact_object_point": REF.contact_object_point[..., :2]},
    ),
    "contact_object_point_T": (
        "contact_object_point",
        {"contact_object_point": REF.contact_object_point[:-2]},
    ),
    "contact_object_body_float": (
        "contact_object_body",
        {"contact_object_body": REF.contact_object_body.astype(float)},
    ),
    "contact_object_body_range": (
        "contact_object_body",
        {"contact_object_body": np.where(np.arange(L) == 2, 2, REF.contact_object_body)},
    ),
    "contact_object_body_negative": (
        "contact_object_body",
        {"contact_object_body": -np.ones((T, L), dtype=np.int64)},
    ),
    "nan_hand_qpos": ("hand_qpos", {"hand_qpos": _nan("hand_qpos", (4, 10))}),
    "inf_time": ("time", {"time": _nan("time", (5,))}),
    "nan_object_qpos": ("object_qpos", {"object_qpos": _nan("object_qpos", (2, 7))}),
    "nan_contact_link_point": (
        "contact_link_point",
        {"contact_link_point": _nan("contact_link_point", (1, 2, 0))},
    ),
    "nan_contact_object_point": (
        "contact_object_point",
        {"contact_object_point": _nan("contact_object_point", (3, 0, 2))},
    ),
    "time_not_increasing": ("time", {"time": np.where(np.arange(T) == 9, REF.time[8], REF.time)}),
    "quat_not_unit": ("object_qpos", {"object_qpos": _bad_quat()}),
    "quat_index_out_of_range": (
        "object_quat_index",
        {"meta": np.array('{"object_quat_index": 6}')},
    ),
    "joint_names_wrong": ("joint_names", {"joint_names": np.array(JOINTS[:7] + ["bogus"] + JOINTS[8:])}),
    "joint_names_short": ("joint_names", {"joint_names": np.array(JOINTS[:-1])}),
    "link_names_wrong": ("link_names", {"link_names": np.array(LINKS[::-1])}),
    "link_names_not_str": ("link_names", {"link_names": np.arange(L)}),
    "object_bodies_empty": ("object_bodies", {"object_bodies": np.array([], dtype=str)}),
    "task_not_str": ("task", {"task": np.array([1, 2])}),
    "meta_not_json": ("meta", {"meta": np.array("{not json")}),
    "meta_not_object": ("meta", {"meta": np.array("[1, 2]")}),
}


@pytest.mark.parametrize("case", sorted(MALFORMED))
def test_malformed_file_raises_one_line_error_naming_field(tmp_path: Path, case: str) -> None:
    field, overrides = MALFORMED[case]
    path = _write(tmp_path / f"{case}.npz", **overrides)
    with pytest.raises(ReferenceError) as err:
        Reference.load(path, joint_names=JOINTS, link_names=LINKS)
    _assert_one_line_error(err, field, path)
    assert err.value.field is not None and field in err.value.field


def test_object_arrays_are_refused_without_unpickling(tmp_path: Path) -> None:
    path = _write(tmp_path / "obj.npz", link_names=np.array(LINKS, dtype=object))
    with pytest.raises(ReferenceError) as err:
        Reference.load(path)
    _assert_one_line_error(err, "link_names", path)


def test_file_level_errors(tmp_path: Path) -> None:
    missing = tmp_path / "nowhere.npz"
    with pytest.raises(ReferenceError) as err:
        Reference.load(missing)
    _assert_one_line_error(err, "not found", missing)

    text = tmp_path / "text.npz"
    text.write_text("hello\nworld\n")
    with pytest.raises(ReferenceError) as err:
        Reference.load(text)
    _assert_one_line_error(err, "npz", text)

    broken = tmp_path / "broken.npz"
    broken.write_bytes(b"PK\x03\x04" + b"\x00" * 50)
    with pytest.raises(ReferenceError) as err:
        Reference.load(broken)
    _assert_one_line_error(err, "npz", broken)

    npy = tmp_path / "array.npy"
    np.save(npy, np.zeros(3))
    with pytest.raises(ReferenceError) as err:
        Reference.load(npy)
    _assert_one_line_error(err, "npz", npy)


def test_validate_in_memory_and_save_refuses_malformed(tmp_path: Path) -> None:
    ref = _reference()
    ref.validate(JOINTS, LINKS)
    with pytest.raises(ReferenceError) as err:
        replace(ref, hand_qpos=ref.hand_qpos[:, :-1]).validate()
    _assert_one_line_error(err, "hand_qpos")
    with pytest.raises(ReferenceError) as err:
        replace(ref, task=None).validate()
    _assert_one_line_error(err, "task")
    with pytest.raises(ReferenceError) as err:
        replace(ref, meta={"bad": object()}).validate()
    _assert_one_line_error(err, "meta")
    with pytest.raises(ReferenceError) as err:
        replace(ref, time=ref.time.astype(np.float32)).save(tmp_path / "f32.npz")
    _assert_one_line_error(err, "time", tmp_path / "f32.npz")
    assert not (tmp_path / "f32.npz").exists()
    assert list(tmp_path.iterdir()) == []


def test_directory_and_renamed_text_file_are_named_for_what_they_are(tmp_path: Path) -> None:
    with pytest.raises(ReferenceError) as err:
        Reference.load(tmp_path)
    _assert_one_line_error(err, "is a directory", tmp_path)
    text = tmp_path / "notes.npz"
    text.write_text("not an archive\n")
    with pytest.raises(ReferenceError) as err:
        Reference.load(text)
    _assert_one_line_error(err, "not a zip archive", text)
    assert "pickle" not in str(err.value)


# ------------------------------------------------------------------ against the task and the hand
def test_reference_is_checked_against_the_task(tmp_path: Path) -> None:
    path = _write(tmp_path / "ref.npz")
    ref = Reference.load(path)
    width = ref.object_qpos.shape[1]
    good = {"task": ref.task, "object_width": width, "object_bodies": list(ref.object_bodies)}
    Reference.load(path, JOINTS, LINKS, **good)
    cases = {
        "task": {**good, "task": "apple_but_not_this_one"},
        "object_qpos": {**good, "object_width": width + 1},
        "object_bodies": {**good, "object_bodies": ["door", "knob"]},
    }
    for field, expect in cases.items():
        with pytest.raises(ReferenceError) as err:
            Reference.load(path, JOINTS, LINKS, **expect)
        _assert_one_line_error(err, field, path)
        assert err.value.field == field


def test_joint_values_beyond_the_limits_are_refused(tmp_path: Path) -> None:
    ref = _reference()
    ranges = np.tile([-1.0, 1.0], (len(JOINTS), 1))
    ranges[:6] = [-10.0, 10.0]
    ref.hand_qpos[:] = 0.0
    ref.hand_qpos[5, 9] = 1.0 + 0.5 * JOINT_LIMIT_TOLERANCE  # within the tolerance
    ref.validate(JOINTS, LINKS, joint_ranges=ranges)
    ref.hand_qpos[7, 9] = 1.2
    with pytest.raises(ReferenceError) as err:
        ref.validate(JOINTS, LINKS, joint_ranges=ranges)
    _assert_one_line_error(err, "hand_qpos")
    assert JOINTS[9] in str(err.value) and "frame 7" in str(err.value)


def test_a_reference_of_another_task_is_refused_by_the_trial_path(tmp_path: Path, scene_for) -> None:
    """Seen before the fix: a bottle reference given to the apple task ran to a status-ok record."""
    from contactmpc.reference.source import get_reference
    from tests.helpers import static_reference

    # a short reference of the bottle (not a synthesised one: what the trial path reads is the same)
    path = static_reference(scene_for("bottle"), duration=0.2, frames=6).save(tmp_path / "bottle.npz")
    get_reference(scene_for("bottle", f"task.reference_path={path}"))  # the bottle's own: accepted
    apple = scene_for("apple", f"task.reference_path={path}")
    with pytest.raises(ReferenceError) as err:
        get_reference(apple)
    _assert_one_line_error(err, "the reference is for task 'bottle', not 'apple'", path)
