"""The reference-report job (``conf/job/reference_report.yaml``): a reference's kinematic consistency,
and for a synthesised reference its quality gates."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from contactmpc.records import write_json
from contactmpc.reference.consistency import consistency_report
from contactmpc.reference.source import get_reference
from contactmpc.reference.synthetic.gates import check_gates, gate_report
from contactmpc.scene import Scene


def reference_report(make_scene: Callable[[], Scene], output_dir: str | Path, **_) -> Path:
    """Print the task's reference's consistency (:func:`~contactmpc.reference.consistency.consistency_report`)
    and, for a synthesised reference, its quality gates (which must pass); write both as
    ``reference_<task>.json``."""
    scene = make_scene()
    ref = get_reference(scene, None)
    source = ref.meta.get("source", "file")
    print(
        f"reference of task {scene.task.name} ({source}): {ref.num_frames} frames, {ref.duration:.2f} s "
        f"(x{scene.task.time_scale:g} slowed: {ref.duration * scene.task.time_scale:.1f} s)"
    )
    consistency = consistency_report(scene, ref)
    print("  kinematic consistency (played back):")
    for key, value in consistency.items():
        if key != "penetration_per_frame":
            print(f"    {key:<38} {_fmt(value)}")
    report = {"task": scene.task.name, "source": source, "consistency": consistency}
    if source == "synthetic":  # the gates are the synthesiser's promises; an imported motion has none
        gates = gate_report(scene, ref)
        print("  quality gates:")
        for key, value in gates.items():
            print(f"    {key:<38} {_fmt(value)}")
        report["gates"] = gates
        check_gates(gates, task=scene.task.name)
        print("  all gates pass")
    if ref.meta.get("clipped"):
        clipped = ref.meta["clipped"]
        worst = max(v["max_excess"] for v in clipped.values())
        print(f"  finger angles clipped to the hand's limits: {len(clipped)} joints, by <= {worst:.4f} rad")
        report["clipped"] = ref.meta["clipped"]
    return write_json(Path(output_dir) / f"reference_{scene.task.name}.json", report)


def _fmt(value) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)
