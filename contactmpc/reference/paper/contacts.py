"""The authors' contact files: ``contacts/data/<task>.xml``, per-frame hand/object contact pairs.

A MuJoCo ``<custom><numeric>`` XML, read by :func:`read_contacts`: ``contact_numdata_<f> = [offset,
count]`` per mocap frame ``f``; ``contact_pos_hand_data_<f>_<k> = [bodyIndex, x, y, z]`` (metres, in the
frame of body ``bodyIndex`` of the authors' compiled model) and ``contact_pos_object_data_<f>_<k> = [x,
y, z]`` (metres, object body frame). ``offset`` is the number of contacts of the frames before ``f``: the
C++ (``mjpc/tasks/allegro/allegro.cc``) finds contact ``k`` of frame ``f`` as the numeric element
``offset + k`` places after the first contact element. This reader goes by the element *names* instead
and checks that the offsets agree with them.

Every problem raises :class:`~contactmpc.reference.data.ReferenceError`, one line naming the file and
the element. Which frame the C++ looks up at a simulation time is
:func:`~contactmpc.reference.paper.evaluation.contact_frame_index`.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from contactmpc.reference.data import ReferenceError
from contactmpc.reference.paper.fields import PathLike, check_file, frozen

__all__ = ["ContactFrames", "FrameContacts", "read_contacts"]

_NUMDATA = re.compile(r"contact_numdata_(\d+)")
_POS = re.compile(r"contact_pos_(hand|object)_data_(\d+)_(\d+)")
_POS_SIZE = {"hand": 4, "object": 3}


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
            "body_index": frozen(self.body_index, np.int64),
            "hand_point": frozen(self.hand_point, np.float64).reshape(-1, 3),
            "object_point": frozen(self.object_point, np.float64).reshape(-1, 3),
            "frame_offsets": frozen(self.frame_offsets, np.int64),
            "frame_counts": frozen(self.frame_counts, np.int64),
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


# -------------------------------------------------------------------------------------------- reader
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
    check_file(path)
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
