"""The reference-report job (``conf/job/reference_report.yaml``): a reference's quality gates."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from contactmpc.records import write_json
from contactmpc.reference.source import get_reference
from contactmpc.reference.synthetic.gates import check_gates, gate_report
from contactmpc.scene import Scene


def reference_report(make_scene: Callable[[], Scene], output_dir: str | Path, **_) -> Path:
    """Print the quality-gate report of the task's reference and write it as ``gates_<task>.json``."""
    scene = make_scene()
    ref = get_reference(scene, None)
    report = gate_report(scene, ref)
    print(
        f"reference of task {scene.task.name}: {ref.num_frames} frames, {ref.duration:.2f} s "
        f"(x{scene.task.time_scale:g} slowed: {ref.duration * scene.task.time_scale:.1f} s)"
    )
    for key, value in report.items():
        print(f"  {key:<40} {value}")
    check_gates(report, task=scene.task.name)
    print("  all gates pass")
    return write_json(Path(output_dir) / f"gates_{scene.task.name}.json", report)
