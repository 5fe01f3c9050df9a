"""Variants composed from groups: every old variant is the same trial under its new name, old records
resume and group as before, and every task x variant, group member and experiment builds and plans.

The old variants' configs are in ``tests/data/old_variants.json``: what each member of ``conf/variant``
set, at 21b5a0a (before the wrist, shaping and release groups), beyond ``variant=full`` (task=apple,
resolved, flattened). An old variant composes now, through :data:`EXPECTED`, to the same config in
every value that reaches the trial, its old flat ``sampler.release_*`` keys read through
:func:`contactmpc.labels.upgrade_config`; only the labels (the root ``variant`` slot) may differ.
"""

from __future__ import annotations

import copy
import json
import os
from pathlib import Path

import pytest
from hydra._internal.core_plugins.basic_sweeper import BasicSweeper
from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.utils import instantiate
from omegaconf import OmegaConf

import launch
from contactmpc import labels
from contactmpc.labels import (
    OLD_RELEASE_KEYS,
    OLD_VARIANTS,
    RELEASE_DEFAULTS,
    method_labels,
    method_name,
    upgrade_config,
)
from contactmpc.runs import config_differences
from tests.conftest import CONF_DIR, build_scene, compose_config

OLD = json.loads((Path(__file__).parent / "data" / "old_variants.json").read_text())["variants"]

EXPECTED: dict[str, tuple[str, ...]] = {
    "full": ("variant=full",),
    "no_contact": ("variant=no_contact",),
    "joint_space": ("variant=joint_space",),
    "replay": ("variant=replay",),
    "robust": ("variant=robust",),
    "wrist": ("variant=wrist",),
    "wrist_acquire": ("variant=full", "wrist=acquire"),
    "surface": ("variant=full", "shaping=surface"),
    "clearance": ("variant=full", "shaping=clearance"),
    "wrist_surface": ("variant=full", "wrist=acquire", "shaping=surface"),
    "wrist_clearance": ("variant=wrist_clearance",),
    "release_reset": ("variant=full", "release=reset"),
    "release": ("variant=full", "release=open"),
    "release_scheduled": ("variant=full", "release=scheduled"),
    "release_flat": ("variant=full", "release=flat"),
    "release_backoff": ("variant=full", "release=backoff"),
}
"""Each variant of 21b5a0a -> the overrides that compose the same trial now."""

PAPER_DATA = os.environ.get("CONTACTMPC_PAPER_DATA", "")
HAS_PAPER_DATA = bool(PAPER_DATA and Path(PAPER_DATA, "allegro").is_dir())
VARIANTS = sorted(p.stem for p in (CONF_DIR / "variant").glob("*.yaml"))
GROUP_MEMBERS = [(g, p.stem) for g in labels.GROUPS for p in sorted((CONF_DIR / g).glob("*.yaml"))]
# the members that set an option of another group's object, with a member of that group to set it on
NEEDS = {
    ("place", "wrist"): ("release=flat",),
    ("rollout", "fine_until_held"): ("carry=held",),
    ("effort", "acquire_waiting"): ("pacing=lift",),
}
# the members that change the authors' demonstration: planned on a paper task (skipped without the data)
PAPER_ONLY = {("retarget", "wrist")}
EXPERIMENTS = sorted(p.stem for p in (CONF_DIR / "experiment").glob("*.yaml"))
# the smallest planner that plans: one plan of 2 samples over a 0.1 s horizon, single-threaded
TINY = (
    "planner.num_samples=2",
    "planner.horizon=0.1",
    "planner.replan_period=0.05",
    "planner.nthread=1",
    "duration=0.05",
    "job.progress=false",
)


def _flat(node, prefix: str = "") -> dict:
    if isinstance(node, dict) and node:
        return {k: v for key, val in node.items() for k, v in _flat(val, f"{prefix}{key}.").items()}
    return {prefix[:-1]: node}


def _config(*overrides: str) -> dict:
    return OmegaConf.to_container(compose_config([*overrides, "output_dir=/tmp/x"]), resolve=True)


def _as_before(config: dict, changes: dict) -> dict:
    """``config`` (today's ``variant=full``) as a record made at 21b5a0a holds it, with ``changes`` (an
    old variant's values beyond full's) applied: the release options as flat ``sampler.release_*`` keys."""
    old = copy.deepcopy(config)
    for node in (old["sampler"], old["job"]["sampler"]):
        assert node.pop("release") is None
        node.update({k: RELEASE_DEFAULTS[name] for k, name in OLD_RELEASE_KEYS.items()})
    for key, value in sorted(changes.items(), key=lambda kv: kv[1] != "<absent>"):  # removals first
        *parents, leaf = key.split(".")
        node = old
        for p in parents:
            if not isinstance(node.get(p), dict):
                node[p] = {}
            node = node[p]
        if value == "<absent>":
            node.pop(leaf, None)
        else:
            node[leaf] = value
    # options of predictive sampling added after 21b5a0a: a variant that changes the planner (replay)
    # takes none of them, so its record at 21b5a0a had none
    for node in (old["planner"], old["job"]["planner"]):
        if node.get("_target_") != config["planner"].get("_target_"):
            for key in PREDICTIVE_SAMPLING_SINCE:
                node.pop(key, None)
    return old


PREDICTIVE_SAMPLING_SINCE = ("update", "elite_fraction", "temperature")


def test_every_old_variant_has_its_overrides_and_the_variants_are_few():
    assert (
        set(EXPECTED)
        == set(OLD)
        == set(OLD_VARIANTS) | {"full", "no_contact", "joint_space", "replay", "robust"}
    )
    # few: the paper's three, replay, robust, and the named combinations of groups that records carry
    # (wrist, wrist_clearance) or that are the project's methods (grasp_release and those that add groups
    # to it: grasp_release_ahead, grasp_release_ahead_acquire, grasp_held_eased, grasp_held_eased_refined,
    # grasp_held_retract, grasp_held_expected, grasp_held_expected_long, grasp_held_expected_paced,
    # grasp_held_expected_adaptive)
    assert len(VARIANTS) <= 17


@pytest.mark.parametrize("old", sorted(EXPECTED))
def test_an_old_variant_composes_now_to_the_same_trial(old):
    """The config the old variant composed at 21b5a0a, and the one its overrides compose now, hold the
    same value at every key that reaches the trial (the old release keys read through the key map), so
    a record of it resumes as the same trial; and the method's name is the old variant's."""
    base = _config("task=apple", "variant=full")
    before = _as_before(base, OLD[old])
    after = _config("task=apple", *EXPECTED[old])
    now = compose_config(["task=apple", *EXPECTED[old]], return_hydra_config=True)
    a, b = _flat(upgrade_config(before)), _flat(upgrade_config(after))
    a.pop("variant"), b.pop("variant")  # the root slot named after the group: a label, not the trial
    assert a == b
    assert config_differences(before, after) == []
    choices = {k: now.hydra.runtime.choices.get(k) for k in ("variant", *labels.GROUPS)}
    assert method_labels({"variant": old}) == method_labels(choices)  # the label map: old -> now
    assert method_name(choices) == method_name({"variant": old}) == old


def test_old_release_keys_read_as_one_release_node():
    """A record's flat ``sampler.release_*`` keys: at their defaults, ``sampler.release: null``; else
    one ReleaseSchedule node, equal to what release=backoff composes now."""
    plain = {"sampler": {"sigma2": 0.2, "release_pause": 0.0, "release_window": None}}
    assert upgrade_config(plain) == {"sampler": {"sigma2": 0.2, "release": None}}
    old = {f"release_{k}": v for k, v in (("pause", 1.5), ("open", 1.0), ("open_to", "flat"))}
    old |= {"release_backoff": 0.08, "release_backoff_window": [0.75, 1.75], "release_reset": True}
    old |= {"release_noise": 0.0}
    now = _config("task=apple", "release=backoff")["sampler"]["release"]
    assert upgrade_config({"sampler": old})["sampler"]["release"] == now
    with pytest.raises(ValueError, match="both"):
        upgrade_config({"sampler": {"release": now, "release_pause": 1.0}})


def test_method_names_group_old_and_new_records_alike():
    """The analysis' method name: the old variant's for its combination, whichever labels name it."""
    assert method_name({"variant": "wrist_acquire"}) == "wrist_acquire"
    assert method_name({"variant": "full", "wrist": "acquire"}) == "wrist_acquire"
    assert method_name({"variant": "wrist_clearance", "wrist": "acquire", "shaping": "clearance"}) == (
        "wrist_clearance"
    )
    assert method_name({"variant": "full", "wrist": "acquire", "shaping": "clearance"}) == "wrist_clearance"
    assert method_name({"variant": "full", "release": "open"}) == "release"
    assert method_name({"variant": "joint_space", "wrist": "acquire"}) == "joint_space+wrist=acquire"
    assert method_name({"variant": "full", "wrist": "fixed", "shaping": None}) == "full"
    assert method_name({"variant": None}) is None


# ------------------------------------------------------------------------- one planning step each


def _plans_once(overrides: list[str], name: str, reference_files: dict, tmp_path: Path) -> None:
    """Compose, build and run the trial job of task ``name`` for one plan; its record says ``ok``."""
    if name.startswith("paper_") and not HAS_PAPER_DATA:
        pytest.skip("CONTACTMPC_PAPER_DATA does not name the authors' mjpc/tasks directory")
    reference = [f"task.reference_path={reference_files[name]}"] if name in reference_files else []
    cfg = compose_config([*overrides, *TINY, *reference])
    job = launch.build_job(cfg.job)
    path = job(
        make_scene=lambda: instantiate(cfg.scene)(hand=instantiate(cfg.hand), task=instantiate(cfg.task)),
        output_dir=tmp_path,
        seed=cfg.seed,
        config=None,
        labels={"task": name},
    )
    record = json.loads(Path(path).read_text())
    assert record["status"] == "ok", record.get("error")
    assert record["num_plans"] >= 1


TASK_NAMES = sorted(p.stem for p in (CONF_DIR / "task").glob("*.yaml"))
PAPER_TASKS = [t for t in TASK_NAMES if t.startswith("paper_")]
FREE_TASKS = [t for t in TASK_NAMES if t not in PAPER_TASKS and t != "doorknob"]
# Each variant on the articulated synthetic task, on a synthetic free-body one and on a paper one, the
# two taken in turn, so every task plans under several variants (not all 8 x 12: a composition costs ~1 s).
VARIANT_TASKS = [
    (task, variant)
    for i, variant in enumerate(VARIANTS)
    for task in ("doorknob", FREE_TASKS[i % len(FREE_TASKS)], PAPER_TASKS[i % len(PAPER_TASKS)])
]


def test_the_variant_pairs_cover_every_task():
    assert {task for task, _ in VARIANT_TASKS} == set(TASK_NAMES)
    assert {variant for _, variant in VARIANT_TASKS} == set(VARIANTS)


@pytest.mark.parametrize(("task", "variant"), VARIANT_TASKS, ids=[f"{t}-{v}" for t, v in VARIANT_TASKS])
def test_every_variant_plans_on_a_synthetic_and_a_paper_task(task, variant, reference_files, tmp_path):
    _plans_once([f"task={task}", f"variant={variant}"], task, reference_files, tmp_path)


@pytest.mark.parametrize(("group", "member"), GROUP_MEMBERS, ids=[f"{g}={m}" for g, m in GROUP_MEMBERS])
def test_every_group_member_plans(group, member, reference_files, tmp_path):
    needs = NEEDS.get((group, member), ())
    task = "paper_doorknob" if (group, member) in PAPER_ONLY else "doorknob"
    _plans_once([f"task={task}", f"{group}={member}", *needs], task, reference_files, tmp_path)


def first_job(experiment: str) -> tuple[list[str], str]:
    """The overrides of an experiment's first job, as its sweeper orders them, and its task."""
    cfg = compose_config([f"experiment={experiment}"], return_hydra_config=True)
    params = OmegaConf.to_container(cfg.hydra.sweeper.params)
    parsed = OverridesParser.create().parse_overrides([f"{k}={v}" for k, v in params.items()])
    overrides = [f"experiment={experiment}", *BasicSweeper.split_arguments(parsed, None)[0][0]]
    return overrides, compose_config(overrides, return_hydra_config=True).hydra.runtime.choices.task


@pytest.mark.parametrize("experiment", EXPERIMENTS)
def test_every_experiment_s_first_job_plans(experiment, reference_files, tmp_path):
    _plans_once(*first_job(experiment), reference_files, tmp_path)


def test_the_analysis_groups_an_old_record_with_a_new_one_of_the_same_method(tmp_path):
    """An old record (``variant: release_backoff``, flat release keys) and a new one (``variant: full``,
    ``release: backoff``) are one method, one condition; of the same seed, one trial (the newer kept)."""
    from analysis.aggregate import RecordWarning, load_records
    from contactmpc.records import write_json

    base = _config("task=apple", "variant=full")
    records = {
        "old0": ({"variant": "release_backoff"}, _as_before(base, OLD["release_backoff"]), 0),
        "old1": ({"variant": "release_backoff"}, _as_before(base, OLD["release_backoff"]), 1),
        "new1": (
            {"variant": "full", "release": "backoff"},
            _config("task=apple", *EXPECTED["release_backoff"]),
            1,
        ),
    }
    for i, (name, (found, config, seed)) in enumerate(records.items()):
        config = {**config, "seed": seed}
        record = {"task": "apple", **found, "seed": seed, "status": "ok", "ttf": 1.0, "config": config}
        write_json(tmp_path / name / "trial.json", record)
        os.utime(tmp_path / name / "trial.json", (1000 + i, 1000 + i))
    with pytest.warns(RecordWarning, match="recorded 2 times: keeping the newest, .*new1"):
        df = load_records(tmp_path)
    assert sorted(df["seed"]) == [0, 1]
    assert set(df["variant"]) == {"release_backoff"} and set(df["release"]) == {"backoff"}
    assert set(df["condition"]) == {""}


def test_the_release_node_has_a_schema():
    """sampler.release from the release group holds every option of ReleaseSchedule, and a misspelt
    one fails at compose time."""
    from hydra.errors import ConfigCompositionException

    from contactmpc.control.release import ReleaseSchedule

    node = _config("task=apple", "release=reset")["sampler"]["release"]
    assert node == {"_target_": labels.RELEASE_TARGET, **RELEASE_DEFAULTS, "reset": True}
    assert isinstance(instantiate(node), ReleaseSchedule)
    with pytest.raises(ConfigCompositionException, match="sampler.release.paus"):
        compose_config(["release=open", "sampler.release.paus=1.0"])


@pytest.mark.parametrize("task", ["paper_apple", "paper_bottle", "paper_doorknob", "paper_stapler"])
def test_a_paper_task_chooses_the_project_s_method_and_the_command_line_wins(task):
    choices = compose_config([f"task={task}"], return_hydra_config=True).hydra.runtime.choices
    assert (choices.variant, choices.preset) == ("grasp_held_expected_adaptive", "paper_32samples_calibrated")
    assert (choices.wrist, choices.shaping, choices.release, choices.reuse) == (
        "acquire",
        "clearance",
        "retract_articulated",
        "elites_expected",
    )
    assert (choices.compensation, choices.effort, choices.carry) == ("predict", "acquire_error", "held")
    assert choices.pacing == "lift_retry"
    cfg = compose_config([f"task={task}", "variant=full", "preset=paper"], return_hydra_config=True)
    assert (cfg.hydra.runtime.choices.variant, cfg.hydra.runtime.choices.preset) == ("full", "paper")
    assert (cfg.hydra.runtime.choices.shaping, cfg.hydra.runtime.choices.release) == ("none", "none")
    assert (cfg.hydra.runtime.choices.compensation, cfg.hydra.runtime.choices.effort) == ("none", "uniform")
    assert cfg.hydra.runtime.choices.reuse == "none" and cfg.planner.reuse == 0
    assert cfg.planner.num_samples == 128


def test_a_synthesised_task_keeps_the_lite_preset_and_no_variant():
    choices = compose_config(["task=apple"], return_hydra_config=True).hydra.runtime.choices
    assert (choices.variant, choices.preset, choices.shaping) == (None, "lite", "none")


def test_compensation_is_a_group_and_names_the_method_with_it():
    """compensation=predict sets planner.compensate_latency (off by default: none composes the config of
    before); the record labels it, and grasp_release with it is the named method grasp_release_ahead."""
    off = compose_config(["task=apple"])
    assert off.planner.compensate_latency is False
    assert compose_config(["task=apple", "compensation=none"]) == off
    cfg = compose_config(
        ["task=apple", "variant=grasp_release", "compensation=predict"], return_hydra_config=True
    )
    assert cfg.planner.compensate_latency is True and cfg.hydra.runtime.choices.compensation == "predict"
    found = {g: cfg.hydra.runtime.choices[g] for g in labels.GROUPS} | {"variant": "grasp_release"}
    assert labels.method_name(found) == "grasp_release_ahead"
    assert labels.method_name({**found, "compensation": "none"}) == "grasp_release"
    # with effort=acquire it is grasp_release_ahead_acquire; a named method with a group more than any
    # name covers: its name, then the group (and the name reads back the same)
    assert labels.method_name({**found, "effort": "acquire"}) == "grasp_release_ahead_acquire"
    groups = {"wrist": "acquire", "shaping": "clearance", "release": "flat", "effort": "acquire"}
    assert labels.method_name({"variant": "full", **groups}) == "grasp_release+effort=acquire"
    assert labels.method_name({"variant": "grasp_release+effort=acquire"}) == "grasp_release+effort=acquire"
    assert labels.method_name({"variant": "full", "effort": "acquire"}) == "full+effort=acquire"
    assert labels.method_labels({"variant": "grasp_release_ahead"}) == found | {
        "variant": "grasp_release_ahead"
    }
    named = compose_config(["task=apple", "variant=grasp_release_ahead"], return_hydra_config=True)
    assert OmegaConf.to_container(named.planner) == OmegaConf.to_container(cfg.planner)
    assert named.hydra.runtime.choices.compensation == "predict"
    assert (
        labels.method_name(
            {"variant": "grasp_release_ahead", **{g: named.hydra.runtime.choices[g] for g in labels.GROUPS}}
        )
        == "grasp_release_ahead"
    )


NEAR = ("scene.link_distance_cutoff=0.01", "planner.lazy_distances=true")
"""What variant=grasp_held_expected_adaptive sets beside its groups: the clearance term's distances read up to
its 1 cm margin, not 5 cm, and computed only in the plans that read them (the same costs bit for bit, so the
same trials, tests/test_cost.py; fewer geomdist computations)."""


def _paper_apple(*overrides) -> tuple[dict, dict]:
    """The paper apple's config with ``overrides`` (the hydra node left out) and its method groups'
    choices."""
    cfg = compose_config(["task=paper_apple", *overrides], return_hydra_config=True)
    choices = {g: cfg.hydra.runtime.choices[g] for g in labels.GROUPS}
    cfg = OmegaConf.to_container(cfg, resolve=False)
    cfg.pop("hydra")
    return cfg, choices


def test_grasp_held_eased_is_the_method_with_the_carry_and_the_release_of_its_levers():
    """variant=grasp_held_eased composes the trial of grasp_release_ahead_acquire with carry=held and
    release=eased, and the trial the method study's lever ran as overrides (carry=held
    sampler.release.noise=1.0 sampler.release.blend=1.0); its records are named by it, the lever's by the
    method it is on."""

    named, choices = _paper_apple("variant=grasp_held_eased")
    groups, _ = _paper_apple("variant=grasp_release_ahead_acquire", "carry=held", "release=eased")
    lever, lever_choices = _paper_apple(
        "variant=grasp_release_ahead_acquire",
        "carry=held",
        "sampler.release.noise=1.0",
        "sampler.release.blend=1.0",
    )
    assert named == groups == lever
    assert labels.method_name({"variant": "grasp_held_eased", **choices}) == "grasp_held_eased"
    assert (
        labels.method_name({"variant": "grasp_release_ahead_acquire", **lever_choices})
        == "grasp_release_ahead_acquire+carry=held"
    )


def test_grasp_held_eased_refined_is_the_method_with_the_model_refined_on_misprediction():
    """variant=grasp_held_eased_refined composes the trial of grasp_held_eased with rollout=fine_on_error
    (the method study's records of the latter are named by it), and planner.switch_error on."""
    named, choices = _paper_apple("variant=grasp_held_eased_refined")
    groups, group_choices = _paper_apple("variant=grasp_held_eased", "rollout=fine_on_error")
    assert named == groups and choices == group_choices
    assert named["planner"]["switch_error"] == 0.001 and named["planner"]["switch_timestep"] == 0.005
    for variant in ("grasp_held_eased_refined", "grasp_held_eased"):
        assert labels.method_name({"variant": variant, **choices}) == "grasp_held_eased_refined"
    assert (
        labels.method_name({"variant": "grasp_held_eased+rollout=fine_on_error"})
        == "grasp_held_eased_refined"
    )
    assert labels.method_name({**choices, "variant": "full", "rollout": "paper"}) == "grasp_held_eased"


def test_grasp_held_retract_is_the_method_letting_go_of_an_articulation_by_retracting():
    """variant=grasp_held_retract composes grasp_held_eased with release=retract_articulated: its config
    differs only in the release schedule, which adds the hold and the repeated retraction for an object on
    joints (sampler.release.articulated_only); the method study's records of the latter are named by it."""
    named, choices = _paper_apple("variant=grasp_held_retract")
    groups, group_choices = _paper_apple("variant=grasp_held_eased", "release=retract_articulated")
    assert named == groups and choices == group_choices
    eased, _ = _paper_apple("variant=grasp_held_eased")
    release, before = named["sampler"].pop("release"), eased["sampler"].pop("release")
    assert named == eased  # the release schedule is all that differs
    added = {k: v for k, v in release.items() if before.get(k) != v}
    assert added == {"hold": 2.0, "retract": 0.02, "retract_again": True, "articulated_only": True}
    assert labels.method_name({"variant": "grasp_held_retract", **choices}) == "grasp_held_retract"
    assert labels.method_name({"variant": "grasp_held_eased", **choices}) == "grasp_held_retract"


def test_grasp_held_expected_is_the_method_keeping_its_runners_up_once_the_reference_expects_a_grasp():
    """variant=grasp_held_expected, the default's step without the pacing and the error's samples,
    composes grasp_held_retract with reuse=elites_expected: its planner carries 8 runners-up from the
    reference's 3-finger instant, and nothing else differs; the method study's lever trials of the latter
    are named by it."""
    named, choices = _paper_apple("variant=grasp_held_expected")
    default, _ = _paper_apple()  # the paper tasks' default: it with the retried grasp and the error's samples
    adaptive = ("variant=grasp_held_expected", "pacing=lift_retry", "effort=acquire_error", *NEAR)
    assert default == _paper_apple(*adaptive)[0]
    assert default != named
    groups, group_choices = _paper_apple("variant=grasp_held_retract", "reuse=elites_expected")
    assert named == groups and choices == group_choices
    retract, _ = _paper_apple("variant=grasp_held_retract")
    planner, before = named.pop("planner"), retract.pop("planner")
    assert named == retract  # the planner's reuse is all that differs
    assert {k: v for k, v in planner.items() if before.get(k) != v} == {"reuse": 8, "reuse_grasp": 3}
    assert labels.method_name({"variant": "grasp_held_expected", **choices}) == "grasp_held_expected"
    assert labels.method_name({"variant": "grasp_held_retract", **choices}) == "grasp_held_expected"


def test_effort_acquire_long_keeps_the_grasps_samples_for_4_s_after_the_first_contact():
    """effort=acquire_long on grasp_held_expected: 128 samples a plan until 4 s after the first expected
    contact (acquire's 2 s), nothing else differs; variant=grasp_held_expected_long composes exactly that,
    and the lever's trials are named by it."""
    named, choices = _paper_apple("variant=grasp_held_expected")
    longer, long_choices = _paper_apple("variant=grasp_held_expected", "effort=acquire_long")
    planner, before = longer.pop("planner"), named.pop("planner")
    assert longer == named
    assert {k: v for k, v in planner.items() if before.get(k) != v} == {"acquire_until": 4.0}
    assert planner["acquire_samples"] == 128 == before["acquire_samples"]
    for variant in ("grasp_held_expected", "grasp_held_expected_long"):  # the lever's trials name the method
        assert labels.method_name({"variant": variant, **long_choices}) == "grasp_held_expected_long"
    assert _paper_apple("variant=grasp_held_expected_long") == (longer | {"planner": planner}, long_choices)


def test_pacing_lift_is_pacing_hold_at_3_5_cm_and_names_the_paced_method():
    """pacing=lift on grasp_held_expected: pacing=hold's wait with planner.pace_lag = 3.5 cm (hold's 2 cm),
    nothing else differs; the method study's lever (pacing=hold planner.pace_lag=0.035) composes the same
    trial, and variant=grasp_held_expected_paced composes exactly it and names it."""
    named, _ = _paper_apple("variant=grasp_held_expected")
    lift, lift_choices = _paper_apple("variant=grasp_held_expected", "pacing=lift")
    lever, _ = _paper_apple("variant=grasp_held_expected", "pacing=hold", "planner.pace_lag=0.035")
    assert lift == lever
    planner, before = lift.pop("planner"), named.pop("planner")
    assert lift == named
    assert {k: v for k, v in planner.items() if before.get(k) != v} == {"pace_lag": 0.035}
    paced, paced_choices = _paper_apple("variant=grasp_held_expected_paced")
    assert paced == lift | {"planner": planner} and paced_choices == lift_choices
    for variant in ("grasp_held_expected", "grasp_held_expected_paced"):  # the lever's trials name the method
        assert labels.method_name({"variant": variant, **lift_choices}) == "grasp_held_expected_paced"


def test_the_adaptive_method_is_the_paced_one_with_its_retry_and_error_effort_and_names_them():
    """variant=grasp_held_expected_adaptive composes exactly grasp_held_expected_paced with pacing=lift_retry
    and effort=acquire_error (the method study's lever trials' overrides), the link distances read only up
    to the clearance term's margin (``NEAR``: the same costs, tests/test_cost.py), and names those trials."""
    lever, lever_choices = _paper_apple(
        "variant=grasp_held_expected_paced", "pacing=lift_retry", "effort=acquire_error", *NEAR
    )
    named, named_choices = _paper_apple("variant=grasp_held_expected_adaptive")
    assert named == lever and named_choices == lever_choices
    assert _paper_apple() == (named, named_choices)  # the paper tasks' default
    assert named["planner"]["acquire_error"] == [0.03, 0.35] and named["planner"]["pace_retry"] == 1.5
    for variant in ("grasp_held_expected_paced", "grasp_held_expected_adaptive"):
        assert labels.method_name({"variant": variant, **lever_choices}) == "grasp_held_expected_adaptive"


def test_place_is_a_group_that_samples_the_wrist_before_the_hand_lets_go():
    """place=wrist sets the release schedule's window to the 3 s before the last expected contact (off by
    default: none composes the config of before); the record labels it and the method is named with it;
    without a release schedule it is refused in one line naming the fix."""
    from contactmpc.control.samplers import PCASplineSpace
    from contactmpc.validate import ConfigError

    off = compose_config(["task=paper_bottle", "variant=grasp_held_eased"])
    assert off.sampler.release.window is None
    assert compose_config(["task=paper_bottle", "variant=grasp_held_eased", "place=none"]) == off
    cfg = compose_config(
        ["task=paper_bottle", "variant=grasp_held_eased", "place=wrist"], return_hydra_config=True
    )
    assert list(cfg.sampler.release.window) == [-3.0, 0.0] and cfg.hydra.runtime.choices.place == "wrist"
    rest = OmegaConf.to_container(cfg, resolve=False)
    rest.pop("hydra")
    rest["sampler"]["release"]["window"] = None
    assert rest == OmegaConf.to_container(off, resolve=False)  # the window is all it changes
    found = {g: cfg.hydra.runtime.choices[g] for g in labels.GROUPS} | {"variant": "grasp_held_eased"}
    assert labels.method_name(found) == "grasp_held_eased+place=wrist"
    assert labels.method_labels({"variant": "grasp_release_ahead_acquire+place=wrist"})["place"] == "wrist"
    bare = compose_config(["task=apple", "place=wrist"])
    with pytest.raises(ConfigError, match="no release schedule is selected.*release=scheduled"):
        PCASplineSpace(0.2, release=OmegaConf.to_container(bare.sampler.release))


def test_rollout_fine_steps_the_planning_model_only_and_paper_changes_nothing(compose):
    """rollout=paper (the default) composes the same config as no choice; rollout=fine halves the planning
    model's step and leaves the plant's; the scene it builds steps its planning model at 5 ms;
    rollout=fine_budget steps it at 5 ms within the paper point's rollout steps a plan;
    rollout=fine_after_grasp keeps 10 ms and switches to 5 ms 2 s after the first expected contact,
    rollout=fine_from_contact at it, within the paper point's rollout steps; rollout=fine_on_error once the
    model has mispredicted the object, rollout=fine_grasp_on_error then back at the release,
    rollout=fine_until_held back once the grasp has held, rollout=fine_lift 2 s after the switch."""
    base = compose(["task=apple"])
    assert compose(["task=apple", "rollout=paper"]) == base
    fine = compose(["task=apple", "rollout=fine"])
    assert fine.scene.planner_timestep == 0.005
    assert fine.scene.plant_timestep == base.scene.plant_timestep
    scene = build_scene(("task=apple", "rollout=fine"))
    assert scene.planner_model.opt.timestep == 0.005
    assert scene.plant_model.opt.timestep == build_scene(("task=apple",)).plant_model.opt.timestep
    budget = compose(["task=apple", "rollout=fine_budget"])
    assert budget.scene.planner_timestep == 0.005
    # the paper point's plan: 128 samples x 250 steps of 10 ms
    assert budget.planner.step_budget == 128 * 250
    late = compose(["task=apple", "rollout=fine_after_grasp"])
    assert late.scene.planner_timestep == base.scene.planner_timestep  # 10 ms while the grasp is formed
    assert (late.planner.switch_timestep, late.planner.switch_after) == (0.005, 2.0)
    assert base.planner.switch_timestep is None
    contact = compose(["task=apple", "rollout=fine_from_contact"])
    assert contact.scene.planner_timestep == base.scene.planner_timestep
    assert (contact.planner.switch_timestep, contact.planner.switch_after) == (0.005, 0.0)
    assert contact.planner.step_budget == 128 * 250
    on_error = compose(["task=apple", "rollout=fine_on_error"]).planner
    assert (on_error.switch_timestep, on_error.switch_after, on_error.switch_error) == (0.005, None, 0.001)
    assert on_error.step_budget == 128 * 250
    assert on_error.switch_back_after is None and base.planner.switch_back_after is None
    grasp = compose(["task=apple", "rollout=fine_grasp_on_error"]).planner  # ... and back at the release
    assert {**grasp, "switch_back_after": None} == on_error and grasp.switch_back_after == 0.0
    held = compose(["task=apple", "rollout=fine_until_held"]).planner  # ... and back on the grasp's hold
    assert {**held, "switch_back_held": False} == on_error and held.switch_back_held
    assert not base.planner.switch_back_held
    lift = compose(["task=apple", "rollout=fine_lift"]).planner  # ... for 2 s from the switch
    assert {**lift, "switch_for": None} == late.planner and lift.switch_for == 2.0
    assert base.planner.switch_for is None


def test_a_named_method_with_a_group_set_back_to_its_default_is_named_so():
    """A record of a named variant writes each group's choice, so a group set back to its default on it
    (variant=grasp_held_eased effort=uniform) is that, not the variant's own: the name says so and reads
    back the same; an old variant's default-valued labels still read as the variant's."""
    cfg = compose_config(
        ["task=paper_stapler", "variant=grasp_held_eased", "effort=uniform"], return_hydra_config=True
    )
    found = {g: cfg.hydra.runtime.choices[g] for g in labels.GROUPS} | {"variant": "grasp_held_eased"}
    assert found["effort"] == "uniform"
    name = labels.method_name(found)
    assert name == "grasp_held_eased+effort=uniform"
    assert labels.method_labels({"variant": name}) == labels.method_labels(found)
    assert labels.method_labels(found)["effort"] == "uniform"
    assert labels.method_name({**found, "effort": "acquire"}) == "grasp_held_eased"
    assert labels.method_name({**found, "effort": "acquire_half"}) == "grasp_held_eased+effort=acquire_half"
    # an old variant's record wrote the defaults of groups that did not exist yet
    assert labels.method_name({"variant": "wrist_clearance", "wrist": "fixed"}) == "wrist_clearance"
