"""The reference motion: one demonstration as arrays over time, stored as one ``.npz``.

File format (``np.savez_compressed``, loadable with ``allow_pickle=False``; one array per field):

=========================  ===========  ==========  ===================================================
key                        shape        dtype       meaning
=========================  ===========  ==========  ===================================================
``time``                   (T,)         float64     seconds, strictly increasing
``hand_qpos``              (T, J)       float64     the hand's joints: root (wrist) DOFs, then fingers
``object_qpos``            (T, n_o)     float64     object configuration (free-body pos + unit quat
                                                    w, x, y, z at ``meta["object_quat_index"]``, then
                                                    articulation angles)
``contact_active``         (T, L)       bool        expected contact per hand link
``contact_link_point``     (T, L, 3)    float64     contact point, link-local frame
``contact_object_point``   (T, L, 3)    float64     corresponding point, object-body-local frame
``contact_object_body``    (T, L)       integer     index into ``object_bodies`` of that body
``link_names``             (L,)         unicode     hand link (body) names
``joint_names``            (J,)         unicode     hand joint names, in ``hand_qpos`` column order
``object_bodies``          (B,)         unicode     object body names (B >= 1)
``task``                   ()           unicode     task name
``meta``                   ()           unicode     JSON object: source, units, version, time_scale,
                                                    object_quat_index (int or null), ...
=========================  ===========  ==========  ===================================================

Per link and frame the contact is *summarised* (mean of the link's contact area, paper §II-A).
Every problem found on load or by :meth:`Reference.validate` raises :class:`ReferenceError` with a
one-line message naming the file (when loading) and the field.
"""

from __future__ import annotations

import json
import os
import zipfile
from collections.abc import Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["JOINT_LIMIT_TOLERANCE", "QUAT_NORM_TOLERANCE", "Reference", "ReferenceError"]

QUAT_NORM_TOLERANCE = 1e-3
"""Allowed deviation of the object quaternion norm from 1."""

JOINT_LIMIT_TOLERANCE = 0.01
"""How far (rad or m) a reference's joint value may lie outside the hand's joint limits."""

_FLOAT_FIELDS = ("time", "hand_qpos", "object_qpos", "contact_link_point", "contact_object_point")
_STRING_ARRAY_FIELDS = ("link_names", "joint_names", "object_bodies")


class ReferenceError(ValueError):  # shadows the builtin (weakref) ReferenceError inside this module
    """A reference motion is missing, unreadable or malformed.

    The message is one line naming the file (when there is one) and the field.

    Attributes:
        field: the offending field (``None`` for file-level problems).
        path: the file, when the reference was being loaded.
    """

    def __init__(self, message: str, field: str | None = None, path: str | os.PathLike | None = None):
        where = f"{os.fspath(path)}: " if path is not None else ""
        what = f"field '{field}': " if field is not None else ""
        text = " ".join(f"{where}{what}{message}".split())
        super().__init__(text)
        self.field = field
        self.path = None if path is None else os.fspath(path)


@dataclass(eq=False)
class Reference:
    """A demonstration: hand and object configurations and expected contacts over time.

    Shapes: ``T`` frames, ``L`` hand links, ``n_o`` object configuration size, ``B`` object bodies.
    The constructor does not check anything; call :meth:`validate` (``load`` and ``save`` do).

    Attributes:
        time: ``(T,)`` float64 seconds, strictly increasing.
        hand_qpos: ``(T, J)`` float64, in ``joint_names`` order (for the Allegro hand: wrist x, y, z,
            rx, ry, rz then 16 finger joints).
        object_qpos: ``(T, n_o)`` float64; the free-body quaternion (w, x, y, z), if any, starts at
            column ``meta["object_quat_index"]``.
        contact_active: ``(T, L)`` bool, whether link ``l`` is expected in contact.
        contact_link_point: ``(T, L, 3)`` float64, link-local contact point.
        contact_object_point: ``(T, L, 3)`` float64, corresponding object-local point.
        contact_object_body: ``(T, L)`` int, index into ``object_bodies`` of the body that
            ``contact_object_point`` is expressed in (0 for single-body objects).
        link_names: ``(L,)`` str.
        joint_names: ``(J,)`` str, column order of ``hand_qpos``.
        object_bodies: ``(B,)`` str.
        task: task name.
        meta: JSON-serialisable dict (source, units, version, time_scale, object_quat_index, ...).
            Stored as JSON, so it round-trips exactly when it holds only JSON types (a tuple comes
            back as a list, a non-str key as a str).
    """

    time: np.ndarray
    hand_qpos: np.ndarray
    object_qpos: np.ndarray
    contact_active: np.ndarray
    contact_link_point: np.ndarray
    contact_object_point: np.ndarray
    contact_object_body: np.ndarray
    link_names: np.ndarray
    joint_names: np.ndarray
    object_bodies: np.ndarray
    task: str
    meta: dict[str, Any] = field(default_factory=dict)

    # ------------------------------------------------------------------ properties
    @property
    def num_frames(self) -> int:
        """Number of frames ``T``."""
        return int(np.shape(self.time)[0])

    @property
    def num_links(self) -> int:
        """Number of hand links ``L``."""
        return len(self.link_names)

    @property
    def duration(self) -> float:
        """``time[-1] - time[0]`` in seconds."""
        return float(self.time[-1] - self.time[0])

    @property
    def object_quat_index(self) -> int | None:
        """Start column of the object's (w, x, y, z) quaternion in ``object_qpos``, or None."""
        return self.meta.get("object_quat_index")

    # ------------------------------------------------------------------ validation
    def validate(
        self,
        expected_joint_names: Sequence[str] | None = None,
        expected_link_names: Sequence[str] | None = None,
        *,
        task: str | None = None,
        object_width: int | None = None,
        object_bodies: Sequence[str] | None = None,
        joint_ranges: np.ndarray | None = None,
        path: str | os.PathLike | None = None,
    ) -> None:
        """Check every field; raise on the first problem.

        The keyword expectations come from the scene the reference is for (see
        :func:`contactmpc.reference.source.get_reference`); each is checked when given.

        Args:
            expected_joint_names: the hand's joint names in qpos order, if known (they fix ``J``;
                otherwise ``J`` is the length of the reference's own ``joint_names``).
            expected_link_names: the hand links the contacts must refer to, in order, if known.
            task: the task's name; the reference's ``task`` must equal it.
            object_width: ``n_o`` of the task's object configuration.
            object_bodies: the task's object bodies, in order.
            joint_ranges: (J, 2) the hand's joint limits; values beyond them by more than
                :data:`JOINT_LIMIT_TOLERANCE` are refused.
            path: file name to put in error messages.

        Raises:
            ReferenceError: one-line message naming the field (and ``path``).
        """

        def fail(name: str, message: str) -> None:
            raise ReferenceError(message, field=name, path=path)

        for f in fields(self):
            if getattr(self, f.name) is None:
                fail(f.name, "missing")

        # dtypes
        for name in _FLOAT_FIELDS:
            arr = np.asarray(getattr(self, name))
            if arr.dtype != np.float64:
                fail(name, f"expected dtype float64, got {arr.dtype}")
        if np.asarray(self.contact_active).dtype != np.bool_:
            fail("contact_active", f"expected dtype bool, got {np.asarray(self.contact_active).dtype}")
        body = np.asarray(self.contact_object_body)
        if body.dtype.kind not in "iu":
            fail("contact_object_body", f"expected an integer dtype, got {body.dtype}")
        for name in _STRING_ARRAY_FIELDS:
            arr = np.asarray(getattr(self, name))
            if arr.dtype.kind != "U" or arr.ndim != 1:
                fail(name, f"expected a 1-D array of str, got dtype {arr.dtype} shape {arr.shape}")
        if not isinstance(self.task, str):
            fail("task", f"expected str, got {type(self.task).__name__}")
        if not isinstance(self.meta, dict):
            fail("meta", f"expected dict, got {type(self.meta).__name__}")

        if task is not None and self.task != task:
            fail("task", f"the reference is for task {self.task!r}, not {task!r}")

        # shapes
        time = np.asarray(self.time)
        if time.ndim != 1 or time.shape[0] < 1:
            fail("time", f"expected shape (T,) with T >= 1, got {time.shape}")
        num_t = time.shape[0]
        num_l = len(self.link_names)
        num_j = len(self.joint_names if expected_joint_names is None else expected_joint_names)
        num_b = len(self.object_bodies)
        if num_b < 1:
            fail("object_bodies", "expected at least one object body, got none")
        object_qpos = np.asarray(self.object_qpos)
        expected = {
            "hand_qpos": ((num_t, num_j), "(T, J)"),
            "object_qpos": ((num_t, object_qpos.shape[-1] if object_qpos.ndim == 2 else -1), "(T, n_o)"),
            "contact_active": ((num_t, num_l), "(T, L)"),
            "contact_link_point": ((num_t, num_l, 3), "(T, L, 3)"),
            "contact_object_point": ((num_t, num_l, 3), "(T, L, 3)"),
            "contact_object_body": ((num_t, num_l), "(T, L)"),
            "joint_names": ((num_j,), "(J,)"),
        }
        for name, (shape, label) in expected.items():
            got = np.shape(getattr(self, name))
            if got != shape:
                sources = {"T": "T from 'time'", "L": "L from 'link_names'", "J": "J from the joint names"}
                origin = ", ".join(v for k, v in sources.items() if k in label)
                fail(name, f"expected shape {label} = {shape} ({origin}), got {got}")

        # values
        for name in _FLOAT_FIELDS:
            arr = np.asarray(getattr(self, name))
            bad = ~np.isfinite(arr)
            if bad.any():
                idx = tuple(int(i) for i in np.argwhere(bad)[0])
                fail(name, f"non-finite value {arr[idx]} at index {idx}")
        steps = np.diff(time)
        if np.any(steps <= 0):
            i = int(np.flatnonzero(steps <= 0)[0])
            fail("time", f"not strictly increasing: time[{i}]={time[i]} >= time[{i + 1}]={time[i + 1]}")
        if body.size and (body.min() < 0 or body.max() >= num_b):
            idx = tuple(int(i) for i in np.argwhere((body < 0) | (body >= num_b))[0])
            fail("contact_object_body", f"index {body[idx]} at {idx} out of range [0, {num_b})")
        self._validate_quaternion(object_qpos, fail)
        self._validate_names("joint_names", self.joint_names, expected_joint_names, fail)
        self._validate_names("link_names", self.link_names, expected_link_names, fail)
        self._validate_names("object_bodies", self.object_bodies, object_bodies, fail)
        if object_width is not None and object_qpos.shape[1] != object_width:
            fail(
                "object_qpos",
                f"has {object_qpos.shape[1]} columns, but the task's object configuration has {object_width}",
            )
        if joint_ranges is not None:
            self._validate_limits(np.asarray(joint_ranges, float), fail)
        try:
            json.dumps(self.meta, allow_nan=False)
        except (TypeError, ValueError) as err:
            fail("meta", f"not JSON-serialisable: {err}")

    def _validate_limits(self, ranges: np.ndarray, fail) -> None:
        hand = np.asarray(self.hand_qpos)
        excess = np.maximum(ranges[:, 0] - hand, hand - ranges[:, 1])
        bad = excess > JOINT_LIMIT_TOLERANCE
        if bad.any():
            frame, joint = (int(i) for i in np.argwhere(bad)[0])
            name = str(np.asarray(self.joint_names)[joint])
            lo, hi = ranges[joint]
            fail(
                "hand_qpos",
                f"joint {name!r} = {hand[frame, joint]:.4g} at frame {frame} is outside its limits "
                f"[{lo:.4g}, {hi:.4g}] by {excess[frame, joint]:.3g} (tolerance {JOINT_LIMIT_TOLERANCE}; "
                f"{int(bad.sum())} values in all)",
            )

    def _validate_quaternion(self, object_qpos: np.ndarray, fail) -> None:
        index = self.meta.get("object_quat_index")
        if index is None:
            return
        if isinstance(index, bool) or not isinstance(index, int | np.integer):
            fail("meta.object_quat_index", f"expected int or None, got {index!r}")
        n_o = object_qpos.shape[1]
        if not 0 <= index <= n_o - 4:
            fail("meta.object_quat_index", f"{index} leaves no room for 4 quaternion columns in n_o={n_o}")
        norms = np.linalg.norm(object_qpos[:, index : index + 4], axis=1)
        bad = np.abs(norms - 1.0) > QUAT_NORM_TOLERANCE
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            fail(
                "object_qpos",
                f"quaternion at columns {index}:{index + 4} has norm {norms[i]:.6g} at frame {i} "
                f"(tolerance {QUAT_NORM_TOLERANCE})",
            )

    @staticmethod
    def _validate_names(name: str, names: np.ndarray, expected: Sequence[str] | None, fail) -> None:
        if expected is None:
            return
        got = [str(n) for n in np.asarray(names).tolist()]
        want = [str(n) for n in expected]
        if got == want:
            return
        if len(got) != len(want):
            fail(name, f"expected {len(want)} names {want}, got {len(got)} names {got}")
        i = next(i for i, (g, w) in enumerate(zip(got, want, strict=True)) if g != w)
        fail(name, f"mismatch at index {i}: expected {want[i]!r}, got {got[i]!r}")

    # ------------------------------------------------------------------ I/O
    def as_arrays(self) -> dict[str, np.ndarray]:
        """The npz payload: one array per field (``task`` and ``meta`` as 0-d unicode arrays)."""
        out: dict[str, np.ndarray] = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "meta":
                out[f.name] = np.array(json.dumps(value, allow_nan=False, sort_keys=True))
            elif f.name == "task":
                out[f.name] = np.array(str(value))
            elif f.name in _STRING_ARRAY_FIELDS:
                out[f.name] = np.asarray(value, dtype=str)
            else:
                out[f.name] = np.asarray(value)
        return out

    def save(self, path: str | os.PathLike) -> Path:
        """Validate, then write the reference atomically as a compressed ``.npz``.

        Args:
            path: destination; ``.npz`` is appended when missing (as numpy does).

        Returns:
            The path written.

        Raises:
            ReferenceError: if the reference is malformed (nothing is written).
        """
        dest = Path(path)
        if dest.suffix != ".npz":
            dest = dest.with_name(dest.name + ".npz")
        self.validate(path=dest)
        tmp = dest.with_name(f".{dest.name}.{os.getpid()}.tmp")
        try:
            with open(tmp, "wb") as fh:
                np.savez_compressed(fh, **self.as_arrays())
            os.replace(tmp, dest)
        finally:
            if tmp.exists():
                tmp.unlink()
        return dest

    @classmethod
    def load(
        cls,
        path: str | os.PathLike,
        joint_names: Sequence[str] | None = None,
        link_names: Sequence[str] | None = None,
        **expected: Any,
    ) -> Reference:
        """Read and validate a reference ``.npz`` (never unpickles).

        Args:
            path: the file.
            joint_names: expected hand joint names (qpos order), checked when given.
            link_names: expected hand link names, checked when given.
            **expected: the other expectations of :meth:`validate` (task, object_width,
                object_bodies, joint_ranges).

        Returns:
            The reference, arrays exactly as stored.

        Raises:
            ReferenceError: file missing or not an npz archive, a field missing, unreadable or
                malformed (one line, naming the file and the field).
        """
        path = Path(path)
        if path.is_dir():
            raise ReferenceError("is a directory, not a reference file", path=path)
        if not path.is_file():
            raise ReferenceError("file not found", path=path)
        if not zipfile.is_zipfile(path):
            with open(path, "rb") as fh:
                magic = fh.read(6)
            what = "a single .npy array" if magic == b"\x93NUMPY" else "not a zip archive of .npy arrays"
            raise ReferenceError(f"not an .npz archive ({what})", path=path)
        try:
            archive = np.load(path, allow_pickle=False)
        except (OSError, ValueError, zipfile.BadZipFile, EOFError) as err:
            raise ReferenceError(f"not a readable .npz archive ({err})", path=path) from err
        if not isinstance(archive, np.lib.npyio.NpzFile):
            raise ReferenceError("not an .npz archive (a single .npy array)", path=path)
        values: dict[str, Any] = {}
        with archive:
            for f in fields(cls):
                if f.name not in archive.files:
                    raise ReferenceError("missing", field=f.name, path=path)
                try:
                    values[f.name] = archive[f.name]
                except (OSError, ValueError, zipfile.BadZipFile, EOFError) as err:
                    raise ReferenceError(f"unreadable ({err})", field=f.name, path=path) from err
        for name in ("task", "meta"):
            arr = values[name]
            if arr.shape != () or arr.dtype.kind != "U":
                raise ReferenceError(
                    f"expected a 0-d unicode array, got dtype {arr.dtype} shape {arr.shape}",
                    field=name,
                    path=path,
                )
            values[name] = str(arr)
        try:
            meta = json.loads(values["meta"])
        except json.JSONDecodeError as err:
            raise ReferenceError(f"not valid JSON ({err})", field="meta", path=path) from err
        if not isinstance(meta, dict):
            raise ReferenceError(
                f"expected a JSON object, got {type(meta).__name__}", field="meta", path=path
            )
        values["meta"] = meta
        ref = cls(**values)
        ref.validate(joint_names, link_names, path=path, **expected)
        return ref
