"""Config schemas: plain dataclasses mirroring the constructors that Hydra instantiates.

They give the YAML files in ``conf/`` a schema, so a misspelt key or a wrong type fails when the
config is composed, with Hydra's own error. This module does not import Hydra: ``launch.py`` stores
these dataclasses in Hydra's ``ConfigStore`` (see :func:`launch.register_configs`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

# ----------------------------------------------------------------------------------------- hand


@dataclass
class AllegroHandConf:
    _target_: str = "contactmpc.hands.AllegroHand"
    kp_finger: float = 10.0
    damping_finger: float = 1.0
    armature_finger: float = 0.01
    force_limit_finger: float = 0.7
    kp_slide: float = 600.0
    damping_slide: float = 60.0
    kp_hinge: float = 40.0
    damping_hinge: float = 3.0
    slide_range: list[float] = field(default_factory=lambda: [-1.0, 1.0])
    # Wider than +-pi so that palm-down poses (rx = pi) sit inside the wrist's range.
    hinge_range: list[float] = field(default_factory=lambda: [-6.2832, 6.2832])
    gravcomp: bool = True
    name: str = "allegro_right"


# ---------------------------------------------------------------------------------------- tasks


@dataclass
class TaskConf:
    _target_: str = "???"
    hand_home: list[float] = field(default_factory=lambda: [0.0] * 22)
    time_scale: float = 5.0
    reference_path: str | None = None
    demonstration: Any = None


@dataclass
class AppleConf(TaskConf):
    _target_: str = "contactmpc.tasks.AppleTask"
    radius: float = 0.041
    height_ratio: float = 0.9
    mass: float = 0.2
    position: list[float] = field(default_factory=lambda: [0.0, 0.0])
    friction: float = 1.0


@dataclass
class BottleConf(TaskConf):
    _target_: str = "contactmpc.tasks.BottleTask"
    radius: float = 0.0325
    height: float = 0.20
    mass: float = 0.45
    position: list[float] = field(default_factory=lambda: [0.0, 0.0])
    friction: float = 0.9


@dataclass
class StaplerConf(TaskConf):
    _target_: str = "contactmpc.tasks.StaplerTask"
    length: float = 0.16
    width: float = 0.04
    base_mass: float = 0.2
    top_mass: float = 0.15
    open_angle: float = 0.22
    spring_stiffness: float = 1.5
    spring_rest: float = 0.35
    position: list[float] = field(default_factory=lambda: [0.0, 0.0])
    friction: float = 0.9


@dataclass
class DoorknobConf(TaskConf):
    _target_: str = "contactmpc.tasks.DoorknobTask"
    door_width: float = 0.5
    door_height: float = 0.8
    door_thickness: float = 0.03
    door_mass: float = 3.0
    knob_height: float = 0.4
    knob_radius: float = 0.028
    knob_offset: float = 0.07
    knob_stiffness: float = 0.3
    max_knob_angle: float = 1.2
    unlock_angle: float = 0.7
    bolt_throw: float = 0.012
    play: float = 0.002
    door_damping: float = 0.5


# ---------------------------------------------------------------------------------------- scene


@dataclass
class SceneConf:
    _target_: str = "contactmpc.scene.Scene"
    _partial_: bool = True
    plant_timestep: float = 0.001
    planner_timestep: float = 0.01
    integrator: str = "implicitfast"
    cone: str = "elliptic"
    impratio: float = 10.0


# ------------------------------------------------------------- controller (filled in by issue 4)


@dataclass
class CostConf:
    """Eq. 2 of the paper: lambda_o |q_o^ - q_o|^2 + lambda_c |c(q_a) - c(q_o)|^2 + lambda_v |dq_a|^2."""

    _target_: str = "contactmpc.control.cost.TrackingCost"
    lambda_o: float = 1.0
    lambda_c: float = 1.0
    lambda_v: float = 0.01
    rotation_weight: float = 0.1
    articulation_weight: float = 1.0


@dataclass
class SamplerConf:
    """Where samples live: PC-curves (paper) or joint curves (ablation)."""

    _target_: str = "???"
    sigma2: float = 0.2
    root_sigma2: float = 0.0
    whiten: bool = False
    num_components: int | None = None


@dataclass
class PlannerConf:
    """Paper defaults: 128 samples, 2.5 s horizon, replanning every 10 ms."""

    _target_: str = "???"
    num_samples: int = 128
    horizon: float = 2.5
    replan_period: float = 0.01
    nthread: int | None = None


@dataclass
class MPPIConf(PlannerConf):
    temperature: float = 0.1


@dataclass
class CEMConf(PlannerConf):
    num_elites: int = 8
    min_std_ratio: float = 0.1
    max_std_ratio: float = 1.0


# ----------------------------------------------------------------------------------------- jobs


@dataclass
class TrialJobConf:
    _target_: str = "contactmpc.jobs.trial.run_trial"
    _partial_: bool = True
    sampler: Any = "${sampler}"
    cost: Any = "${cost}"
    planner: Any = "${planner}"
    num_control_points: int | None = None
    duration: float | None = "${duration}"
    progress: bool = True
    failure_gap: float = 0.3
    failure_min_expected: int = 6
    reference_cache: str | None = "outputs/cache/references"
    video: str | None = None
    video_speed: float = 1.0


@dataclass
class BenchmarkJobConf:
    _target_: str = "contactmpc.jobs.benchmark.benchmark_planner"
    _partial_: bool = True
    sampler: Any = "${sampler}"
    cost: Any = "${cost}"
    planner: Any = "${planner}"
    threads: list[int] = field(default_factory=lambda: [1, 2])
    repeats: int = 10
    at_fraction: float = 0.5
    reference_cache: str | None = "outputs/cache/references"


@dataclass
class WriteReferenceJobConf:
    _target_: str = "contactmpc.jobs.write_reference.write_reference"
    _partial_: bool = True
    path: str | None = None


@dataclass
class ReferenceReportJobConf:
    _target_: str = "contactmpc.jobs.reference_report.reference_report"
    _partial_: bool = True


@dataclass
class FilmstripJobConf:
    _target_: str = "contactmpc.jobs.filmstrip.reference_filmstrip"
    _partial_: bool = True
    num_frames: int = 7
    size: list[int] = field(default_factory=lambda: [240, 320])
    reference_cache: str | None = "outputs/cache/references"


@dataclass
class RenderSceneJobConf:
    _target_: str = "contactmpc.jobs.render_scene.render_scene"
    _partial_: bool = True
    size: list[int] = field(default_factory=lambda: [480, 640])


# ----------------------------------------------------------------------------------------- root


@dataclass
class Config:
    task: Any = None
    hand: Any = None
    cost: Any = None
    sampler: Any = None
    planner: Any = None
    job: Any = None
    preset: Any = None
    variant: Any = None
    experiment: Any = None
    scene: SceneConf = field(default_factory=SceneConf)
    seed: int = 0
    resume: bool = True
    duration: float | None = None
    output_dir: str = "${hydra:runtime.output_dir}"


# (group, name, schema) triples that launch.py stores in Hydra's ConfigStore.
SCHEMAS: tuple[tuple[str | None, str, type], ...] = (
    (None, "config_schema", Config),
    ("hand", "allegro_schema", AllegroHandConf),
    ("task", "apple_schema", AppleConf),
    ("task", "bottle_schema", BottleConf),
    ("task", "stapler_schema", StaplerConf),
    ("task", "doorknob_schema", DoorknobConf),
    ("cost", "cost_schema", CostConf),
    ("sampler", "sampler_schema", SamplerConf),
    ("planner", "planner_schema", PlannerConf),
    ("planner", "mppi_schema", MPPIConf),
    ("planner", "cem_schema", CEMConf),
    ("job", "trial_schema", TrialJobConf),
    ("job", "render_scene_schema", RenderSceneJobConf),
    ("job", "benchmark_schema", BenchmarkJobConf),
    ("job", "write_reference_schema", WriteReferenceJobConf),
    ("job", "reference_report_schema", ReferenceReportJobConf),
    ("job", "filmstrip_schema", FilmstripJobConf),
)
