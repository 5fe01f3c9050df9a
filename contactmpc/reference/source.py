"""Where a trial's reference comes from: a user's ``.npz`` or the task's synthesised demonstration."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from contactmpc.reference.data import Reference
from contactmpc.reference.synthetic.demonstration import synthesize
from contactmpc.reference.synthetic.designs import DEMOS
from contactmpc.reference.synthetic.kinematics import SynthesisError
from contactmpc.scene import Scene


def _fingerprint(scene: Scene) -> str:
    """A short hash of everything a synthesis depends on: task and hand parameters, package version."""
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
            "v": __version__,
        },
        sort_keys=True,
        default=str,
    )
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def get_reference(scene: Scene, cache_dir: str | Path | None = None) -> Reference:
    """The task's reference, validated against the hand's joint and link names.

    A task with ``reference_path`` loads that file (a bad file raises
    :class:`~contactmpc.reference.data.ReferenceError` naming the field). Otherwise the task's
    demonstration (:data:`~contactmpc.reference.synthetic.designs.DEMOS`) is synthesised
    (deterministically) and, with ``cache_dir``, cached there by a fingerprint of the task and hand
    parameters.

    Args:
        scene: the composed scene.
        cache_dir: optional cache directory for synthesised references.

    Raises:
        SynthesisError: no synthetic demonstration for the task, or its reference fails a gate.
    """
    names = {"joint_names": scene.hand.joint_names, "link_names": scene.hand.link_names}
    if scene.task.reference_path:
        return Reference.load(scene.task.reference_path, **names)
    path = None
    if cache_dir is not None:
        path = Path(cache_dir) / f"{scene.task.name}_{_fingerprint(scene)}.npz"
        if path.exists():
            return Reference.load(path, **names)
    demo = DEMOS.get(scene.task.name)
    if demo is None:
        name = scene.task.name
        raise SynthesisError(f"no synthetic demonstration for task {name!r} (known: {sorted(DEMOS)})")
    ref = synthesize(scene, demo)
    ref.validate(scene.hand.joint_names, scene.hand.link_names)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        ref.save(path)
    return ref
