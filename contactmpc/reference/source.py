"""Where a trial's reference comes from: a user's ``.npz`` (``task.reference_path``) or the task's
demonstration (``task.demonstration``, chosen in the task's config): a synthetic design of
:mod:`contactmpc.reference.synthetic.designs`, or the authors' data imported by
:class:`contactmpc.reference.paper.demonstration.PaperDemonstration`. A demonstration has
``build(scene) -> Reference`` and says whether its result is worth caching (``cacheable``)."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from contactmpc.reference.data import Reference
from contactmpc.reference.synthetic.demonstration import SYNTHESIS_VERSION
from contactmpc.reference.synthetic.kinematics import SynthesisError
from contactmpc.scene import Scene


def _fingerprint(scene: Scene) -> str:
    """A short hash of everything a synthesis depends on: task, design and hand parameters, versions."""
    from contactmpc import __version__

    def public(obj) -> dict:
        return {
            k: (v.tolist() if isinstance(v, np.ndarray) else v)
            for k, v in sorted(vars(obj).items())
            if not k.startswith("_") and isinstance(v, int | float | str | bool | tuple | list | np.ndarray)
        }

    blob = json.dumps(
        {
            "task": type(scene.task).__name__,
            "t": public(scene.task),
            "h": public(scene.hand),
            "d": f"{type(scene.task.demonstration).__module__}.{type(scene.task.demonstration).__qualname__}",
            "dv": public(scene.task.demonstration),
            "v": __version__,
            "sv": SYNTHESIS_VERSION,
        },
        sort_keys=True,
        default=str,
    )
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def get_reference(scene: Scene, cache_dir: str | Path | None = None) -> Reference:
    """The task's reference, validated against the scene: the hand's joint and link names and joint
    limits, the task's name, object-configuration width and object bodies.

    A task with ``reference_path`` loads that file (a bad file raises
    :class:`~contactmpc.reference.data.ReferenceError` naming the field). Otherwise the task's
    ``demonstration`` design is synthesised (deterministically) and, with ``cache_dir``, cached there
    by a fingerprint of the task, design and hand parameters.

    Args:
        scene: the composed scene.
        cache_dir: optional cache directory for synthesised references.

    Raises:
        SynthesisError: the task has neither a reference file nor a demonstration design, or the
            synthesised reference fails a gate.
    """
    task, hand = scene.task, scene.hand
    names = (hand.joint_names, hand.link_names)
    expect = {
        "task": task.name,
        "object_width": task.layout.width,
        "object_bodies": task.object_bodies,
        "joint_ranges": hand.joint_ranges,
    }
    if task.reference_path:
        return Reference.load(task.reference_path, *names, **expect)
    demo = scene.task.demonstration
    if demo is None:
        raise SynthesisError(
            f"task {scene.task.name!r} has no reference_path and no demonstration design to synthesise"
        )
    path = None
    if cache_dir is not None and demo.cacheable:
        path = Path(cache_dir) / f"{scene.task.name}_{_fingerprint(scene)}.npz"
        if path.exists():
            return Reference.load(path, *names, **expect)
    ref = demo.build(scene)
    ref.validate(*names, **expect)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        ref.save(path)
    return ref
