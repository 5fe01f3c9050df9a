"""The project's method for the paper's four tasks (issue 33): the method the paper tasks select by default
(``variant=grasp_held_eased``; before it ``grasp_release_ahead_acquire``, ``grasp_release_ahead`` and
``grasp_release``) at the calibrated latency, ten seeds a task, beside the steps it is built from and the
paper's full method on the same seeds at the same point."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
from omegaconf import OmegaConf

from analysis import release
from analysis.aggregate import COUNTED_STATUSES, TASK_ORDER, ordered
from analysis.inference import completion_test, newcombe
from analysis.online import by_slowdown
from analysis.operating_point import points, readings
from analysis.prose import ALL_TASKS, glance_row, median, of, seeds, span
from analysis.study import REPO, sweep_params
from analysis.summarize import Fmt, Stat, markdown, pipe_table, summarize
from analysis.timeline import timeline
from contactmpc.control.latency import ComputeLatency
from contactmpc.labels import GROUPS, NAMED_VARIANTS, method_labels, method_name

QUESTION = (
    "Does one named method (the paper tasks' default: grasp_held_eased, or before it one of the steps it "
    "is built from) "
    "complete all four of the paper's tasks, at least 9 of 10 seeds each and at least 8 of 10 finished "
    "cleanly, at the paper point's calibrated latency, and how does it compare with the paper's full "
    "method on the same seeds?"
)
TITLE = "The method: one method for the paper's four tasks"
EXPERIMENT = "method"
EXPERIMENTS = [
    "python launch.py experiment=method variant=grasp_held_eased rollout=fine_on_error "
    "hydra.sweep.dir=studies/method/records  # = variant=grasp_held_eased_refined",
    "python launch.py experiment=method variant=grasp_held_eased rollout=fine_until_held "
    "hydra.sweep.dir=studies/method/records",
    "python launch.py experiment=method variant=grasp_held_eased place=wrist "
    "hydra.sweep.dir=studies/method/records",
    "python launch.py experiment=method variant=grasp_held_eased rollout=fine_grasp_on_error "
    "hydra.sweep.dir=studies/method/records",
    "python launch.py experiment=method variant=grasp_held_eased rollout=fine_from_contact "
    "hydra.sweep.dir=studies/method/records",
    "python launch.py experiment=method variant=grasp_held_eased rollout=fine_after_grasp "
    "hydra.sweep.dir=studies/method/records",
    "python launch.py experiment=method variant=grasp_held_eased rollout=fine_budget "
    "hydra.sweep.dir=studies/method/records",
    "python launch.py experiment=method variant=grasp_held_eased rollout=fine "
    "hydra.sweep.dir=studies/method/records",
    "python launch.py experiment=method variant=grasp_held_eased retarget=wrist "
    "hydra.sweep.dir=studies/method/records",
    "python launch.py experiment=method variant=grasp_held_eased hydra.sweep.dir=studies/method/records",
    "python launch.py experiment=method variant=grasp_release_ahead effort=acquire "
    "hydra.sweep.dir=studies/method/records  # = variant=grasp_release_ahead_acquire",
    *(
        f"python launch.py experiment=method variant={v} hydra.sweep.dir=studies/method/records"
        for v in ("grasp_release_ahead", "grasp_release", "full")
    ),
]

HERE = Path(__file__).resolve().parent
CONF = REPO / "conf"
#: The methods the study runs, in the tables' order: the project's (the latest first), then the paper's.
ORDER = (
    "grasp_held_eased+shaping=clearance_grasp",
    "grasp_held_eased+reuse=elites",
    "grasp_held_eased_refined",
    "grasp_held_eased+rollout=fine_until_held",
    "grasp_held_eased+place=wrist",
    "grasp_held_eased+rollout=fine_grasp_on_error",
    "grasp_held_eased+rollout=fine_from_contact",
    "grasp_held_eased+rollout=fine_after_grasp",
    "grasp_held_eased+rollout=fine_budget",
    "grasp_held_eased+rollout=fine",
    "grasp_held_eased+retarget=wrist",
    "grasp_held_expected_adaptive",
    "grasp_held_expected_long",
    "grasp_held_expected_paced",
    "grasp_held_expected",
    "grasp_held_retract",
    "grasp_held_eased",
    "grasp_release_ahead_acquire",
    "grasp_release_ahead",
    "grasp_release",
    "full",
)
BASELINE = "full"
#: The issue's target per task: at least this many of TARGET_SEEDS seeds completed, and finished cleanly.
TARGET_SEEDS, TARGET_COMPLETED, TARGET_CLEAN = 10, 9, 8
ALPHA = 0.05


# ------------------------------------------------------------------------------------------- the plan


def run_names() -> dict[str, str]:
    """The methods run.sh runs, in its order (``${VARIANTS:-a b}``), each as the analysis names it
    (``grasp_release_ahead_acquire``) to the name run.sh gives it (``grasp_release_ahead+effort=acquire``);
    else :data:`ORDER`'s, each its own."""
    m = re.search(r"\$\{VARIANTS:-([^}]*)\}", (HERE / "run.sh").read_text())
    if not m:
        return {v: v for v in ORDER}
    return {method_name({"variant": method}): method for method in m[1].split()}


def variants() -> list[str]:
    """The methods run.sh runs, in its order, named as the analysis names them (:func:`run_names`)."""
    return list(run_names())


def plan() -> tuple[list[str], list[int]]:
    """The tasks (without ``paper_``) and the seeds ``experiment=method`` sweeps."""
    params = sweep_params(EXPERIMENT)
    tasks = [t.removeprefix("paper_") for t in params.get("task", [])]
    return ordered(tasks, TASK_ORDER), sorted(int(s) for s in params.get("seed", []))


def groups(method: str | None = None) -> list[tuple[str, str, str]]:
    """``(group, member, what it does)`` for each group a method (default: the study's) selects: those
    its ``conf/variant/<variant>.yaml`` selects, then each ``+group=member`` its name adds; what it does
    is the member's own comment (``conf/<group>/<member>.yaml``)."""
    variant, *more = (method or METHOD).split("+")
    conf = OmegaConf.load(CONF / "variant" / f"{variant}.yaml")
    out = []
    for entry in conf.get("defaults") or []:
        if not isinstance(entry, dict) and not OmegaConf.is_dict(entry):
            continue
        for key, member in dict(entry).items():
            group = key.split("/")[-1].strip()
            out.append((group, str(member), _comment(CONF / group / f"{member}.yaml")))
    for group, member in (g.split("=", 1) for g in more):
        out.append((group, member, _comment(CONF / group / f"{member}.yaml")))
    return out


def _comment(path: Path) -> str:
    """The leading comment of a config file, its ``@package`` line left out, as one paragraph."""
    lines = []
    for line in path.read_text().splitlines():
        if not line.startswith("#"):
            break
        if "@package" not in line:
            lines.append(line.lstrip("#").strip())
    return " ".join(lines)


def task_defaults(group: str) -> dict[str, str]:
    """Per paper task (``conf/task/paper_<task>.yaml``, the task without ``paper_``), the member of
    ``group`` (``variant``, ``preset``) its defaults select, where it selects one."""
    out = {}
    for path in sorted((CONF / "task").glob("paper_*.yaml")):
        for entry in OmegaConf.load(path).get("defaults") or []:
            if OmegaConf.is_dict(entry):
                for key, member in entry.items():
                    if str(key).split("@")[0].removeprefix("override ").strip("/ ") == group:
                        out[path.stem.removeprefix("paper_")] = str(member)
    return {t: out[t] for t in ordered(out, TASK_ORDER)}


def default_method() -> str:
    """The method the paper tasks select by default (``conf/task/paper_*.yaml``'s variant and the method
    groups they select, named as the analysis names it; the first of :data:`ORDER` where they select none
    of it)."""
    variants = task_defaults("variant")
    picked = {g: task_defaults(g) for g in GROUPS}
    chosen = {
        method_name({"variant": v, **{g: picked[g].get(task) for g in GROUPS}})
        for task, v in variants.items()
    }
    return next((v for v in ORDER if v in chosen), ORDER[0])


#: The method the study is about: the paper tasks' default.
METHOD = default_method()


def planned_latency() -> float | None:
    """The latency (s) ``preset=paper_32samples_calibrated`` sets (``planner.latency``)."""
    value = OmegaConf.select(
        OmegaConf.load(CONF / "preset" / "paper_32samples_calibrated.yaml"), "planner.latency"
    )
    return None if value is None else float(value)


# ---------------------------------------------------------------------------------------------- trials


def frame(study, folder: str | None = None) -> pd.DataFrame:
    """Every record of the study (or only those of its ``folder``: :data:`HELDOUT`), the task without
    ``paper_``, with ``counted`` (status ok or diverged: a trial that ran, a diverged one not completed),
    boolean ``completed``, ``finished_cleanly`` and ``failed``, and the object errors in each task's kind
    (:func:`analysis.release.with_errors`)."""
    df = study.records() if folder is None else study.records(f"{study.dir.name}/{folder}", own=False)
    if not len(df):
        return df.assign(record_path=[], seed=[], counted=[], completed=[], finished_cleanly=[])
    df = readings(df)
    df["seed"] = df["seed"].astype(int)
    df["counted"] = df["status"].isin(COUNTED_STATUSES)
    ok = df["status"].eq("ok")
    for c in ("completed", "finished_cleanly", "failed"):
        values = df[c] if c in df else pd.Series(False, index=df.index)
        df[c] = values.map(lambda v: isinstance(v, bool | np.bool_) and bool(v)).astype(bool) & ok
    for c in ("ttf", "cpu_seconds", "failure_time"):
        df[c] = pd.to_numeric(df[c] if c in df else pd.Series(math.nan, index=df.index), errors="coerce")
    df = release.with_errors(df)
    df = df if folder is not None else with_equivalents(study, df)
    # the cost columns compare CPU seconds on one processor only (its family and model, as the host names
    # it): per method and task, the one most of its trials ran on (of the levers', per lever: one setting a
    # value no group names, planner.reuse_grasp=4, runs another config under the same method's name)
    df = df.copy()
    df["cost_processor"] = None
    if PROCESSOR in df and len(df):
        by = [df["task"], df["variant"]] + ([df["record_path"].map(lever_of)] if folder == LEVERS else [])
        for _, g in df.groupby(by, dropna=False):
            df.loc[g.index, "cost_processor"] = cost_processor(g)
    df["cpu_seconds"] = df["cpu_seconds"].where(
        df[PROCESSOR].eq(df["cost_processor"]) if PROCESSOR in df else False
    )
    return df


def _lever_on_every_object(lever: str) -> dict[str, tuple[str, str]]:
    """An :data:`EQUIVALENT` entry whose trials are ``lever``'s on a free object and on joints alike."""
    return {kind: ("levers", lever) for kind in ("free", "joints")}


#: Trials that are a method's in all but their name, by its own rule: per method and kind of object
#: (``free``: a free body; ``joints``: an object on joints only), whose trials stand in for its own on a
#: planned seed it has none of its own on: another method's of the sweep (``records``) or a lever's
#: (``levers``, :func:`lever_frame`). ``grasp_held_retract`` differs from ``grasp_held_eased`` only in its
#: release schedule, whose additions act on an object on joints alone (``sampler.release.articulated_only``;
#: ``tests/test_release.py`` checks the planner bit for bit on a free object): on a free object it is
#: ``grasp_held_eased``, on the doorknob ``grasp_held_eased`` with the lever below.
#: ``grasp_held_expected`` is ``grasp_held_retract`` with ``reuse=elites_expected``: on every object, that
#: lever's trials; ``grasp_held_expected_long`` is ``grasp_held_expected`` with ``effort=acquire_long``.
#: ``grasp_held_expected_paced`` is ``grasp_held_expected`` with ``pacing=lift`` (``pacing=hold`` at 3.5 cm):
#: on a free object that lever's trials; on an object on joints a paced trial is the unpaced one
#: (``tests/test_method_levers.py`` checks it bit for bit), so there ``grasp_held_expected``'s.
#: ``grasp_held_expected_adaptive`` is ``grasp_held_expected_paced`` with ``pacing=lift_retry`` and
#: ``effort=acquire_error``: on a free object that lever's trials; on an object on joints neither acts (the
#: same test), so there too ``grasp_held_expected``'s.
EQUIVALENT = {
    "grasp_held_expected_adaptive": {
        "free": ("levers", "effort=acquire_error pacing=lift_retry variant=grasp_held_expected_paced"),
        "joints": ("levers", "reuse=elites_expected variant=grasp_held_retract"),
    },
    "grasp_held_expected_long": _lever_on_every_object("effort=acquire_long variant=grasp_held_expected"),
    "grasp_held_expected_paced": {
        "free": ("levers", "pacing=hold planner.pace_lag=0.035 variant=grasp_held_expected"),
        "joints": ("levers", "reuse=elites_expected variant=grasp_held_retract"),
    },
    "grasp_held_expected": _lever_on_every_object("reuse=elites_expected variant=grasp_held_retract"),
    "grasp_held_retract": {
        "free": ("records", "grasp_held_eased"),
        "joints": ("levers", "release=retract sampler.release.retract_again=True"),
    },
}


#: Why a method's stand-ins are its trials where :func:`equivalents_note`'s general reading does not say it
#: (``{free}``, ``{joints}``: the levers that stand in on a free object and on one on joints).
EQUIVALENT_WHY = {
    "grasp_held_expected_paced": "on a free object its config is the lever `{free}`'s "
    "(`tests/test_variants.py` checks the two compose the same), and on an object on joints the pacing never "
    "acts (`tests/test_method_levers.py` checks the trial bit for bit), so there it is "
    "`grasp_held_expected`'s, the lever `{joints}`'s",
    "grasp_held_expected_adaptive": "on a free object its config is the lever `{free}`'s "
    "(`tests/test_variants.py` checks the two compose the same), and on an object on joints neither the "
    "pacing, the retry nor the error's samples act (`tests/test_method_levers.py` checks the trial bit for "
    "bit), so there it is `grasp_held_expected`'s, the lever `{joints}`'s",
}


def own_trials(df: pd.DataFrame) -> pd.DataFrame:
    """:data:`METHOD`'s trials in ``df`` that it ran itself (no stand-in: :func:`with_equivalents`)."""
    if not len(df):
        return df
    mine = df[df["variant"] == METHOD]
    return mine[mine["stand_in"].isna()] if "stand_in" in mine else mine


def lever_variant(lever: str) -> str | None:
    """The variant a lever's overrides name (``variant=grasp_held_retract`` of ``reuse=elites_expected
    variant=grasp_held_retract``); ``None`` where they name none."""
    return dict(part.split("=", 1) for part in lever.split()).get("variant")


def built_chain(method: str | None = None) -> list[str]:
    """``method`` (default :data:`METHOD`) and the methods it is built on through :data:`EQUIVALENT` (on a
    free object: the method whose records stand in for it, or the variant the lever that does names):
    ``grasp_held_expected``, ``grasp_held_retract``, ``grasp_held_eased``."""
    out = [method or METHOD]
    while (entry := EQUIVALENT.get(out[-1], {}).get("free")) is not None:
        folder, name = entry
        on = name if folder == "records" else lever_variant(name)
        if not on or on in out:
            break
        out.append(on)
    return out


def free_base(method: str | None = None) -> str:
    """The method whose trials are ``method``'s (default :data:`METHOD`) on a free object, on which the
    levers of the free objects are built: the last of :func:`built_chain` (itself where
    :data:`EQUIVALENT` has none)."""
    return built_chain(method)[-1]


def object_kind(df: pd.DataFrame, task: str) -> str | None:
    """``free`` where the task's trials in ``df`` have a free body's position error, else ``joints``;
    ``None`` where ``df`` holds no object errors."""
    if "object_position_error_mean" not in df:
        return None
    return "free" if release.error_kind(df[df["task"] == task]) == "position" else "joints"


def with_equivalents(study, df: pd.DataFrame, seeds=None) -> pd.DataFrame:
    """``df`` with the trials that stand in for a method's (:data:`EQUIVALENT`) on the planned tasks and
    the seeds it has no trial of its own on (``seeds``: which seeds may stand in; default: the planned
    ones), each named as that method (``variant``) with ``stand_in`` the name of the method or lever it
    ran as."""
    seeds = seeds or (lambda seed: seed in plan()[1])
    rows, checks, levers = [], [], None
    for method, by_kind in EQUIVALENT.items():
        have = set(zip(*(df.loc[df["variant"] == method, c] for c in ("task", "seed")), strict=True))
        for task in plan()[0]:
            if not (df["task"] == task).any() or (kind := object_kind(df, task)) is None:
                continue
            folder, name = by_kind[kind]
            if folder == "records":
                source, column = df, "variant"
            else:  # the levers' trials, read once
                levers = lever_frame(study) if levers is None else levers
                source, column = levers, "lever"
            if not len(source):
                continue
            found = source[(source["task"] == task) & (source[column] == name)]
            found = found[np.array([bool(seeds(s)) for s in found["seed"]], dtype=bool)]
            mine = [(task, s) in have for s in found["seed"]]
            for path, seed in zip(found.loc[mine, "record_path"], found.loc[mine, "seed"], strict=True):
                own = df.loc[(df["variant"] == method) & (df["task"] == task) & (df["seed"] == seed)]
                a, b = read_record(own["record_path"].iloc[0]), read_record(path)
                checks.append((method, task, int(seed), name, all(a.get(k) == b.get(k) for k in SAME_RECORD)))
            missing = found[~np.array(mine, dtype=bool)]  # a boolean mask even where none is found
            if len(missing):
                rows.append(missing.assign(variant=method, stand_in=name))
    attrs = {**df.attrs, "equivalent_checks": checks}
    if rows:
        df = pd.concat([df, *rows], ignore_index=True)
    df.attrs.update(attrs)
    return df


def equivalents_note(df: pd.DataFrame) -> str:
    """Which trials stand in for a method's (:func:`with_equivalents`), and on how many of the seeds the
    method ran itself its record and the stand-in's agree (:data:`SAME_RECORD`); ``""`` without any."""
    if "stand_in" not in df:
        return ""
    extra = df[df["stand_in"].notna() & df["variant"].isin(EQUIVALENT) & df["counted"]]
    checks = df.attrs.get("equivalent_checks", [])
    out = []
    for method in EQUIVALENT:
        mine = extra[extra["variant"] == method] if len(extra) else extra
        if not len(mine):
            continue
        by = "; ".join(
            f"{task}: seeds {seeds(g['seed'])} by `{g['stand_in'].iloc[0]}`"
            for task in plan()[0]
            if len(g := mine[mine["task"] == task])
        )
        done = [c for c in checks if c[0] == method]
        agree = sum(c[4] for c in done)
        seen = ", ".join(f"{task} {seed}" for _, task, seed, _, _ in done)
        free, joints = EQUIVALENT[method]["free"][1], EQUIVALENT[method]["joints"][1]
        same = f"its config is the lever `{free}`'s (`tests/test_variants.py` checks the two compose "
        same += "the same)"
        why = (
            EQUIVALENT_WHY[method].format(free=free, joints=joints)
            if method in EQUIVALENT_WHY
            else same
            if free == joints
            else f"on a free object its release is `{free}`'s (`sampler.release.articulated_only`: the hold "
            "and the retraction act only on an object on joints; `tests/test_release.py` checks the planner "
            f"bit for bit), and on an object on joints it is that method with the lever `{joints}`"
        )
        out.append(
            f"`{method}` is run as its own trials where it has them; elsewhere a trial of the same config in "
            f"all that acts on that task stands in for it ({by}): {why}. "
            + (
                f"Where it ran itself on a seed a stand-in also ran ({seen}), the two records agree "
                f"(completion, finishing cleanly, TTF and the final errors) on {of(agree, len(done))}."
                if done
                else "It has not yet run itself on a seed a stand-in ran."
            )
        )
    return "".join(f"\n{line}\n" for line in out)


#: The column that tells processors apart for costs: the host's processor (brand, family, model), else the
#: brand string alone (records before it).
PROCESSOR = "processor"


def cost_processor(df: pd.DataFrame) -> str | None:
    """The processor the most records ran on (ties: the first by name): the CPU seconds of trials on
    different processors are not compared, so every cost in the report is a cost on this one."""
    if PROCESSOR not in df or not df[PROCESSOR].notna().any():
        return None
    counts = df[PROCESSOR].dropna().astype(str).value_counts()
    return sorted(counts.index, key=lambda c: (-counts[c], c))[0]


def cost_note(df: pd.DataFrame) -> str:
    """Which records the CPU seconds come from (:func:`cost_processor`)."""
    if "cost_processor" not in df or not df["cost_processor"].notna().any():
        return ""
    ok = counted(df)
    kept = int(ok[PROCESSOR].eq(ok["cost_processor"]).sum())
    where = "; ".join(
        f"`{method}` on the {short_processor(cpu)} ({', '.join(tasks)})"
        for method in ordered(ok["variant"].unique(), ORDER)
        for cpu, tasks in _by_processor(ok[ok["variant"] == method]).items()
    )
    return (
        "CPU-s: per method and task, seconds of one core of the processor most of its trials ran on "
        f"({kept} of {len(ok)} trials; the others count in every other column but not in the costs: one "
        "processor's seconds are not another's, and one brand string, AMD EPYC, names processors of "
        f"different speeds): {where}. Compare costs only between cells on one processor.\n"
    )


def cost_on(g: pd.DataFrame) -> str | None:
    """The processor (short) the CPU seconds of the trials ``g`` come from (:func:`frame`'s
    ``cost_processor``); ``None`` where none counts."""
    on = g.loc[g["cpu_seconds"].notna(), "cost_processor"].dropna() if "cost_processor" in g else ()
    return short_processor(on.iloc[0]) if len(on) else None


def short_processor(cpu: str | None) -> str:
    """``AMD EPYC (family 25, model 17)`` of a host's processor name (the vendor and stepping left out)."""
    return re.sub(r"\((?:[A-Za-z]+, )?(family \d+, model \d+)(?:, stepping \d+)?\)", r"(\1)", str(cpu))


def _by_processor(df: pd.DataFrame) -> dict[str, list[str]]:
    """The tasks of ``df`` by the processor their costs come from."""
    out: dict[str, list[str]] = {}
    for task in ordered(df["task"].unique(), TASK_ORDER):
        cpu = df.loc[df["task"] == task, "cost_processor"].dropna()
        if len(cpu):
            out.setdefault(cpu.iloc[0], []).append(task)
    return out


def counted(df: pd.DataFrame) -> pd.DataFrame:
    """The trials that count (:func:`frame`'s ``counted``), of the planned tasks and seeds."""
    if not len(df):
        return df
    tasks, planned_seeds = plan()
    return df[df["counted"] & df["task"].isin(tasks) & df["seed"].isin(planned_seeds)]


def cell(df: pd.DataFrame, task: str, variant: str) -> pd.DataFrame:
    return df[(df["task"] == task) & (df["variant"] == variant)].sort_values("seed")


# ----------------------------------------------------------------------------------------------- prose


def what(study) -> str:
    lines = [
        f"**The method** (`variant={METHOD}`, `conf/variant/{METHOD}.yaml`) is the paper's full method with "
        "these groups (each member's own description, from `conf/`):",
        "",
    ]
    lines += [f"- `{g}={m}`: {text}" for g, m, text in groups()]
    tasks, planned_seeds = plan()
    lat = planned_latency()
    lines += [
        "",
        f"{by_default()}, with `preset=paper_32samples_calibrated` "
        f"(`preset=paper_32samples` with `planner.latency` = {1e3 * lat:.0f} ms in `conf/`: each plan "
        "applied that long after the state it was planned from, the paper point's latency calibrated in the "
        "[plan_cost](../plan_cost/README.md) study). `experiment=method` sweeps "
        f"{codes(tasks)} x seeds {seeds(planned_seeds)} (seeds vary slowest, so a sweep stopped early "
        f"holds every task at the seeds it reached), once per method: {codes(variants())} "
        f"(`studies/method/run.sh`), {len(tasks) * len(planned_seeds) * len(variants())} trials in all.",
    ]
    return "\n".join(lines) + "\n"


def by_default() -> str:
    """Which paper tasks select the method and the preset by default (their ``conf/task`` defaults)."""
    variant, preset = task_defaults("variant"), task_defaults("preset")
    chosen = [t for t in variant if variant[t] == METHOD and preset.get(t) == "paper_32samples_calibrated"]
    if not chosen:
        return "No paper task selects it by default (`conf/task/paper_*.yaml`); it is run"
    every = set(chosen) == {p.stem.removeprefix("paper_") for p in (CONF / "task").glob("paper_*.yaml")}
    which = "Every paper task" if every else f"The paper tasks {codes(chosen)}"
    return f"{which} (`conf/task/paper_*.yaml`) select{'s' if every else ''} it by default"


def codes(items) -> str:
    """``a``, ``b`` and ``c`` in code type."""
    return Fmt.listing([f"`{i}`" for i in items])


def point(study, df: pd.DataFrame) -> str:
    """Where the records ran: samples, horizon, latency and replan interval, per method, as recorded."""
    if not len(df):
        return "**The point the records ran at**: not measured yet (no records).\n"
    try:
        p = points(df.drop(columns=[c for c in ("_span", "_after", "_final") if c in df]))
    except ValueError:  # no record with a planner config (none ran to its end)
        return "**The point the records ran at**: not readable (no record has a planner config).\n"
    parts = []
    for variant in ordered(p["variant"], ORDER):
        g = p[p["variant"] == variant]
        at = g.groupby(["samples", "horizon", "latency", "interval"], dropna=False).size()
        text = "; ".join(
            f"{s} samples x {h:g} s horizon, each plan applied {1e3 * lat:.0f} ms after its state, "
            f"a plan every {1e3 * i:.0f} ms ({n} record{'s' if n != 1 else ''})"
            for (s, h, lat, i), n in at.items()
        )
        presets = ", ".join(
            f"`{x}`" for x in sorted(df.loc[df["variant"] == variant, "preset"].dropna().unique())
        )
        parts.append(f"`{variant}`: {text}" + (f" (preset {presets})" if presets else ""))
    lat = planned_latency()
    same = lat is not None and bool((p["latency"].round(3) == round(lat, 3)).all())
    check = (
        f" Every record's latency is the {1e3 * lat:.0f} ms the preset sets."
        if same
        else f" **Not every record ran at the preset's latency** ({Fmt.num(1e3 * (lat or math.nan), 0)} ms)."
    )
    return "**The point the records ran at** (read from them): " + "; ".join(parts) + "." + check + "\n"


def missing(df: pd.DataFrame) -> str:
    """What the planned sweep still lacks, per method and task, and the records that do not count."""
    tasks, planned_seeds = plan()
    ok = counted(df)
    lines = []
    for variant in variants():
        gaps = []
        for task in tasks:
            have = set(cell(ok, task, variant)["seed"]) if len(ok) else set()
            lack = [s for s in planned_seeds if s not in have]
            if lack:
                gaps.append(f"{task} seed{'s' if len(lack) != 1 else ''} {seeds(lack)}")
        n = sum(len(cell(ok, t, variant)) for t in tasks) if len(ok) else 0
        total = len(tasks) * len(planned_seeds)
        mine = ok[ok["variant"] == variant] if len(ok) else ok
        standing = int(mine["stand_in"].notna().sum()) if "stand_in" in mine else 0
        lines.append(
            f"- `{variant}`: {of(n, total)} planned trials kept"
            + (f" ({standing} of them stood in for by an equivalent config's: below)" if standing else "")
            + (f"; missing: {'; '.join(gaps)}" if gaps else " (complete)")
            + "."
        )
    if len(df) and (bad := df[~df["counted"]]).shape[0]:
        lines.append(
            "- Records that do not count (the trial did not run to its end; re-run them): "
            + "; ".join(
                f"{r.task} `{r.variant}` seed {r.seed}: status {r.status}"
                for r in bad.sort_values("seed").itertuples()
            )
            + "."
        )
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------------------------------ the table

STATS = {
    "trials": Stat("seed", "n"),
    "completed": Stat("completed", "count"),
    "finished cleanly": Stat("finished_cleanly", "count"),
    "median TTF": Stat("ttf", "median", digits=2),
    "_span": Stat("_span", "median", scale=1e3, digits=0),
    "_after": Stat("_after", "median", scale=1e3, digits=0),
    "_final": Stat("_final", "median", scale=1e3, digits=0),
    "median CPU-s": Stat("cpu_seconds", "median", digits=0),
}


def target(k: int, c: int, n: int) -> str:
    """Where ``k`` completed and ``c`` finished cleanly of ``n`` kept seeds leave the issue's target."""
    left = TARGET_SEEDS - n
    need_k, need_c = max(0, TARGET_COMPLETED - k), max(0, TARGET_CLEAN - c)
    if not need_k and not need_c:
        return "met" + (f" (already, {n} of {TARGET_SEEDS} seeds kept)" if left > 0 else "")
    if need_k > left or need_c > left:
        return "missed" + (f" (already, {n} of {TARGET_SEEDS} seeds kept)" if left > 0 else "")
    return (
        f"open: {n} of {TARGET_SEEDS} seeds kept; of the {left} left, needs {need_k} more completed "
        f"and {need_c} more finished cleanly"
    )


def table(df: pd.DataFrame) -> str:
    ok = counted(df)
    if not len(ok):
        return "Not measured yet: no trial of the planned sweep has been kept.\n"
    t = summarize(ok, by=["task", "variant"], stats=STATS, order={"task": TASK_ORDER, "variant": ORDER})
    stats = t.attrs["stats"]
    kinds = ok.attrs.get("error_kinds", {})
    t.insert(
        3,
        "seeds",
        [seeds(cell(ok, task, v)["seed"]) for task, v in zip(t["task"], t["variant"], strict=True)],
    )
    t["median object error: span / after span / final"] = [
        " / ".join(stats[c].show(r[c]) for c in ("_span", "_after", "_final"))
        + (" mm" if kinds.get(r["task"]) == "position" else " x 1e-3 (rad, or m for a slide)")
        for _, r in t.iterrows()
    ]
    t["target (≥ 9/10 completed, ≥ 8/10 clean)"] = [
        target(
            int(cell(ok, task, v)["completed"].sum()),
            int(cell(ok, task, v)["finished_cleanly"].sum()),
            len(cell(ok, task, v)),
        )
        for task, v in zip(t["task"], t["variant"], strict=True)
    ]
    cpu = t.pop("median CPU-s")
    t["median CPU-s"] = cpu
    t = t.drop(columns=["_span", "_after", "_final"])
    t.attrs["stats"] = {h: s for h, s in stats.items() if h in t}
    return markdown(t)


# ---------------------------------------------------------------------------------------- side by side


def smallest_difference(k: int, n: int, alpha: float = ALPHA) -> int | None:
    """The fewest seeds (of ``n`` a side) by which a count must differ from ``k`` of ``n`` for Barnard's
    test to give p < ``alpha``; ``None`` where no count can."""
    for d in range(1, n + 1):
        for other in (k + d, k - d):
            if 0 <= other <= n and completion_test(other, n, k, n)[0] < alpha:
                return d
    return None


def others() -> list[str]:
    """The methods :data:`METHOD` is set beside: the rest of :data:`ORDER`, the paper's last."""
    return [v for v in ORDER if v != METHOD]


def built_from(method: str) -> str | None:
    """The method of :data:`ORDER` that ``method`` adds a step to: the name before its last ``+group=member``
    where that is one (``grasp_held_eased`` of ``grasp_held_eased+rollout=fine``), else the method of
    :data:`ORDER` whose groups differ from its own in one group (``grasp_held_eased`` of
    ``grasp_held_eased_refined``), else the next in :data:`ORDER`; ``None`` for the last."""
    if "+" in method and (base := method.rsplit("+", 1)[0]) in ORDER:
        return base
    if (step := _one_group_off(method)) is not None:
        return step
    later = ORDER[ORDER.index(method) + 1 :]
    return next((m for m in later if not m.startswith(method + "+")), None)


def _groups(method: str) -> tuple[str, dict[str, str]]:
    """The variant a method of :data:`ORDER` builds on (``full`` for a named one) and its groups' members."""
    labels = method_labels({"variant": method})
    return NAMED_VARIANTS.get(labels["variant"], labels["variant"]), {g: labels[g] for g in GROUPS}


def _one_group_off(method: str) -> str | None:
    """The first method of :data:`ORDER` after ``method`` on the same variant whose groups differ from its
    own in one group, at its default there (a group set on top of it: ``grasp_held_eased`` of
    ``grasp_held_eased_refined``); ``None`` where there is none."""
    base, mine = _groups(method)
    for other in ORDER[ORDER.index(method) + 1 :]:
        on, theirs = _groups(other)
        off = [g for g in GROUPS if mine[g] != theirs[g]]
        if on == base and len(off) == 1 and theirs[off[0]] == GROUPS[off[0]]:
            return other
    return None


def pairs() -> list[tuple[str, str]]:
    """What the side-by-side compares: each method of :data:`ORDER` against the one it adds one step to
    (:func:`built_from`: a lever's effect), then :data:`METHOD` against the paper's method where that is
    not among them."""
    steps = [(m, parent) for m in ORDER if (parent := built_from(m)) is not None]
    return steps + ([(METHOD, BASELINE)] if (METHOD, BASELINE) not in steps and METHOD != BASELINE else [])


def paired(df: pd.DataFrame) -> tuple[str, str]:
    """The side-by-side table of each pair (:func:`pairs`) on the seeds both methods have, and its
    findings."""
    ok = counted(df)
    tasks, planned = plan()
    rows, notes = [], []
    for first, other in pairs():
        for task in tasks:
            a, b = (cell(ok, task, v) if len(ok) else ok for v in (first, other))
            if not len(a) or not len(b):
                continue
            common = sorted(set(a["seed"]) & set(b["seed"]))
            if not common:
                continue
            a, b = (x[x["seed"].isin(common)].set_index("seed") for x in (a, b))
            n = len(common)
            for measure, col in (("completed", "completed"), ("finished cleanly", "finished_cleanly")):
                k1, k2 = int(a[col].sum()), int(b[col].sum())
                p, p_min = completion_test(k1, n, k2, n)
                d, lo, hi = newcombe(k1, n, k2, n)
                only_a = [s for s in common if a.at[s, col] and not b.at[s, col]]
                only_b = [s for s in common if b.at[s, col] and not a.at[s, col]]
                need = smallest_difference(k2, n)
                power = (
                    "no count could reach p < 0.05"
                    if need is None
                    else f"only a difference of ≥ {need} of {n} seeds could give p < 0.05"
                )
                verdict = (
                    f"p < {ALPHA:g}"
                    if p < ALPHA
                    else f"not significant; {power}: little power at these counts"
                )
                if n < len(planned):  # a screen's seeds may have been picked by another method's outcome
                    verdict += (
                        f"; on {n} of the {len(planned)} seeds, which a screen may have picked by another "
                        "method's outcome: not a test at seeds drawn at random"
                    )
                rows.append(
                    f"| {first} | {other} | {task} | {measure} | {seeds(common)} | {k1}/{n} / {k2}/{n} "
                    f"| {100 * d:+.0f} [{100 * lo:+.0f}, {100 * hi:+.0f}] | {p:.3g} | {p_min:.3g} "
                    f"| {seeds(only_a)} | {seeds(only_b)} | {verdict} |"
                )
                notes.append(
                    f"- **{task}**, {measure} ({n} seed{'s' if n != 1 else ''} in both): `{first}` "
                    f"{of(k1, n)}, `{other}` {of(k2, n)}; {100 * d:+.0f} points "
                    f"[{100 * lo:+.0f}, {100 * hi:+.0f}], Barnard's p = {p:.3g} ({verdict})."
                )
    if not rows:
        return "", "Not measured yet: no task has trials of two methods on a common seed.\n"
    cols = (
        "method", "against", "task", "measure", "seeds in both", "method / against",
        "difference, points [95 % CI]", "Barnard p", "smallest attainable p",
        "seeds only the method", "seeds only the other", "reading",
    )  # fmt: skip
    return pipe_table(cols, "lllllrrrrlll", rows), "\n".join(notes) + "\n"


# -------------------------------------------------------------------------------------------- failures


def outcome(r) -> str:
    if not r.counted:
        return f"status {r.status} (did not run to its end)"
    parts = ["not completed"]
    if r.completed:
        parts = ["completed, finished cleanly" if r.finished_cleanly else "completed, not finished cleanly"]
    if r.status != "ok":
        parts.append(f"status {r.status}")
    if pd.notna(r.ttf):
        parts.append(f"TTF {r.ttf:.2f}")
    if r.failed and pd.notna(r.failure_time):
        parts.append(f"contact lost at {r.failure_time:.1f} s")
    ms = [c[len("milestone_") :] for c in r._fields if c.startswith("milestone_")]
    reached = [m for m in ms if getattr(r, f"milestone_{m}") is True]
    if ms:
        parts.append("milestones reached: " + (", ".join(reached) if reached else "none"))
    return "; ".join(parts)


def failures(study, df: pd.DataFrame) -> str:
    if not len(df):
        return "Not measured yet.\n"
    bad = df[~df["counted"] | ~df["completed"] | df["failed"]]
    if not len(bad):
        return f"None: every one of the {len(df)} trials completed without a TTF failure.\n"
    bad = bad.assign(_t=bad["task"].map({t: i for i, t in enumerate(TASK_ORDER)}).fillna(99))
    bad = bad.assign(_v=bad["variant"].map({v: i for i, v in enumerate(ORDER)}).fillna(99))
    out = []
    for r in bad.sort_values(["_t", "_v", "seed"]).itertuples():
        run = Path(r.record_path).parent
        name = f"timeline_{r.task}_{r.variant}_seed{r.seed}.png"
        link = study.draw(
            name,
            lambda path, run=run: timeline(run, path),
            f"timeline: {r.task}, {r.variant}, seed {r.seed}",
            data=run / "timeseries.npz",
        )
        head = f"- **{r.task}, `{r.variant}`, seed {r.seed}**: {outcome(r)}."
        if link is None:
            rel = run.relative_to(REPO) if run.is_relative_to(REPO) else run
            head += (
                f" Timeline not drawn: its time series (`{rel}/timeseries.npz`) is not on this machine. "
                f"Re-make it: `python launch.py experiment=method variant={r.variant} "
                f"'hydra.sweeper.params.task=\"paper_{r.task}\"' 'hydra.sweeper.params.seed=\"{r.seed}\"' "
                f"hydra.sweep.dir=/tmp/method_rerun`, copy the run's `timeseries.npz` into `{rel}/` and run "
                "`python -m analysis.study method` (the same trial bit for bit only on a machine like the "
                "one that ran it)."
            )
            out.append(head)
            continue
        text = (study.dir / "figures" / name).with_suffix(".txt")
        if text.is_file():
            lines = text.read_text().splitlines()[1:]  # its first line repeats the trial
            head += " The timeline's diagnosis: " + "; ".join(lines) + "."
        out += [head, "", f"  {link}", ""]
    return "\n".join(out).rstrip("\n") + "\n"


# ----------------------------------------------------------------------------------------------- online


def _ms(r: dict, key: str) -> str:
    return Fmt.num(1e3 * r[key], 0) if isinstance(r.get(key), float) else "—"


def online_cpu(r: dict) -> str:
    """The processor an online run ran on, short: the record's host CPU without its vendor string and
    stepping (``AMD EPYC (family 25, model 1)``); its coarse ``cpu`` where the record has no host."""
    return short_processor(((r.get("host") or {}).get("cpu")) or r.get("cpu") or "unknown CPU")


def usual_cpu(records: list[dict]) -> str | None:
    """The processor (:func:`online_cpu`) most of the online runs ``records`` ran on (ties: by name), as
    :func:`cost_processor` picks it."""
    return cost_processor(pd.DataFrame({PROCESSOR: [online_cpu(r) for r in records]}))


def real_time(r: dict) -> bool:
    """Whether an online run ran in real time (slowdown 1) replanning continuously (neither paced by
    ``job.min_interval`` nor held by ``job.apply_after``), predicting as far as the last plans took
    (not ``job.latency_by_samples``)."""
    levers = r.get("apply_after") or r.get("min_interval") or r.get("latency_by_samples")
    return r.get("slowdown") == 1 and not levers


def lazy_distances(r: dict) -> bool:
    """Whether a record's planner computed the link-object distances only where its cost read them
    (``planner.lazy_distances``, from the record's config)."""
    return bool(((r.get("config") or {}).get("planner") or {}).get("lazy_distances"))


def online_method(r: dict, usual: str | None = None) -> str:
    """An online run's method: :func:`method_name`, ``paced N ms`` where the planner was paced to a plan
    every ``job.min_interval`` of control time at most, and ``held to N ms`` where each plan was held to act
    no sooner than ``job.apply_after`` after its state; ``latency by samples`` where each plan predicted its
    state as far ahead as the last plans of its samples took (``job.latency_by_samples``); ``distances only
    where read`` where the planner computed the clearance term's distances only in the plans that read them
    (``planner.lazy_distances``: the same plans, sooner); ``beside N other trials`` where others ran on the
    machine at the same time (the record's ``concurrent_trials``), so its runs are not counted with the same
    method's runs alone; ``on <processor>`` where it ran on another processor than ``usual`` (wall-clock
    runs on different processors are not counted together)."""
    paced, held = r.get("min_interval") or 0.0, r.get("apply_after") or 0.0
    others = int(r.get("concurrent_trials") or 1) - 1
    cpu = online_cpu(r)
    return (
        method_name(r)
        + (f", paced {1e3 * paced:.0f} ms" if paced > 0 else "")
        + (f", held to {1e3 * held:.0f} ms" if held > 0 else "")
        + (", latency by samples" if r.get("latency_by_samples") else "")
        + (", distances only where read" if lazy_distances(r) else "")
        + (f", beside {others} other trial{'s' * (others > 1)}" if others > 0 else "")
        + (f", on {cpu}" if usual is not None and cpu != usual else "")
    )


def _online_row(r: dict, usual: str | None = None) -> str:
    yes = {True: "yes", False: "no"}
    slowdown, factor = r.get("slowdown", math.nan), r.get("real_time_factor", math.nan)
    return (
        f"| {r.get('task', '').removeprefix('paper_')} | {online_method(r, usual)} | {r.get('seed')} "
        f"| {Fmt.num(slowdown, 0)} | {Fmt.num(factor, 3)} "
        f"| {_ms(r, 'replan_interval_median')} | {_ms(r, 'plan_latency_median')} "
        f"| {_ms(r, 'plan_seconds_grasp_median')} | {_ms(r, 'plan_seconds_after_grasp_median')} "
        f"| {yes[bool(r.get('completed'))]} | {yes[bool(r.get('finished_cleanly'))]} "
        f"| {Fmt.num(r.get('ttf', math.nan), 2)} | {r.get('concurrent_trials') or '—'} | {_switch(r)} |"
    )


def _switch(r: dict) -> str:
    """When a run's planning model switched (``switch_time``), in seconds after the first expected contact;
    "never"; "—" for a run without a switch."""
    if "switch_time" not in r:
        return "—"
    if r["switch_time"] is None or r.get("contact_span_start") is None:
        return "never"
    return f"+{r['switch_time'] - r['contact_span_start']:.2f}"


#: The method's trials on seeds it was not chosen on, kept apart from the sweep's records.
HELDOUT = "heldout"
#: The held-out seeds start here (the sweep's are 0-9); how far they go is read from the records.
HELDOUT_FROM = 10
HELDOUT_SEEDS = f"{HELDOUT_FROM} and above"


def heldout_frame(study, chosen: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """The held-out trials that count (:data:`HELDOUT`, on the planned tasks), with :data:`METHOD`'s
    stand-ins (:func:`stand_ins`) among them; and apart: the method's own, and the stand-ins."""
    df = frame(study, HELDOUT)
    ok = df[df["counted"] & df["task"].isin(plan()[0])] if len(df) else df  # (not the sweep's seeds)
    found = []
    for method in dict.fromkeys((METHOD, free_base())):
        mine = ok[ok["variant"] == method] if len(ok) else ok
        if len(more := stand_ins(study, chosen, mine, method)):
            found.append(more[more["task"].isin(plan()[0])])
    extra = pd.concat(found) if found else ok.iloc[0:0].assign(stand_in=[])
    if len(extra):
        ok = pd.concat([ok, extra])
    if len(ok):  # the trials that are the method's in all but their name (EQUIVALENT), on these seeds
        ok = with_equivalents(study, ok, seeds=lambda seed: seed not in plan()[1])
    own = own_trials(ok)
    return ok, own, extra


def heldout(study, chosen: pd.DataFrame) -> str:
    """Each method's trials on the seeds it was not chosen on (:data:`HELDOUT`), per method (of
    :data:`ORDER`) and task beside its trials on the seeds it was chosen on (``chosen``: the sweep's), with
    the difference in completion and in finishing cleanly and Barnard's test; a line where :data:`METHOD`
    has none yet."""
    names = run_names()
    ok, own, extra = heldout_frame(study, chosen)
    methods = [m for m in ORDER if len(ok) and (ok["variant"] == m).any()]
    last = {m: int(ok.loc[ok["variant"] == m, "seed"].max()) for m in methods}  # its last held-out seed
    runs = " and ".join(
        f'`VARIANTS="{names.get(m, m)}" SEEDS="$(seq -s " " {HELDOUT_FROM} {max(last.get(m, 19), 19)})" '
        f"OUT=studies/method/{HELDOUT} bash studies/method/run.sh`"
        for m in methods or [METHOD]
    )
    head = (
        "A method's groups were chosen on the sweep's seeds, so its counts there are optimistic. Its trials "
        f"on seeds {HELDOUT_SEEDS}, which chose nothing, are kept apart in `{HELDOUT}/` ({runs}, seeds "
        "varying slowest).\n\n"
    )
    if METHOD not in methods:
        head += (
            f"`{METHOD}` has no trial on these seeds yet (its levers' trials on them, run before it was "
            "named, are in the levers' table: *Levers on the method, full trials*)"
            + (": the rows below are of " + codes(methods) + ".\n\n" if methods else ".\n\n")
        )
    for method in ordered(extra["variant"].unique(), ORDER) if len(extra) else []:
        ex = extra[extra["variant"] == method]
        by = ", ".join(f"{task} {seeds(g['seed'])}" for task in plan()[0] if len(g := ex[ex["task"] == task]))
        mine = ", ".join(
            f"{task} {seeds(sorted(set(g['seed'])))}"
            for task in plan()[0]
            if len(g := own[own["task"] == task])
        )
        head += (
            f"Where `{method}` has no held-out trial of its own, a lever trial kept in `{LEVERS}/` that ran "
            "its config (the same resolved config, the seed aside, on the same processor: "
            f"{codes(sorted(set(ex['stand_in'])))}) stands in for it ({by}): the same config and seed "
            "give the same record on one processor (*reproduced*, under *What the records show*)."
            + " The stand-ins ran before the method was named, and their counts were in this report when it "
            "was chosen: they are held out from the sweep's seeds, not from that choice"
            + (
                f"; `{METHOD}`'s own trials here ({mine}) chose nothing."
                if mine and method == METHOD
                else "."
            )
            + "\n\n"
        )
    if len(ok) and "stand_in" in ok and (ok["variant"].isin(EQUIVALENT) & ok["stand_in"].notna()).any():
        head += equivalents_note(ok).strip().replace("\n\n", " ") + "\n\n"
    if not methods:
        return head + "No such trial is kept yet.\n"
    base = counted(chosen)
    rows, lines = [], []
    for method in methods:
        for task in plan()[0]:
            h, c = cell(ok, task, method), cell(base, task, method)
            if not len(h):
                continue
            hk, hc, ck, cc = (int(g[col].sum()) for g in (h, c) for col in ("completed", "finished_cleanly"))
            rows.append(
                f"| `{method}` | {task} | {seeds(h['seed'])} | {of(hk, len(h))} | {of(hc, len(h))} "
                f"| {of(ck, len(c))} | {of(cc, len(c))} |"
            )
            if len(c):
                for what, a, b in (("completed", hk, ck), ("finished cleanly", hc, cc)):
                    d, lo, hi = newcombe(a, len(h), b, len(c))
                    p, floor = completion_test(a, len(h), b, len(c))
                    lines.append(
                        f"- `{method}`, {task}, {what}: {of(a, len(h))} held out against {of(b, len(c))}, "
                        f"{100 * d:+.0f} points [{100 * lo:+.0f}, {100 * hi:+.0f}], Barnard p = {Fmt.p(p)} "
                        f"(at best {Fmt.p(floor)} at these counts)"
                    )
    cols = ("method", "task", "held-out seeds", "completed", "finished cleanly",
            "on the sweep's seeds: completed", "finished cleanly")  # fmt: skip
    return (
        head
        + pipe_table(cols, "lllrrrr", rows)
        + "\n"
        + ";\n".join(lines)
        + (".\n" if lines else "")
        + untouched(ok)
        + target_odds(base, ok)
        + every_task_odds(base, ok, study)
        + against_method(base, ok, methods)
    )


#: How often a method must meet the target on fresh seeds for :func:`target_odds`' needed rates.
TARGET_ODDS = 0.8


def meets_target_chance(clean: int, unclean: int, failed: int) -> float:
    """The chance that :data:`TARGET_SEEDS` new seeds meet the target (≥ :data:`TARGET_COMPLETED`
    completed and ≥ :data:`TARGET_CLEAN` finished cleanly), given ``clean`` trials that finished cleanly,
    ``unclean`` that completed but not cleanly and ``failed`` that did not complete: the posterior
    predictive of the three outcomes' counts under a uniform (Dirichlet(1, 1, 1)) prior on their rates."""
    from scipy.stats import dirichlet_multinomial

    alpha = np.array([clean, unclean, failed], float) + 1.0
    n = TARGET_SEEDS
    return float(
        sum(
            dirichlet_multinomial.pmf([a, b, n - a - b], alpha, n)
            for a in range(TARGET_CLEAN, n + 1)
            for b in range(0, n - a + 1)
            if a + b >= TARGET_COMPLETED
        )
    )


def target_counts(trials: pd.DataFrame) -> tuple[int, int, int, float]:
    """``(seeds, completed, clean, chance)`` of one method's ``trials`` on one task (a seed each): with
    :func:`meets_target_chance` of their counts."""
    n, done, clean = len(trials), int(trials["completed"].sum()), int(trials["finished_cleanly"].sum())
    return n, done, clean, meets_target_chance(clean, done - clean, n - done)


def needed_rate(k: int, odds: float = TARGET_ODDS) -> float:
    """The smallest rate at which at least ``k`` of :data:`TARGET_SEEDS` trials succeed with probability
    ``odds`` (binomial)."""
    from scipy.optimize import brentq
    from scipy.stats import binom

    return float(brentq(lambda p: binom.sf(k - 1, TARGET_SEEDS, p) - odds, 1e-9, 1 - 1e-12))


#: From this seed on, no choice of :data:`METHOD` saw a trial: ``effort=acquire_error``'s thresholds were
#: set on the stapler's seeds up to 19 (*More samples where the object is off the reference*).
UNTOUCHED_FROM = 20


def untouched(held: pd.DataFrame) -> str:
    """:data:`METHOD`'s own held-out trials (``held``: :func:`heldout_frame`'s) from
    :data:`UNTOUCHED_FROM` on, per task: completed and finished cleanly. Empty where it has none."""
    mine = held[(held["variant"] == METHOD) & (held["seed"] >= UNTOUCHED_FROM)] if len(held) else held
    if not len(mine):
        return ""
    said = []
    for task in plan()[0]:
        if len(g := mine[mine["task"] == task].drop_duplicates("seed")):
            done, clean = int(g["completed"].sum()), int(g["finished_cleanly"].sum())
            said.append(
                f"the {task} {of(done, len(g))} completed and {of(clean, len(g))} finished cleanly "
                f"(seeds {seeds(g['seed'])})"
            )
    return (
        f"\nSeeds {UNTOUCHED_FROM} and above ran after every choice of `{METHOD}`, the thresholds of "
        f"`effort=acquire_error` included (set on the stapler's seeds 0-{UNTOUCHED_FROM - 1}: *More samples "
        "where the object is off the reference*), so they are held out from all of it: there it has "
        + "; ".join(said)
        + ".\n"
    )


def target_odds(sweep: pd.DataFrame, held: pd.DataFrame) -> str:
    """:data:`METHOD` over every seed it has, the sweep's (``sweep``) and the held-out ones (``held``, its
    stand-ins counted in), per task: completed and finished cleanly with Wilson's 95 % intervals, and the
    chance that ten new seeds meet the target (:func:`meets_target_chance`); with the rates a method needs
    to meet it :data:`TARGET_ODDS` of the time. Empty without held-out trials of it."""
    from analysis.inference import wilson

    trials = pd.concat([sweep, held]) if len(held) else sweep
    rows = []
    for task in plan()[0]:
        if not len(held) or not len(cell(held, task, METHOD)):
            continue
        g = cell(trials, task, METHOD).drop_duplicates("seed")
        n, done, clean, chance = target_counts(g)
        ci = [wilson(k, n) for k in (done, clean)]
        rows.append(
            f"| {task} | {seeds(g['seed'])} | {of(done, n)} ({100 * ci[0][0]:.0f}-{100 * ci[0][1]:.0f} %) "
            f"| {of(clean, n)} ({100 * ci[1][0]:.0f}-{100 * ci[1][1]:.0f} %) | {100 * chance:.0f} % |"
        )
    if not rows:
        return ""
    need_done, need_clean = needed_rate(TARGET_COMPLETED), needed_rate(TARGET_CLEAN)
    cols = ("task", "seeds", "completed (95 % interval)", "finished cleanly (95 % interval)",
            f"chance {TARGET_SEEDS} new seeds meet the target")  # fmt: skip
    return (
        f"\n**Over every seed `{METHOD}` has** (the sweep's and the held-out ones, its stand-ins counted "
        f"in). The target reads {TARGET_SEEDS} seeds, so a method meets or misses it partly by the draw: "
        f"to meet it {100 * TARGET_ODDS:.0f} % of the time, a method must complete about "
        f"{100 * need_done:.0f} % of its trials (≥ {TARGET_COMPLETED} of {TARGET_SEEDS}) and finish about "
        f"{100 * need_clean:.0f} % cleanly (≥ {TARGET_CLEAN} of {TARGET_SEEDS}), each read alone (binomial). "
        f"The last column is the chance that {TARGET_SEEDS} new seeds meet both, from these counts (the "
        "posterior predictive of clean, completed but not clean and not completed, under a uniform prior on "
        "their rates):\n\n" + pipe_table(cols, "llrrr", rows)
    )


def every_task_odds(sweep: pd.DataFrame, held: pd.DataFrame, study=None) -> str:
    """Each method of :data:`ORDER` with at least :data:`TARGET_SEEDS` seeds on every planned task, the
    sweep's (``sweep``) and the held-out ones (``held``), stand-ins counted in: per task its counts and the
    chance that ten new seeds meet the target (:func:`meets_target_chance`), and the product of the four,
    the chance that one new draw of ten seeds per task meets it on all of them (the tasks' draws
    independent); likeliest first, with a figure of their rates where ``study`` is given. Empty where no
    method has that many."""
    trials = pd.concat([sweep, held]) if len(held) else sweep
    tasks = plan()[0]
    found = []
    for method in ORDER:
        cells, counts, joint = [], [], 1.0
        for task in tasks:
            g = cell(trials, task, method).drop_duplicates("seed")
            if len(g) < TARGET_SEEDS:
                break
            n, done, clean, chance = target_counts(g)
            joint *= chance
            cells.append(f"{done} / {clean} of {n} ({100 * chance:.0f} %)")
            counts.append((task, n, done, clean))
        else:
            found.append((joint, method, cells, counts))
    if not found:
        return ""
    found.sort(key=lambda x: -x[0])
    link = (
        study.draw(
            "target_rates.png",
            lambda path: target_figure(path, [(m, *c) for _, m, _, counts in found for c in counts]),
            "each method's rates per task, with the rates the target needs",
        )
        if study is not None
        else None
    )
    rows = [f"| `{m}` | " + " | ".join(cells) + f" | {100 * joint:.0f} % |" for joint, m, cells, _ in found]
    cols = ("method", *(f"{t}: completed / clean of seeds (chance)" for t in tasks), "all four")
    best = found[0]
    return (
        f"\n**Which method is likeliest to meet the target on every task.** Each method with at least "
        f"{TARGET_SEEDS} seeds on each task (the sweep's and the held-out ones, stand-ins counted in): per "
        f"task its counts and the chance that {TARGET_SEEDS} new seeds meet the target (as above), and their "
        f"product, the chance that a new draw of {TARGET_SEEDS} seeds on each task meets it on all "
        f"{len(tasks)} (the tasks' draws taken as independent); likeliest first. Over fewer seeds the "
        "uniform prior weighs more: the same rates give a lower chance.\n\n"
        + pipe_table(cols, "l" + "r" * (len(tasks) + 1), rows)
        + f"\nThe likeliest is `{best[1]}`, at {100 * best[0]:.0f} %.\n"
        + (f"\n{link}\n" if link else "")
    )


def target_figure(path: Path, rows: list[tuple[str, str, int, int, int]]) -> None:
    """Per task, each method's share of trials completed (hollow) and finished cleanly (filled) with
    Wilson's 95 % intervals, and the rates at which ten new seeds meet the target's two counts
    :data:`TARGET_ODDS` of the time (dashed): ``rows`` of ``(method, task, seeds, completed, clean)``."""
    import matplotlib.pyplot as plt

    from analysis.inference import wilson

    tasks = list(dict.fromkeys(r[1] for r in rows))
    methods = list(dict.fromkeys(r[0] for r in rows))
    fig, axes = plt.subplots(1, len(tasks), figsize=(3.2 * len(tasks), 0.45 * len(methods) + 1.6),
                             squeeze=False, sharey=True)  # fmt: skip
    for ax, task in zip(axes[0], tasks, strict=True):
        for method, _, n, done, clean in (r for r in rows if r[1] == task):
            y = -methods.index(method)
            for k, dy, face in ((done, 0.12, "white"), (clean, -0.12, "C0")):
                lo, hi = wilson(k, n)
                ax.plot([lo, hi], [y + dy, y + dy], color="C0", lw=1)
                ax.plot(k / n, y + dy, "o", mfc=face, mec="C0", ms=5)
        for k, label in ((TARGET_COMPLETED, "completed"), (TARGET_CLEAN, "clean")):
            ax.axvline(needed_rate(k), color="k", lw=0.8, ls="--" if label == "clean" else ":")
        ax.set_title(task)
        ax.set_xlim(0, 1.02)
        ax.set_xlabel("share of seeds")
    axes[0][0].set_yticks([-i for i in range(len(methods))], methods, fontsize=7)
    fig.suptitle(
        f"completed (hollow) and finished cleanly (filled), 95 % intervals; the rates that meet the target "
        f"{100 * TARGET_ODDS:.0f} % of the time: completed (dotted), clean (dashed)",
        fontsize=8,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def against_method(sweep: pd.DataFrame, held: pd.DataFrame, methods: list[str]) -> str:
    """Each of ``methods`` but :data:`METHOD`, per task where it has held-out trials (``held``), against
    :data:`METHOD` on every seed both have, the sweep's (``sweep``) and the held-out ones; and over those
    tasks: completed and finished cleanly, with Barnard's test on each. Empty without such trials."""
    trials = pd.concat([sweep, held]) if len(held) else sweep
    rows, pooled = [], []
    for method in (m for m in methods if m != METHOD):
        sums = np.zeros(4, int)
        n = 0
        for task in plan()[0]:
            mine, theirs = cell(trials, task, method), cell(trials, task, METHOD)
            both = sorted(set(mine["seed"]) & set(theirs["seed"]))
            if not len(held) or not cell(held, task, method)["seed"].isin(both).any():
                continue
            a, b = (g[g["seed"].isin(both)].drop_duplicates("seed") for g in (mine, theirs))
            n_both = len(both)
            counts = [int(g[col].sum()) for g in (a, b) for col in ("completed", "finished_cleanly")]
            p_done, p_clean = (completion_test(counts[i], n_both, counts[i + 2], n_both)[0] for i in (0, 1))
            rows.append(
                f"| `{method}` | {task} | {seeds(both)} | "
                + " | ".join(of(k, n_both) for k in counts)
                + f" | {Fmt.p(p_done)} | {Fmt.p(p_clean)} |"
            )
            sums += counts
            n += n_both
        if n:
            p_done, p_clean = (completion_test(sums[i], n, sums[i + 2], n)[0] for i in (0, 1))
            pooled.append(
                f"- `{method}` over those tasks: completed {of(sums[0], n)} against {of(sums[2], n)} "
                f"(Barnard p = {Fmt.p(p_done)}), finished cleanly {of(sums[1], n)} against "
                f"{of(sums[3], n)} (Barnard p = {Fmt.p(p_clean)})."
            )
    if not rows:
        return ""
    cols = ("method", "task", "seeds", "completed", "finished cleanly", f"`{METHOD}`: completed",
            "finished cleanly", "Barnard p (completed)", "Barnard p (clean)")  # fmt: skip
    return (
        f"\n**Against `{METHOD}` on every seed both have** (the sweep's and the held-out ones; "
        f"`{METHOD}`'s stand-ins counted in), per task where the other method has held-out trials:\n\n"
        + pipe_table(cols, "lllrrrrrr", rows)
        + "\n"
        + "\n".join(pooled)
        + "\n"
    )


LEVERS = "levers"
#: Appended to a lever's name (and a task's) for its trials on the held-out seeds.
HELD_OUT = " (held out)"
LEVERS_RUN = (
    'TASKS="stapler bottle apple" OUT=studies/method/levers bash studies/method/run_levers.sh <overrides>'
)
#: What a lever's override means, where it is not a group's member (whose own description is read from conf/).
LEVER_TEXT = {
    "cost.release_weight=0.0": "no release term (`cost.release_weight`; the method's 1e-3 m^2 of squared "
    "object error a contact after the last expected one), so the hand may stay on the object until it is "
    "still",
    "sampler.release.open=3.0": "the fingers open over 3 s (`sampler.release.open`; the method's 1 s)",
    "cost.rest_weight=100": "the rest term of `release=still` at its weight (`cost.rest_weight`, 100 s^2), "
    "here on top of another release",
    "cost.lambda_c=3.0": "the contact term x3 (`cost.lambda_c`; the paper's 1): the stapler's grasp screen "
    "lifted it on 16 of 20 seeds against the method's 12 (the method_screen study)",
    "planner.carry_hold=1.0": "the carry's wait until the grasp has held (`carry=held`'s 1 s), here on top "
    "of `carry=pose`",
    "planner.carry_turn=1.0": "the carry turns the wrist too (`planner.carry_turn`, 1/s; `carry=held`'s 0): "
    "once the grasp has held, each plan also turns the wrist's committed hinge angles toward the rotation "
    "that takes the carried object's orientation to the reference's, through the wrist's rotational "
    "Jacobian, the object kept in place, at most 0.5 rad in all (`carry=pose`'s turn on `carry=held`)",
    "cost.surface_weight=1.0": "the surface term on top of the clearance term (`cost.surface_weight`; the "
    "method's 0): each link whose contact the reference expects is pulled onto the object wherever it "
    "touches it, read from the clearance term's distance sensors, so the palm and the proximal links close "
    "on the object as the reference's do (the method_screen study screened it on the stapler only)",
    "sampler.release.blend=1.0": "the release reset eases the committed control points into the release "
    "nominal over 1 s (`sampler.release.blend`; the method's 0: at once): the grip the plans walked into "
    "(finger targets at their limits) no longer jumps to the opening",
    "sampler.release.noise=1.0": "the release searched (`sampler.release.noise`; the method's 0, a "
    "schedule): the control points after the last expected contact get the sampling noise of before it, "
    "so the plans choose how the hand lets go by the object's tracking cost after it",
    "sampler.release.open=2.5": "the fingers open over 2.5 s (`sampler.release.open`; the method's 1 s)",
    "sampler.release.open=4.0": "the fingers open over 4 s (`sampler.release.open`; the method's 1 s)",
    "sampler.release.noise=0.0": "the release a schedule (`sampler.release.noise`; the method's 1, a "
    "search): no sampling noise on the control points after the last expected contact, so the hand opens "
    "as the release nominal does, whatever the plans' samples",
    "sampler.release.open_to=approach": "the fingers open to the reference's first pose, the approach's "
    "pre-shape (`sampler.release.open_to`; the method's flat hand)",
    "sampler.release.retract_again=True": "the retraction repeated at every later plan whose state has the "
    "hand still on the object (`sampler.release.retract_again`; `release=retract`'s once)",
    "sampler.release.blend=3.0": "the release reset eases the committed control points into the release "
    "nominal over 3 s (`sampler.release.blend`; the method's 1 s)",
    "sampler.release.retract_margin=0.002": "a finger within 2 mm of the object counts as touching it for "
    "the retraction and its repeats (`sampler.release.retract_margin`; the method's 0: the planning "
    "model's contacts only), so a link resting on the knob in the plant, just apart in the planning model, "
    "is moved off too",
    "planner.pace_lag=0.05": "`pacing=release` waits for the object's place only beyond 5 cm "
    "(`planner.pace_lag`; the group's 3 cm), the final tolerance, so it waits mostly for the object's "
    "orientation (`planner.pace_angle`, 20°)",
    "planner.pace_turn_fade=1.0": "the wrist's turn (`planner.pace_turn`) wound back to the reference's "
    "wrist angles over the 1 s after the last expected contact (`planner.pace_turn_fade`; `release_turn` "
    "keeps it), so the retraction does not bring the wrist's hinges to their gimbal lock",
    "planner.reuse_grasp=4": "the runners-up carried only from the reference's first instant with four "
    "fingers on the object (`planner.reuse_grasp`; `reuse=elites_expected`'s three): later where the "
    "reference closes its grasp finger by finger (*When the reference closes its grasp*)",
    "planner.reuse_fingers=2": "the runners-up carried only into the plans whose state has at least two "
    "fingers on the object (`planner.reuse_fingers`; `reuse=elites_grasped`'s gate), here on top of "
    "`reuse=elites_expected`'s",
    "planner.reuse_scaled=True": "the runners-up kept and carried in at `reuse=elites`'s share of a plan's "
    "samples (`planner.reuse_scaled`; the method's 8 whatever a plan's size): 32 of a grasp plan's 128, so "
    "a longer grasp window (`effort=acquire_long`) does not thin them out",
    "planner.pace_lag=0.035": "`pacing=hold` waits only while the object is more than 3.5 cm from where "
    "the reference has it (`planner.pace_lag`; the group's 2 cm, at which the apple's reference waited in "
    "every paced trial: *The lift paced by the grasp*), so the lift waits where a grasp is losing the object",
    "planner.reuse=4": "4 of the last plan's runners-up carried into the next (`planner.reuse`; "
    "`reuse=elites`'s 8), so a plan of 32 samples draws 28 fresh",
    "sampler.release.hold=1.0": "the wrist held still from 1 s before the reference's last expected "
    "contact (`sampler.release.hold`; `release=halt`'s 2 s), so a set-down the reference still makes in "
    "its last 2 s of contact (the bottle's) is not stopped short in the air",
}


def built_on(df: pd.DataFrame) -> str:
    """The method the trials ``df`` ran on top of: of the methods their names start with
    (``grasp_release_ahead_acquire`` of ``grasp_release_ahead_acquire+carry=held``; a lever's ``on``, where
    ``df`` has it: :func:`lever_frame`), the most common
    (ties: the first in :data:`ORDER`); :data:`METHOD` without any trial."""
    if not len(df) or "variant" not in df:
        return METHOD
    names = df["on"] if "on" in df else df["variant"].dropna().astype(str).str.split("+").str[0]
    counts = names.value_counts()
    rank = {m: i for i, m in enumerate(ORDER)}
    return min(counts.index, key=lambda m: (-counts[m], rank.get(m, len(rank)), m)) if len(counts) else METHOD


def lever_of(record_path) -> str:
    """A lever trial's overrides on top of the method, from its run folder's name (``cost.lambda_c=3.0``,
    ``pacing=release place=wrist``): every ``key=value`` but the experiment, the seed and the task."""
    parts = Path(record_path).parent.name.split(",")
    return " ".join(p for p in parts if p.split("=", 1)[0] not in ("experiment", "seed", "task"))


def lever_frame(study) -> pd.DataFrame:
    """The lever trials that count (:data:`LEVERS`, on the planned tasks, any seed), each with its
    ``lever`` (:func:`lever_of`), ``seeds`` (``"sweep"`` on the sweep's seeds, else ``"held out"``) and
    ``on``, the method it ran on top of (:func:`built_on`)."""
    df = frame(study, LEVERS)
    ok = df[df["counted"] & df["task"].isin(plan()[0])] if len(df) else df
    if not len(ok):
        return ok.assign(lever=[], seeds=[], on=[])
    half = np.where(ok["seed"].isin(plan()[1]), "sweep", "held out")
    levers = [lever_of(p) for p in ok["record_path"]]
    # the method it is on: the variant its overrides name, else the one its name starts with (a lever that
    # makes a named method, reuse=elites_expected variant=grasp_held_retract, is on the variant it names)
    named = [lever_variant(lever) for lever in levers]
    prefix = ok["variant"].astype(str).str.split("+").str[0]
    return ok.assign(lever=levers, seeds=half, on=[n or p for n, p in zip(named, prefix, strict=True)])


def _lever_text(lever: str) -> str:
    """What ``lever``'s overrides do: a group member's own description (from ``conf/``), else
    :data:`LEVER_TEXT`'s."""
    out = []
    for part in lever.split():
        key, member = part.split("=", 1)
        path = CONF / key / f"{member}.yaml"
        text = _comment(path) if path.is_file() else LEVER_TEXT.get(part, "no description kept (LEVER_TEXT)")
        out.append(f"`{part}`: " + text.rstrip("."))
    return "; ".join(out) + "."


def levers_figure(path: Path, rows: list[tuple[str, str, int, int, int, int, int]], on: str = METHOD) -> None:
    """Per task, each lever's trials finished cleanly (solid) and completed (pale) beside those of the method
    they are on (``on``) on the same seeds (grey): ``rows`` of ``(task, lever, n, completed, clean, method's
    completed, method's clean)``."""
    import matplotlib.pyplot as plt

    tasks = list(dict.fromkeys(r[0] for r in rows))
    levers = list(dict.fromkeys(r[1].removesuffix(HELD_OUT) for r in rows))  # a lever's colour
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    width = max(3.2, 0.9 * max(sum(r[0] == t for r in rows) for t in tasks) + 1.0)
    fig, axes = plt.subplots(1, len(tasks), figsize=(width * len(tasks), 4.2), squeeze=False, sharey=True)
    for ax, task in zip(axes[0], tasks, strict=True):
        mine = [r for r in rows if r[0] == task]
        for i, (_, lever, n, done, clean, base_done, base_clean) in enumerate(mine):
            c = colors[levers.index(lever.removesuffix(HELD_OUT)) % len(colors)]
            hatch = "//" if lever.endswith(HELD_OUT) else None  # the held-out seeds hatched
            for x, color, k, kc in ((i - 0.2, "0.55", base_done, base_clean), (i + 0.2, c, done, clean)):
                ax.bar(x, k / n, width=0.38, color=color, alpha=0.35)
                ax.bar(x, kc / n, width=0.38, color=color, hatch=hatch, edgecolor="white" if hatch else None)
                ax.text(x, k / n + 0.02, f"{kc}/{k}/{n}", ha="center", fontsize=6)
        ax.axhline(TARGET_CLEAN / TARGET_SEEDS, color="k", lw=0.8, ls="--")
        ax.set_title(task)
        ax.set_xticks(range(len(mine)), [r[1].replace(" ", "\n") for r in mine], fontsize=7, rotation=30)
        ax.set_ylim(0, 1.12)
        ax.set_xlim(-0.6, max(len(mine), 3) - 0.4)  # a task with one lever keeps narrow bars
    axes[0][0].set_ylabel("finished cleanly (solid), completed (pale)")
    fig.suptitle(
        f"each lever (colour) beside {on} on the same seeds (grey); clean/completed/seeds", fontsize=8
    )
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def stacked(ok: pd.DataFrame) -> str:
    """Each lever against a lever it builds on (whose overrides are a part of its own: ``carry=held``
    under ``carry=held grip=squeeze``) on the seeds both ran, per task and pooled; "" where none does."""
    levers = sorted(set(ok["lever"]))
    out = []
    for lever in levers:
        for under in (b for b in levers if set(b.split()) < set(lever.split())):
            parts, totals = [], np.zeros(5, int)
            for task in plan()[0]:
                a = ok[(ok["lever"] == lever) & (ok["task"] == task)]
                b = ok[(ok["lever"] == under) & (ok["task"] == task)]
                both = sorted(set(a["seed"]) & set(b["seed"]))
                if not both:
                    continue
                a, b = a[a["seed"].isin(both)], b[b["seed"].isin(both)]
                counts = np.array([len(both), a["completed"].sum(), a["finished_cleanly"].sum(),
                                   b["completed"].sum(), b["finished_cleanly"].sum()], int)  # fmt: skip
                totals += counts
                n, done, clean, base_done, base_clean = counts
                parts.append(
                    f"{task} (seeds {seeds(both)}) {clean} of {n} finished cleanly against {base_clean}, "
                    f"completed {done} against {base_done}"
                )
            if not parts:
                continue
            n, done, clean, base_done, base_clean = totals
            p, _ = completion_test(clean, n, base_clean, n)
            out.append(
                f"`{lever}` against `{under}`: " + "; ".join(parts) + f"; in all {clean} of {n} against "
                f"{base_clean} ({clean - base_clean:+d}), completed {done} against {base_done}, Barnard p = "
                f"{Fmt.p(p)}"
            )
    if not out:
        return ""
    return (
        "Levers on top of another lever, against it on the seeds both ran (held-out seeds counted in): "
        + "; ".join(out)
        + ".\n\n"
    )


def lever_names(ok: pd.DataFrame) -> tuple[dict[str, str], dict[str, str]]:
    """Per lever of ``ok`` (:func:`lever_frame`): the method it ran on (:func:`built_on`), and its name in
    the report's tables: the lever alone on the method most levers ran on, else ``lever` on `method``."""
    on = built_on(ok)
    bases = {lever: built_on(g) for lever, g in ok.groupby("lever", sort=True)}  # the method each is on
    return bases, {lever: lever if m == on else f"{lever}` on `{m}" for lever, m in bases.items()}


def levers_section(study, chosen: pd.DataFrame) -> str:
    """Each lever on top of a method (:data:`LEVERS`; the method they ran on, :func:`built_on`) against that
    method's trials on the same seeds (on the held-out ones with its stand-ins, :func:`heldout_frame`), per
    task: the counts, Barnard's test on finishing cleanly, the CPU-s ratio; a figure of the counts."""
    ok = lever_frame(study)
    on = built_on(ok)
    head = (
        f"Options on top of `{on}` (the paper tasks' default when they ran) run as full trials on the "
        "sweep's seeds (stapler first, the task furthest from the target, then the bottle and the apple; "
        f"seeds vary fastest), kept in `{LEVERS}/` (`{LEVERS_RUN}`), each against `{on}`'s own trials on the "
        f"same seeds (on seeds {HELDOUT_SEEDS}, its held-out trials, stand-ins counted in: *On seeds it was "
        "not chosen on*); a "
        "lever run on top of another method (`lever` on `method`) against that method's trials.\n\n"
    )
    if not len(ok):
        return head + "No such trial is kept yet.\n"
    every = with_heldout(study, chosen)  # the held-out seeds' with the stand-ins counted in
    rows, fig_rows = [], []
    # each override once, also where several levers combine it (carry=pose, carry=pose pacing=release)
    notes = [f"- {_lever_text(part)}" for part in sorted({p for lever in ok["lever"] for p in lever.split()})]
    bases, named = lever_names(ok)
    base_of = {lever: every[every["variant"] == m] if len(every) else every for lever, m in bases.items()}
    for lever, g in ok.groupby("lever", sort=True):
        base = base_of[lever]
        for task, half in ((t, h) for t in plan()[0] for h in ("sweep", "held out")):
            h = g[(g["task"] == task) & (g["seeds"] == half)].sort_values("seed")
            if not len(h):
                continue
            c = base[(base["task"] == task) & base["seed"].isin(h["seed"])]
            hk, hc = int(h["completed"].sum()), int(h["finished_cleanly"].sum())
            ck, cc = int(c["completed"].sum()), int(c["finished_cleanly"].sum())
            p, _ = completion_test(hc, len(h), cc, len(c)) if len(c) else (math.nan, math.nan)
            one = len(c) and cost_processor(h) == cost_processor(c)  # seconds of one processor alone
            ratio = h["cpu_seconds"].median() / c["cpu_seconds"].median() if one else math.nan
            both = set(c["seed"])  # a seed the method has no trial on is in neither list
            with_lever, without = (set(x.loc[x["finished_cleanly"], "seed"]) & both for x in (h, c))
            only, lost = sorted(with_lever - without), sorted(without - with_lever)
            mm = [f"{median(x[col], scale=1e3)}" for col in ("_span", "_final") for x in (h, c)]
            errors = f"{mm[0]} / {mm[1]} | {mm[2]} / {mm[3]}"
            where = task if half == "sweep" else task + HELD_OUT
            rows.append(
                f"| `{named[lever]}` | {where} | {seeds(h['seed'])} | {of(hk, len(h))} | {of(hc, len(h))} "
                f"| {of(ck, len(c))} | {of(cc, len(c))} | {Fmt.p(p)} | {seeds(only)} | {seeds(lost)} "
                f"| {errors} | {'' if math.isnan(ratio) else f'{ratio:.2f}'} |"
            )
            if len(c) == len(h):
                name = named[lever] if half == "sweep" else named[lever] + HELD_OUT
                fig_rows.append((task, name, len(h), hk, hc, ck, cc))
    best = []  # per task, the lever (of >= 5 seeds) with the largest difference in seeds finished cleanly
    whole: dict[tuple[str, str], np.ndarray] = {}  # a lever's counts over all its seeds, held out too
    for task, name, *counts in fig_rows:
        key = (task, name.removesuffix(HELD_OUT))
        whole[key] = whole.get(key, np.zeros(5, int)) + np.array(counts)
    for task in plan()[0]:
        mine = [(k[0], k[1], *v) for k, v in whole.items() if k[0] == task and v[0] >= 5]
        if mine:
            _, lever, n, _, clean, _, base_clean = max(mine, key=lambda r: ((r[4] - r[6]) / r[2], r[2]))
            best.append(
                f"{task}: `{lever}`, {clean} of {n} finished cleanly against {base_clean} of {n} "
                f"({clean - base_clean:+d})"
            )
    summary = (
        "Per task, of the levers run on at least 5 seeds (held-out seeds counted in), the one with the "
        "largest difference in trials finished cleanly against the method on the same seeds (as a share of "
        "the seeds; a negative difference: none did better): " + "; ".join(best) + ".\n\n"
        if best
        else ""
    )
    pooled = []  # per lever, over every task and seed it ran on (at least 10 trials)
    for lever in dict.fromkeys(k[1] for k in whole):
        n, done, clean, base_done, base_clean = sum(v for k, v in whole.items() if k[1] == lever)
        if n >= 10:
            p, _ = completion_test(clean, n, base_clean, n)
            tasks = [k[0] for k in whole if k[1] == lever]
            text = (
                f"`{lever}` ({', '.join(tasks)}): {clean} of {n} finished cleanly against {base_clean} "
                f"({clean - base_clean:+d}), completed {done} against {base_done}, Barnard p = {Fmt.p(p)}"
            )
            pooled.append((clean - base_clean, text))
    if pooled:
        pooled.sort(key=lambda r: -r[0])
        summary += (
            "Pooled over the tasks each lever ran on (levers with at least 10 trials; its seeds and the "
            "method's on the same seeds): " + "; ".join(text for _, text in pooled) + ".\n\n"
        )
    summary += stacked(ok)
    apart = []  # per lever, its trials whose seed the method ran on another processor
    for lever, g in ok.groupby("lever", sort=True):
        base = base_of[lever]
        where = base.set_index(["task", "seed"])["cpu"] if "cpu" in base else pd.Series(dtype=object)
        where = where[~where.index.duplicated()]
        pairs = [(r["task"], r["seed"], r.get("cpu")) for r in g.to_dict("records")]
        off = [(t, sd) for t, sd, cpu in pairs if (t, sd) in where.index and where[(t, sd)] != cpu]
        if off:
            per = "; ".join(
                f"{t} {seeds([sd for tt, sd in off if tt == t])}" for t in sorted({t for t, _ in off})
            )
            apart.append(f"`{named[lever]}` {len(off)} of {len(pairs)} ({per})")
    cpus = (
        "Trials whose seed the method ran on another processor (a lent 16-core machine's or this one's; "
        "the same config and seed on another processor is another draw, so for these only the counts "
        "compare, not the seeds): " + "; ".join(apart) + ".\n\n"
        if apart
        else ""
    )
    cols = ("lever", "task", "seeds", "completed", "finished cleanly", f"`{on}`: completed",
            "finished cleanly", "Barnard p (clean)", "clean only with the lever", "clean only without",
            "object error over the span, mm: lever / method", "final", "CPU-s, x the method's")  # fmt: skip
    link = (
        study.draw(
            "levers.png",
            lambda path: levers_figure(path, fig_rows, on),
            "the levers on the method: trials finished cleanly and completed, per task",
        )
        if fig_rows
        else None
    )
    return (
        head
        + summary
        + cpus
        + "The levers:\n\n"
        + "\n".join(notes)
        + "\n\n"
        + pipe_table(cols, "lllrrrrrllrrr", rows)
        + "\nBarnard's exact two-sided p on finishing cleanly (the seeds are paired, the test treats the two "
        "sides as independent samples); the object's position error, the median over the trials of its mean "
        "over the contact span, and at the trial's end; CPU-s: the medians' ratio, on the seeds both have, "
        "where most trials of both ran on one processor (blank: on two; the host's family and model tell "
        "them apart; the method's trials ran at earlier code revisions, so a ratio below 1 for a lever that "
        "adds no rollouts is the code's speed-up since, not the lever's). A lever with fewer seeds than the "
        "sweep's was stopped for one that looked more promising: its counts are of its seeds only.\n"
        + (f"\n{link}\n" if link else "")
    )


GRASP_LEVER = "carry=held"
GRASP_LIFT = 0.05  # m: a sample counts as carried where the object and the reference's are this far up


def carried(series) -> np.ndarray | None:
    """(N,) a trial's carried samples: its free object and the reference's both more than
    :data:`GRASP_LIFT` above where the object starts; ``None`` for an object without a free body (the
    doorknob's articulations) or where nothing is carried."""
    qo, expected = series["object_qpos"], series["expected_object_qpos"]
    if qo.shape[1] < 7:
        return None
    up = (qo[:, 2] - qo[0, 2] > GRASP_LIFT) & (expected[:, 2] - qo[0, 2] > GRASP_LIFT)
    return up if up.any() else None


def _grasp_groups() -> dict[str, list[int]]:
    """The link groups of :func:`grasp_section` as columns of a trial's ``contacts`` (the Allegro's links)."""
    from contactmpc.hands import AllegroPaperHand

    links = AllegroPaperHand.LINKS
    groups = {"palm": ["palm"]}
    for finger, name in (("ff", "index"), ("mf", "middle"), ("rf", "ring"), ("th", "thumb")):
        groups[f"{name}, base and proximal"] = [f"{finger}_base", f"{finger}_proximal"]
        groups[f"{name}, medial"] = [f"{finger}_medial"]
        groups[f"{name}, distal and tip"] = [f"{finger}_distal", f"{finger}_tip"]
    return {g: [links.index(n) for n in names] for g, names in groups.items()}


def carried_contacts(record_path: str, columns: dict[str, list[int]]) -> tuple[dict, float, float] | None:
    """A trial's contacts while its object is carried (:func:`carried`, from its kept time series): per
    group of ``columns``, the shares of the carried samples on which a link of the group touches the object
    and on which the reference expects it to; the mean number of links in contact, and expected. ``None``
    without a time series or a carry."""
    path = Path(record_path).parent / "timeseries.npz"
    series = np.load(path) if path.is_file() else None
    up = None if series is None else carried(series)
    if up is None:
        return None
    touch, expect = series["contacts"][up], series["expected_contacts"][up]
    group = {g: (touch[:, c].any(axis=1).mean(), expect[:, c].any(axis=1).mean()) for g, c in columns.items()}
    return group, touch.sum(axis=1).mean(), expect.sum(axis=1).mean()


def grasp_section(study) -> str:
    """What holds the carried object: per link group, the share of the carried samples on which a link of
    the group touches it in :data:`GRASP_LEVER`'s trials, against the share on which the reference expects
    it (the trials' own time series, kept in ``levers/``); the mean number of links in contact; and
    :func:`grasp_levers`, the other levers' contacts against it."""
    everything = lever_frame(study)
    ok = everything[everything["lever"] == GRASP_LEVER] if len(everything) else everything
    columns = _grasp_groups()
    per_task, counts = {}, []
    for task in plan()[0]:
        shares = [
            x for r in ok[ok["task"] == task].itertuples() if (x := carried_contacts(r.record_path, columns))
        ]
        if shares:
            per_task[task] = shares
            plant, reference = (np.mean([x[i] for x in shares]) for i in (1, 2))
            counts.append(
                f"{task} ({len(shares)} trial{'s' * (len(shares) != 1)}): {plant:.1f} links in contact on "
                f"average against the reference's {reference:.1f}"
            )
    if not per_task:
        return f"No `{GRASP_LEVER}` trial with a time series and a carry is kept yet.\n"
    rows = []
    for g in columns:
        cells = []
        for task in per_task:
            plant = np.mean([x[0][g][0] for x in per_task[task]])
            reference = np.mean([x[0][g][1] for x in per_task[task]])
            cells.append(f"{plant:.2f} / {reference:.2f}")
        rows.append(f"| {g} | " + " | ".join(cells) + " |")
    cols = ("links", *(f"{t}: plant / reference" for t in per_task))
    return (
        "While the object is carried (it and the reference's object both more than "
        f"{GRASP_LIFT * 100:.0f} cm above where it starts), which of the hand's links touch it in "
        f"`{GRASP_LEVER}`'s trials (the lever's time series are kept in `{LEVERS}/`), against where the "
        "reference expects contact: per group of links, the share of the carried samples on which a link of "
        "the group touches the object (plant) or is expected to (reference), the mean over the trials. Links "
        "in contact per carried sample: "
        + "; ".join(counts)
        + ".\n\n"
        + pipe_table(cols, "l" + "r" * len(per_task), rows)
        + grasp_levers(everything)
    )


def grasp_levers(ok: pd.DataFrame) -> str:
    """The levers built to close the grasp, against :data:`GRASP_LEVER` on the seeds both carried the object:
    per lever that builds on it (not a :func:`release_lever`, which changes nothing before the release) and
    task, the mean links in contact while carried and the palm's share of
    the carried samples (:func:`carried_contacts`); empty where no such lever has a time series kept."""
    columns = _grasp_groups()
    built_on = [x for x in set(ok["lever"]) if x.startswith(GRASP_LEVER + " ")] if len(ok) else []
    levers = sorted(x for x in built_on if not release_lever(x))  # a release lever's carry is GRASP_LEVER's
    if not levers:
        return ""
    base = {  # GRASP_LEVER's carried contacts, read once for every lever
        (r.task, int(r.seed)): x
        for r in ok[ok["lever"] == GRASP_LEVER].itertuples()
        if (x := carried_contacts(r.record_path, columns)) is not None
    }
    rows = []
    for lever in levers:
        for task in plan()[0]:
            pairs = {}
            for r in ok[(ok["lever"] == lever) & (ok["task"] == task)].itertuples():
                key = (task, int(r.seed))
                if key in base and (x := carried_contacts(r.record_path, columns)) is not None:
                    pairs[int(r.seed)] = {"lever": x, "base": base[key]}
            both = sorted(pairs)
            if not both:
                continue
            mean = {
                side: (
                    np.mean([pairs[s][side][1] for s in both]),
                    np.mean([pairs[s][side][0]["palm"][0] for s in both]),
                )
                for side in ("lever", "base")
            }
            rows.append(
                f"| `{lever}` | {task} | {_seeds(both)} | {mean['lever'][0]:.1f} / {mean['base'][0]:.1f} | "
                f"{mean['lever'][1]:.2f} / {mean['base'][1]:.2f} |"
            )
    if not rows:
        return ""
    cols = (
        "lever",
        "task",
        "seeds both carried",
        f"links in contact: lever / `{GRASP_LEVER}`",
        "palm's share",
    )
    return (
        f"\nThe levers built on `{GRASP_LEVER}` to close the grasp, against it on the seeds on which both "
        "carried the object (their kept time series): the mean links in contact per carried sample, and the "
        "share of the carried samples on which the palm touches the object.\n\n"
        + pipe_table(cols, "lllrr", rows)
    )


def release_lever(lever: str) -> bool:
    """Whether ``lever`` is :data:`GRASP_LEVER` with only release options on top (``sampler.release.*``,
    ``release=``): a lever that changes nothing before the reference's last expected contact but the plans
    whose window reaches past it."""
    parts = lever.split()
    extra = parts[len(GRASP_LEVER.split()) :]
    return (
        parts[: len(GRASP_LEVER.split())] == GRASP_LEVER.split()
        and bool(extra)
        and all(p.startswith(("sampler.release.", "release=")) for p in extra)
    )


def departs(a: str, b: str) -> float | None:
    """The first logged time (s) at which trial ``a``'s plant (its kept ``qpos``) differs from trial
    ``b``'s (record paths); ``None`` where they never do or a time series is missing."""
    series = []
    for path in (a, b):
        f = Path(path).parent / "timeseries.npz"
        if not f.is_file():
            return None
        series.append(np.load(f))
    n = min(len(series[0]["time"]), len(series[1]["time"]))
    differ = np.flatnonzero((series[0]["qpos"][:n] != series[1]["qpos"][:n]).any(axis=1))
    return float(series[0]["time"][differ[0]]) if differ.size else None


def _let_go(x, task: str) -> str:
    """A trial's object error (a record's fields) where the contact span ends → at the trial's end: the free
    body's position and orientation, or an articulated object's articulations (the doorknob's)."""
    if task == "doorknob":
        where = (x["object_articulation_error_span_final"], x["final_object_articulation_error"])
        return " → ".join(f"{1e3 * v:.0f} x 1e-3" for v in where)
    where = (
        (x["object_position_error_span_final"], x["object_rotation_error_span_final"]),
        (x["final_object_position_error"], x["final_object_rotation_error"]),
    )
    return " → ".join(f"{pos * 1000:.0f} mm, {math.degrees(rot):.0f}°" for pos, rot in where)


def lost_letting_go(x: pd.Series, task: str, seed: int) -> bool:
    """Whether a free object's completed trial (a record's fields) lost its object as the hand let go: inside
    the tolerances where the span ends and outside at the end, or toppled (:func:`endings`); never for the
    doorknob, whose knob has no free body to topple or set down."""
    if task == "doorknob" or not x["completed"] or x["finished_cleanly"]:
        return False
    found = endings(pd.DataFrame([{**x.to_dict(), "seed": seed}]), task)
    return bool(found.get("toppled") or found.get("outside"))


def release_section(study) -> str:
    """The release levers (:func:`release_lever`) against :data:`GRASP_LEVER` on the same seeds, per trial:
    when it departs from :data:`GRASP_LEVER`'s trial (:func:`departs`; on one processor and code the two
    are the same trial until the plans reach past the last expected contact), the object's error where the
    hand lets go and at the end, finished cleanly."""
    ok = lever_frame(study)
    if not len(ok):
        return "No release lever has been run yet.\n"
    base = ok[ok["lever"] == GRASP_LEVER].set_index(["task", "seed"])
    rows, tally = [], {}
    for lever in sorted(set(ok["lever"])):
        if not release_lever(lever):
            continue
        for r in ok[ok["lever"] == lever].sort_values(["task", "seed"]).itertuples():
            if (r.task, r.seed) not in base.index:
                continue
            b = base.loc[(r.task, r.seed)]
            at = departs(r.record_path, b["record_path"])
            end = float(r.contact_span_end)
            when = "never" if at is None else f"{at - end:+.2f} s"
            errors = f"{_let_go(b, r.task)} | {_let_go(r._asdict(), r.task)}"
            rows.append(
                f"| `{lever}` | {r.task} | {r.seed} | {when} | {errors} | "
                f"{'yes' if r.finished_cleanly else 'no'} / {'yes' if b['finished_cleanly'] else 'no'} |"
            )
            t = tally.setdefault(
                lever, {"n": 0, "clean": 0, "base_clean": 0, "base_lost": [], "fixed": [], "lost": []}
            )
            where = f"{r.task} {r.seed}"
            t["n"] += 1
            t["clean"] += bool(r.finished_cleanly)
            t["base_clean"] += bool(b["finished_cleanly"])
            if lost_letting_go(b, r.task, r.seed):
                t["base_lost"].append(where)
                if r.finished_cleanly:
                    t["fixed"].append(where)
            if b["finished_cleanly"] and lost_letting_go(pd.Series(r._asdict()), r.task, r.seed):
                t["lost"].append(where)
    if not rows:
        return "No release lever has been run yet.\n"
    cols = ("lever", "task", "seed", f"departs from `{GRASP_LEVER}`, after the last expected contact",
            f"`{GRASP_LEVER}`: error where the hand lets go → at the end", "lever: the same",
            f"finished cleanly: lever / `{GRASP_LEVER}`")  # fmt: skip

    def lost(v: dict) -> str:
        words = []
        if v["base_lost"]:
            words.append(
                f"`{GRASP_LEVER}` lost the object as the hand let go on {', '.join(v['base_lost'])}; the "
                f"lever finished {len(v['fixed'])} of those cleanly"
            )
        if v["lost"]:
            words.append(
                f"the lever lost it so where `{GRASP_LEVER}` finished cleanly on {', '.join(v['lost'])}"
            )
        return f" ({'; '.join(words)})" if words else ""

    summary = "; ".join(
        f"`{k}` {v['clean']} of {v['n']} finished cleanly against {v['base_clean']}{lost(v)}"
        for k, v in tally.items()
    )
    return (
        f"Options of the release on top of `{GRASP_LEVER}` change nothing before the reference's last "
        "expected contact but the plans whose window reaches past it, so on the same processor and code a "
        f"trial is `{GRASP_LEVER}`'s own until then and the pair differs by the release alone (the column "
        "*departs* says where the two plants first differ, from their kept time series; negative: a plan "
        "before the last contact already saw the changed release). Per trial, the object's position and "
        "orientation error where the contact span ends and at the trial's end (the doorknob's: its "
        "articulation, rad or m for a slide). Lost as the hand let go: "
        "inside the task's tolerances where the span ends and outside them at the end, or toppled "
        "(*Where the method falls short*). " + summary + ".\n\n" + pipe_table(cols, "lllrlll", rows)
    )


#: The bins of :func:`set_down`: the free object's orientation error (degrees) where the hand lets go, up
#: to :data:`TOPPLE_FROM` (and from it on).
SET_DOWN_BINS = (0.0, 15.0, 30.0)


def binned_table(lead: str, said: list[str], cols: tuple[str, ...], rows: list[str]) -> str:
    """A binned table's text: ``lead``, the clauses ``said``, then the table (a label and a count, then
    the bins)."""
    return (
        lead
        + ("; ".join(said) + "." if said else "")
        + "\n\n"
        + pipe_table(cols, "lr" + "r" * (len(cols) - 2), rows)
    )


def bin_heads(edges: tuple[float, ...], prefix: str = "") -> list[str]:
    """The column heads of bins between consecutive ``edges`` (degrees): ``"<prefix>0-15°"``."""
    return [f"{prefix}{lo:.0f}-{hi:.0f}°" for lo, hi in zip(edges[:-1], edges[1:], strict=True)]


def set_down(study) -> str:
    """Per free-object task, every completed trial the study keeps (the sweep's, held-out and lever
    trials, every method) by its object's orientation error where the contact span ends
    (:data:`SET_DOWN_BINS`): how many toppled after the hand let go (:func:`endings`) and how many
    finished cleanly."""
    sweep = frame(study)
    parts = [p for p in (sweep, frame(study, HELDOUT), frame(study, LEVERS)) if len(p)]
    if not parts:
        return ""
    df = pd.concat(parts, ignore_index=True)
    done = df[df["counted"] & df["completed"] & df["task"].isin(plan()[0]) & df["task"].ne("doorknob")]
    rows, said = [], []
    bins = (*SET_DOWN_BINS, TOPPLE_FROM)
    edges = (*bins, math.inf)
    for task in [t for t in plan()[0] if t in set(done["task"])]:
        g = done[done["task"] == task].reset_index(drop=True)
        deg = np.degrees(pd.to_numeric(g["object_rotation_error_span_final"], errors="coerce"))
        toppled = set(endings(g.assign(seed=g.index), task).get("toppled", []))
        cells = []
        for lo, hi in zip(edges[:-1], edges[1:], strict=True):
            inside = g.index[(deg >= lo) & (deg < hi)]
            n, top = len(inside), sum(i in toppled for i in inside)
            clean = int(g.loc[inside, "finished_cleanly"].sum())
            top = "–" if lo >= TOPPLE_FROM else top  # (toppled counts only what was upright enough)
            cells.append(f"{top} / {clean} of {n}" if n else "none")
        rows.append(f"| {task} | {len(g)} | " + " | ".join(cells) + " |")
        low = g.index[deg < SET_DOWN_BINS[1]]
        high = g.index[(deg >= SET_DOWN_BINS[2]) & (deg < TOPPLE_FROM)]
        if len(low) and len(high):
            said.append(
                f"{task}: {sum(i in toppled for i in high)} of {len(high)} set down "
                f"{SET_DOWN_BINS[2]:.0f}-{TOPPLE_FROM:.0f}° off toppled, against "
                f"{sum(i in toppled for i in low)} of {len(low)} set down under {SET_DOWN_BINS[1]:.0f}°"
            )
    if not rows:
        return ""
    heads = bin_heads(bins)
    paired_rows = set_down_pairs(counted(sweep))
    cols = ("task", "completed trials", *heads, f"{TOPPLE_FROM:.0f}° or more")
    return binned_table(
        "Every completed trial kept here (the sweep's, the held-out and the levers' trials, every method), "
        "by how far the object's orientation was off the reference's where the contact span ends (where the "
        "hand lets go); each cell: toppled after the hand let go / finished cleanly, of the trials in the "
        f"bin (toppled: under {TOPPLE_FROM:.0f}° where the span ends, {TOPPLE_TO:.0f}° or more at the end). "
        "The error is the whole rotation, the spin about the vertical included, which tips nothing over. ",
        said,
        cols,
        rows,
    ) + (
        set_down_tilt(done)
        + (
            "\nEach method built on `"
            + free_base()
            + "` against it, on the sweep's seeds both completed: the "
            "object's orientation error where the hand lets go (median, degrees), and the Wilcoxon "
            "signed-rank test on the paired seeds (exact, two-sided), a continuous measure with more "
            "power than the counts of clean finishes.\n\n"
            + pipe_table(
                ("method", "task", "seeds", "median: method / " + free_base(), "lower on", "Wilcoxon p"),
                "lllrrr",
                paired_rows,
            )
            if paired_rows
            else ""
        )
    )


#: Bins of the tilt where the hand lets go (degrees), and the tilt at the end from which an object lies over.
TILT_BINS = (0.0, 5.0, 10.0, 20.0)
LYING = 45.0
#: Free objects with an upright to tip from (the apple, a sphere, has none).
UPRIGHT_TASKS = ("bottle", "stapler")


def tilts(record_path, span_end: float | None) -> tuple[float, float]:
    """A trial's tilt off the reference's orientation (degrees, :func:`~contactmpc.tasks.layout.tilt_angle`:
    the spin about the vertical left out) where its contact span ends (``span_end``, the record's) and at
    the end, from its ``timeseries.npz`` beside the record; NaN where it has none that the study keeps (a
    sweep's ``records/`` keep only ``trial.json``), no span, or an object that is not one free body."""
    from contactmpc.tasks.layout import tilt_angle

    run = Path(record_path).parent
    series = run / "timeseries.npz"
    # a sweep's records/ keep only trial.json (.gitignore): a time series there is this machine's alone
    if not series.is_file() or run.parent.name == "records" or span_end is None or pd.isna(span_end):
        return math.nan, math.nan
    z = np.load(series)
    if z["object_qpos"].shape[-1] != 7:
        return math.nan, math.nan
    angle = np.degrees(tilt_angle(z["object_qpos"][:, 3:7], z["expected_object_qpos"][:, 3:7]))
    inside = np.flatnonzero(z["time"] <= span_end + 1e-9)
    return (float(angle[inside[-1]]) if len(inside) else math.nan), float(angle[-1])


def set_down_tilt(done: pd.DataFrame) -> str:
    """The completed trials of :func:`set_down` that keep a time series, per task of
    :data:`UPRIGHT_TASKS`, by the object's tilt where the hand lets go (:data:`TILT_BINS`): how many lie
    over at the end (tilted :data:`LYING` or more) and how many finished cleanly; and how much of the
    orientation error where the hand lets go is tilt."""
    rows, said = [], []
    edges = (*TILT_BINS, math.inf)
    if "record_path" not in done:
        return ""
    for task in [t for t in UPRIGHT_TASKS if t in set(done["task"])]:
        g = done[done["task"] == task]
        span_end = g["contact_span_end"] if "contact_span_end" in g else pd.Series(None, index=g.index)
        columns = (g["record_path"], span_end, g["finished_cleanly"], g["object_rotation_error_span_final"])
        found = [(*tilts(p, e), c, r) for p, e, c, r in zip(*columns, strict=True)]
        found = [f for f in found if not math.isnan(f[0])]
        if not found:
            continue
        at, end, clean, whole = (np.array(x, float) for x in zip(*found, strict=True))
        cells = []
        for lo, hi in zip(edges[:-1], edges[1:], strict=True):
            inside = (at >= lo) & (at < hi)
            n = int(inside.sum())
            lying, ok = int((end[inside] >= LYING).sum()), int(clean[inside].sum())
            cells.append(f"{lying} / {ok} of {n}" if n else "none")
        rows.append(f"| {task} | {len(found)} | " + " | ".join(cells) + " |")
        off = np.degrees(pd.to_numeric(pd.Series(whole), errors="coerce")).to_numpy()
        wide = (off >= SET_DOWN_BINS[2]) & (off < TOPPLE_FROM)
        if wide.any():
            said.append(
                f"{task}: of the {int(wide.sum())} set down {SET_DOWN_BINS[2]:.0f}-{TOPPLE_FROM:.0f}° off in "
                f"all, the median tilt was {np.median(at[wide]):.1f}° (the rest is spin about the vertical), "
                f"and {int((end[wide] >= LYING).sum())} lay over at the end"
            )
    if not rows:
        return ""
    heads = bin_heads(TILT_BINS, "tilt ")
    cols = ("task", "trials with a time series", *heads, f"tilt {TILT_BINS[-1]:.0f}° or more")
    return binned_table(
        "\nThe same trials where their time series are kept (`timeseries.npz` beside the record: the "
        "held-out and the levers' trials), by the object's tilt where the hand lets go: the angle between "
        "the vertical as the object sees it and as "
        "the reference's does, which leaves out the spin about the vertical (`contactmpc.tasks.layout."
        f"tilt_angle`). Each cell: lying over at the end (tilted {LYING:.0f}° or more) / finished cleanly, "
        "of the trials in the bin. ",
        said,
        cols,
        rows,
    )


def _paced_series(record_path):
    """A paced trial's ``timeseries.npz`` (None without one that logs the reference's time), and its rows
    whose reference time lies before the release's window (``planner.pace_window`` from the reference's last
    expected contact, read from the series): the grasp's waits (``planner.pace_grasp``, or ``pacing=hold``
    without a window) are there, the release's after; all rows without a window."""
    series = Path(record_path).parent / "timeseries.npz"
    if not series.is_file():
        return None, None
    z = np.load(series)
    if "reference_time" not in z.files:
        return None, None
    record = Path(record_path)
    window = None
    if record.is_file():
        window = ((read_record(record).get("config") or {}).get("planner") or {}).get("pace_window")
    s = z["reference_time"]
    touch = z["expected_contacts"].any(axis=1) if "expected_contacts" in z.files else np.zeros(len(s), bool)
    if window is None or not touch.any():
        return z, np.ones(len(s), bool) if window is None else np.zeros(len(s), bool)
    return z, s < s[touch].max() + window[0] - 1e-9


def paced_waits(record_path) -> tuple[float, float, float, float] | None:
    """A paced trial's release wait, from its ``timeseries.npz``: ``(seconds the reference fell behind there
    in all, the object's tilt off the reference's where it began to wait, where it stopped, at the trial's
    end)`` (degrees, :func:`~contactmpc.tasks.layout.tilt_angle`); NaN for the wait's tilts where it never
    waited; ``None`` without a series that logs the reference's time or a single free body. A trial that
    paces the grasp too (``planner.pace_grasp``) counts only the waits from the release's window on."""
    from contactmpc.tasks.layout import tilt_angle

    z, grasp = _paced_series(record_path)
    if z is None or z["object_qpos"].shape[-1] != 7:
        return None
    behind = z["time"] - z["reference_time"]
    if grasp.all():  # (no window: every wait counts)
        grasp = np.zeros(len(grasp), bool)
    before = behind[grasp].max() if grasp.any() else 0.0  # the grasp's waits
    waiting = np.flatnonzero((np.diff(behind) > 1e-9) & ~grasp[:-1])  # rows after which it fell behind
    angle = np.degrees(tilt_angle(z["object_qpos"][:, 3:7], z["expected_object_qpos"][:, 3:7]))
    if not len(waiting):
        return 0.0, math.nan, math.nan, float(angle[-1])
    return (
        float(behind.max() - before),
        float(angle[waiting[0]]),
        float(angle[waiting[-1] + 1]),
        float(angle[-1]),
    )


def grasp_waits(record_path) -> tuple[float, float, float, float] | None:
    """A trial's grasp wait (``pacing=hold*``), from its ``timeseries.npz``: ``(seconds the reference fell
    behind before the release's window, the reference's time where it first waited after its first expected
    contact (s), the object's position error there and where the grasp's last wait ended (mm))``; NaN but
    the first where it never waited there; ``None`` without a series that logs the reference's time and its
    expected contacts."""
    z, grasp = _paced_series(record_path)
    if z is None or "expected_contacts" not in z.files or not z["expected_contacts"].any():
        return None
    s = z["reference_time"]
    behind = z["time"] - s
    waiting = np.flatnonzero((np.diff(behind) > 1e-9) & grasp[:-1])
    if not len(waiting):
        return 0.0, math.nan, math.nan, math.nan
    first = s[z["expected_contacts"].any(axis=1)].min()
    error = z["object_position_error"] * 1e3
    return (float(behind[grasp].max()), float(s[waiting[0]] - first), float(error[waiting[0]]),
            float(error[waiting[-1] + 1]))  # fmt: skip


def _paced_levers(study, chosen: pd.DataFrame, kind: str):
    """The lever trials whose ``pacing`` member (as their record composed it) names ``kind`` (``"release"``:
    the release paced, ``"hold"``: the grasp, ``lift`` too), as ``(trials, each lever's method, each lever's
    name as the levers' table has it, whether the method finished cleanly per (method, task, seed),
    stand-ins counted in)``; ``None`` without any."""
    ok = lever_frame(study)
    if not len(ok):
        return None
    bases, named = lever_names(ok)  # (as the levers' table names them)
    # the pacing its record composed (a lever on a paced method names none: pacing=lift is hold's, at 3.5 cm)
    kinds = (kind, "lift") if kind == "hold" else (kind,)
    paced = ok["pacing"].astype(str) if "pacing" in ok else pd.Series("", index=ok.index)
    # (a retry lever is shown apart: its own kind)
    ok = ok[[any(k in p for k in kinds) and ("retry" in p) == ("retry" in kind) for p in paced]]
    if not len(ok):
        return None
    every = with_heldout(study, chosen)
    clean = {
        (r["variant"], r["task"], r["seed"]): bool(r["finished_cleanly"]) for r in every.to_dict("records")
    }
    return ok, bases, named, clean


def _paced_trials(found, measure):
    """Each trial of :func:`_paced_levers`'s ``found`` by lever, task and seed, with what ``measure`` reads
    from its record's path (left out where it reads ``None``) and whether the method it is on finished
    cleanly on that seed (``None``: no trial of it there)."""
    ok, bases, _, clean = found
    for r in ok.sort_values(["lever", "task", "seed"]).to_dict("records"):
        waits = measure(r["record_path"])
        if waits is not None:
            yield r, waits, clean.get((bases[r["lever"]], r["task"], r["seed"]))


def _outcome(r) -> str:
    """How a trial (a record's row) ended: ``clean``, ``completed`` or ``not completed``."""
    return "clean" if r["finished_cleanly"] else "completed" if r["completed"] else "not completed"


def _ended(r, base: bool | None) -> str:
    """Two table cells: how a trial (a record's row) ended (``clean``, ``completed``, ``not completed`` or
    its status), and whether the method's trial on that seed finished cleanly (``base``)."""
    if r["status"] != "ok":
        mine = str(r["status"])  # (diverged: counted, not completed)
    else:
        mine = "clean" if r["finished_cleanly"] else "completed" if r["completed"] else "not completed"
    return f"{mine} | {'—' if base is None else 'clean' if base else 'not clean'}"


def grasp_retries(record_path) -> list[tuple[float, float]] | None:
    """A trial's rewinds (``planner.pace_retry``), from its record and ``timeseries.npz``: per rewind, when it
    began (s after the reference's first expected contact, the record's ``contact_span_start``) and how far
    the object then lay across the table from where it started (mm); ``None`` without the record's
    ``retry_times`` or a series."""
    record = read_record(Path(record_path)) if Path(record_path).is_file() else {}
    times = record.get("retry_times")
    series = Path(record_path).parent / "timeseries.npz"
    if times is None or not series.is_file() or record.get("contact_span_start") is None:
        return None
    z = np.load(series)
    t, xy = z["time"], z["object_qpos"][:, :2]
    out = []
    for at in times:
        k = min(int(np.searchsorted(t, at)), len(t) - 1)
        moved = float(np.linalg.norm(xy[k] - xy[0])) * 1e3
        out.append((float(at) - float(record["contact_span_start"]), moved))
    return out


def retried_grasps(study, chosen: pd.DataFrame) -> str:
    """The levers that try a lost grasp again (``pacing=lift_retry``) trial by trial: when each rewind began
    and where the object lay then, how the trial and the method's on that seed (stand-ins counted in)
    ended; then seed by seed beside the method (:func:`finer_levers`)."""
    found = _paced_levers(study, chosen, "lift_retry")
    if found is None:
        return ""
    ok, _, named, _ = found
    rows, per, figures = [], {}, []
    for r, rewinds, base in _paced_trials(found, grasp_retries):
        when = ", ".join(f"{a:+.1f}" for a, _ in rewinds) or "—"
        where = ", ".join(f"{b:.0f}" for _, b in rewinds) or "—"
        ttf = "—" if pd.isna(r.get("ttf")) else f"{float(r['ttf']):.2f}"
        cells = (f"`{named[r['lever']]}`", r["task"], r["seed"], when, where, ttf, _ended(r, base))
        rows.append("| " + " | ".join(map(str, cells)) + " |")
        run = Path(r["record_path"]).parent
        if rewinds:  # (its timeline: the object lost, and what the grasp tried again did)
            link = study.draw(
                f"timeline_{r['task']}_retry_seed{r['seed']}.png",
                lambda path, run=run: timeline(run, path),
                f"timeline: {r['task']}, the grasp tried again, seed {r['seed']}",
                data=run / "timeseries.npz",
            )
            if link is not None:
                figures.append(f"- {r['task']}, seed {r['seed']} (rewinds at {when} s): {link}")
        got = per.setdefault((r["lever"], r["task"]), [0, 0, 0, 0, 0, 0, 0])
        got[0] += 1
        got[1] += bool(rewinds)
        got[2] += bool(r["finished_cleanly"])
        got[3] += bool(r["completed"]) and bool(rewinds)
        got[4] += base is not None and bool(base)
        got[5] += bool(r["finished_cleanly"]) and base is False  # rescued
        got[6] += not r["finished_cleanly"] and base is True  # lost
    if not rows:
        return ""
    said = [
        f"`{named[lever]}` on the {task}: {n} trials, the grasp tried again on {retried} (completed after it "
        f"on {after}); {finished} finished cleanly, where the method finished {base} on those seeds "
        f"({rescued} rescued, {lost} lost)"
        for (lever, task), (n, retried, finished, after, base, rescued, lost) in per.items()
    ]
    cols = ("lever", "task", "seed", "rewinds began, s of control time after the first expected contact",
            "the object across the table from where it started there, mm", "TTF", "the trial",
            "the method it is on, that seed")  # fmt: skip
    return (
        "\n## A lost grasp tried again\n\n"
        "Each lever trial that tries a lost grasp again (`pacing=lift_retry`: once the object has lain 1.5 s "
        "on the table while the reference lifts it, more than 3.5 cm from the reference's, with at most one "
        "finger on it and not fallen over, counted from the end of the paced wait for it (3 s), the "
        "reference's clock runs back at 3x to 0.5 s before its first expected contact, the wrist moved "
        "across the table to where the object lies, and on again; rewinds take at most 8 s in all), from its "
        "record and time series: when each rewind began, where the object lay then, how the trial ended, and "
        "how the method's trial on that seed ended. "
        + "; ".join(said)
        + ". A trial's TTF counts its first loss: a grasp won again does not undo it. The lever's rule (when "
        "a grasp counts as lost, how long after the paced wait, the wrist moved but not turned) was set on "
        "these trials' seeds, so for it none of them is held out.\n\n| "
        + " | ".join(cols) + " |\n|" + "---|" * 3 + "--:|" * 3 + "---|---|\n"
        + "\n".join(rows)
        + "\n"
        + (
            "\nThe timeline of each trial that tried its grasp again (the reference's time runs back at each "
            "rewind, so the timeline's object error there is against the reference's earlier pose):\n\n"
            + "\n".join(figures)
            + "\n"
            if figures
            else ""
        )
        + finer_levers(
            lever_frame(study),
            with_heldout(study, chosen),
            "pacing=lift_retry",
            "that try a lost grasp again (a `pacing=lift_retry` override",
        )
    )


ERROR_EFFORT = "effort=acquire_error"


def error_effort(study, chosen: pd.DataFrame) -> str:
    """The levers that draw the grasp's samples again where the object is off the reference
    (``effort=acquire_error``) trial by trial: how many of its plans did (the record's ``error_plans``), how
    the trial ended, and how the trial of the same config without the lever ended on that seed (the lever's
    overrides less ``effort=``), with the two trials' CPU-s; then seed by seed beside the method."""
    ok = lever_frame(study)
    ok = ok[ok["lever"].str.contains(ERROR_EFFORT, regex=False)] if len(ok) else ok
    if not len(ok):
        return ""
    every = lever_frame(study)
    rows, per = [], {}
    for r in ok.sort_values(["lever", "task", "seed"]).to_dict("records"):
        record = read_record(Path(r["record_path"]))
        without = " ".join(p for p in r["lever"].split() if not p.startswith("effort="))
        same = (every["task"] == r["task"]) & (every["seed"] == r["seed"])
        twin = every[(every["lever"] == without) & same]
        other = twin.iloc[0] if len(twin) else None
        plans, n = record.get("error_plans"), record.get("num_plans")
        share = "—" if plans is None or not n else f"{plans} of {n}"
        cpu = f"{float(r['cpu_seconds']):.0f}"
        if other is not None:
            cpu += f" / {float(other['cpu_seconds']):.0f}"
        mine, theirs = _outcome(r), "—" if other is None else _outcome(other)
        cells = (f"`{r['lever']}`", r["task"], r["seed"], share, mine, f"`{without}`: {theirs}", cpu)
        rows.append("| " + " | ".join(map(str, cells)) + " |")
        got = per.setdefault((r["lever"], r["task"]), [0, 0, 0, 0, 0])
        got[0] += 1
        got[1] += bool(r["completed"])
        got[2] += bool(r["finished_cleanly"])
        if other is not None:
            got[3] += 1
            got[4] += bool(other["finished_cleanly"])
    said = [
        f"`{lever}` on the {task}: {of(k, n)} completed, {of(c, n)} finished cleanly; without the lever, "
        f"{of(b, m)} finished cleanly on the seeds it has"
        for (lever, task), (n, k, c, m, b) in per.items()
    ]
    cols = ("lever", "task", "seed", "plans given 128 samples for the object's error", "the trial",
            "the same without the lever, that seed", "CPU-s (with / without)")  # fmt: skip
    return (
        "\n## More samples where the object is off the reference\n\n"
        "Each lever trial that draws the grasp's 128 samples again, after the grasp's window, in every plan "
        "made before the reference's last expected contact from a state whose object is more than 3 cm or "
        "0.35 rad from where the reference has it (`effort=acquire_error`), from its record: how many of its "
        "plans did, how it ended, and how the trial of the same config without the lever ended on that seed. "
        + "; ".join(said)
        + ". The thresholds were set from the time series of the stapler's `pacing=lift_retry` trials on "
        "seeds 0-19 (its failures turn the stapler in the grasp while it is carried), so for it "
        "those seeds are not held out.\n\n| "
        + " | ".join(cols) + " |\n|" + "---|" * 3 + "--:|---|---|--:|\n"
        + "\n".join(rows)
        + "\n"
        + finer_levers(
            ok,
            with_heldout(study, chosen),
            ERROR_EFFORT,
            "that draw the grasp's samples where the object is off the reference (an `effort=acquire_error` "
            "override",
        )
    )


def paced_lift(study, chosen: pd.DataFrame) -> str:
    """The levers that pace the grasp (``pacing=hold*``) trial by trial: how long the reference waited before
    the release's window, when it first waited, the object's position error there and where the grasp's
    waits ended, and how the trial and the method's on that seed (stand-ins counted in) ended."""
    found = _paced_levers(study, chosen, "hold")
    if found is None:
        return ""
    ok, _, named, _ = found
    rows, per = [], {}
    for r, (waited, began, at, stopped), base in _paced_trials(found, grasp_waits):
        cells = [
            ("—" if math.isnan(x) else f"{x:{f}}")
            for x, f in ((began, "+.1f"), (at, ".0f"), (stopped, ".0f"))
        ]
        rows.append(
            f"| `{named[r['lever']]}` | {r['task']} | {r['seed']} | {waited:.1f} | {' | '.join(cells)} "
            f"| {_ended(r, base)} |"
        )
        got = per.setdefault((r["lever"], r["task"]), [0, 0, 0, 0, 0, 0])
        got[0] += waited > 0
        got[1] += bool(r["finished_cleanly"])
        got[2] += bool(base)
        got[3] += base is not None
        got[4] += bool(r["finished_cleanly"]) and base is False  # rescued
        got[5] += not r["finished_cleanly"] and base is True  # lost
    if not rows:
        return ""
    said = []
    for (lever, task), (waited, finished, base, known, rescued, lost) in per.items():
        n = int(((ok["lever"] == lever) & (ok["task"] == task)).sum())
        said.append(
            f"`{named[lever]}` on the {task}: {n} trials, the reference waited in the grasp on {waited}; "
            f"{finished} finished cleanly, where the method finished {base} of the {known} it has on those "
            f"seeds ({rescued} rescued, {lost} lost)"
        )
    cols = ("lever", "task", "seed", "waited in the grasp, s", "first waited, s after the first contact",
            "object off the reference there, mm", "where the grasp's waits ended, mm", "the trial",
            "the method it is on, that seed")  # fmt: skip
    return (
        "\n## The lift paced by the grasp\n\n"
        "Each lever trial whose reference waits for the grasp (`pacing=hold*`, or `pacing=lift` in the "
        "method it is on: from the first expected contact, while the object is more than 2 cm (`lift`: "
        "3.5 cm) from where the reference has it, its clock holds, up to 3 s; with `hold_release_turn` until "
        "the release's window, which has a budget of its own), from "
        "its time series: how long the reference's clock held before the release's window, the reference's "
        "time where it first held (after its first expected contact), the object's position error there "
        "and where the grasp's last wait ended, how the trial ended, and how the method's trial on that "
        "seed ended (its stand-ins counted in). "
        + "; ".join(said)
        + ".\n\n"
        + pipe_table(cols, "lllrrrrll", rows)
    )


def paced_release(study, chosen: pd.DataFrame) -> str:
    """The levers that pace the release (``pacing=release*``) trial by trial: how long the reference waited,
    the object's tilt where the wait began and where it ended, at the trial's end, and how the trial and
    the method's on that seed (stand-ins counted in) ended."""
    found = _paced_levers(study, chosen, "release")
    if found is None:
        return ""
    _, _, named, _ = found
    rows, per = [], {}
    for r, (waited, began, stopped, end), base in _paced_trials(found, paced_waits):
        deg = [("—" if math.isnan(x) else f"{x:.0f}") for x in (began, stopped, end)]
        rows.append(
            f"| `{named[r['lever']]}` | {r['task']} | {r['seed']} | {waited:.1f} | {deg[0]} | {deg[1]} "
            f"| {deg[2]} | {_ended(r, base)} |"
        )
        if waited > 0:
            got = per.setdefault(r["lever"], [[], 0, 0, 0])
            got[0].append(began - stopped)
            got[1] += bool(r["finished_cleanly"])
            got[2] += bool(base)
            got[3] += base is not None
    if not rows:
        return ""
    said = [
        f"`{named[lever]}`: it waited on {len(turn)} trials, the object righted by {np.median(turn):+.0f}° "
        f"over the wait (median, negative where it tipped further): {finished} of them finished cleanly, "
        f"where the method it is on finished {base} of the {known} it has"
        for lever, (turn, finished, base, known) in per.items()
    ]
    cols = ("lever", "task", "seed", "waited, s", "tilt where the wait began, °", "where it ended, °",
            "at the end, °", "the trial", "the method it is on, that seed")  # fmt: skip
    return (
        "\n### The release paced by the object\n\n"
        "Each lever trial whose release waits for the object (`pacing=release*`), from its time series: how "
        "long the reference's clock held (s), the object's tilt off the reference's (the spin about the "
        "vertical left out) where the wait began and where it ended (where the hand let go), and at the "
        "trial's end (— where it never waited: the method's config in all that acts, run its wait's budget "
        "longer); beside it how the method's trial on that seed ended (its stand-ins counted in). The wait "
        "is decided on the whole orientation error (`planner.pace_angle`, the spin about the vertical "
        "counted in), so an object spun but upright waits too. "
        + "; ".join(said)
        + ".\n\n"
        + pipe_table(cols, "lllrrrrll", rows)
    )


def set_down_pairs(ok: pd.DataFrame, least: int = 5) -> list[str]:
    """Rows of :func:`set_down`'s paired table: each method of :data:`ORDER` built on :func:`free_base`
    against it, per free-object task with at least ``least`` seeds both completed: the orientation error
    where the contact span ends, its medians, on how many seeds the method's is the lower, and the exact
    two-sided Wilcoxon signed-rank p."""
    from scipy.stats import wilcoxon

    rows = []
    if not len(ok):
        return rows
    base = free_base()
    for method in [m for m in ORDER if m != base and built_from(m) == base]:
        for task in [t for t in plan()[0] if t != "doorknob"]:
            a, b = (cell(ok, task, v) for v in (method, base))
            a, b = (x[x["completed"]].set_index("seed") for x in (a, b))
            common = sorted(set(a.index) & set(b.index))
            if len(common) < least:
                continue
            col = "object_rotation_error_span_final"
            x, y = (np.degrees(pd.to_numeric(d.loc[common, col]).to_numpy()) for d in (a, b))
            p = float(wilcoxon(x, y, method="exact").pvalue) if np.any(x != y) else 1.0
            rows.append(
                f"| `{method}` | {task} | {seeds(common)} | {np.median(x):.0f} / {np.median(y):.0f} "
                f"| {int(np.sum(x < y))} of {len(common)} | {p:.3g} |"
            )
    return rows


ROUGH = "slide_friction"
ROUGH_RUN = (
    "for s in $(seq 0 9); do python launch.py experiment=method task=paper_doorknob task.slide_friction=0.5 "
    f"seed=$s hydra.sweep.dir=studies/method/{ROUGH}; done"
)


def rough_frame(study) -> pd.DataFrame:
    """The doorknob trials that count on a slide with dry friction (:data:`ROUGH`), each with its
    ``friction`` (N, :func:`_friction`)."""
    df = frame(study, ROUGH)
    ok = df[df["counted"] & df["task"].eq("doorknob")] if len(df) else df
    return ok.assign(friction=[_friction(r) for r in ok.to_dict("records")])


def _frictions(g: pd.DataFrame) -> str:
    """The slide frictions of trials ``g`` (:func:`rough_frame`'s), as text: ``0.5``, or ``0.5, 1``."""
    return ", ".join(f"{f:g}" for f in sorted(set(g["friction"])))


def rough_slide(ok: pd.DataFrame, chosen: pd.DataFrame, study=None) -> str:
    """The method on the doorknob with dry friction on its slide (``ok``: :func:`rough_frame`;
    ``task.slide_friction``, not the authors' model), per seed beside its trials on the authors'
    frictionless slide (``chosen``: the sweep's) on the same seeds, with the difference in finishing
    cleanly and Barnard's test; the figure of the knob after the hand lets go where ``study`` is given."""
    head = (
        "The doorknob's trials do not settle because nothing stops the authors' knob once the hand is off it "
        "(*Where the method falls short*). To tell that apart from the method, the method's doorknob trials "
        f"are run again on a slide with dry friction (`task.slide_friction`, MuJoCo's `frictionloss`, in "
        f"the plant and the planner's model alike; not the authors' model), kept apart in `{ROUGH}/` "
        f"(`{ROUGH_RUN}`; the paper's method beside it with `variant={BASELINE}`). These trials do not count "
        "for the target, which is on the authors' model.\n\n"
    )
    if not len(ok):
        return head + "No such trial is kept yet.\n"
    on = rough_method(ok)
    base = cell(counted(chosen), "doorknob", on).set_index("seed")
    ended = lambda r: "clean" if r["finished_cleanly"] else "done" if r["completed"] else "failed"  # noqa: E731
    rows = []
    g = cell(ok, "doorknob", on)
    for r in g.to_dict("records"):
        b = base.loc[r["seed"]] if r["seed"] in base.index else None
        theirs = ("", "") if b is None else (ended(b), f"{1e3 * b['_final']:.0f}")
        rows.append(
            f"| {r['seed']} | {r['friction']:g} | {ended(r)} | {1e3 * r['_final']:.0f} "
            f"| {theirs[0]} | {theirs[1]} |"
        )
    c = base.loc[base.index.intersection(g["seed"])]
    lines = _against(g, c, "on the slide with friction", "on the authors' slide")
    cpu = g["cpu_seconds"].dropna()
    if len(cpu):
        lines.append(f"- median CPU-s a trial: {cpu.median():.0f} (on the authors' slide "
                     f"{c['cpu_seconds'].dropna().median():.0f})")  # fmt: skip
    paper = cell(ok, "doorknob", BASELINE)
    if len(paper):  # the paper's method on the same slide: does settling need the method's release?
        theirs = cell(counted(chosen), "doorknob", BASELINE).set_index("seed")
        lines += [
            f"- the paper's method (`{BASELINE}`) on the slide with friction, " + line[2:]
            for line in _against(
                paper, theirs.loc[theirs.index.intersection(paper["seed"])], "there", "on the authors' slide"
            )  # fmt: skip
        ]
        lines += [
            f"- on the slide with friction, `{on}` against `{BASELINE}`, " + line[2:]
            for line in _against(g[g["seed"].isin(paper["seed"])], paper, f"`{on}`", f"`{BASELINE}`")
        ]
    cols = ("seed", "slide friction (N)", f"`{on}`: ended", "final error (mm)",
            "on the authors' slide: ended", "final error (mm)")  # fmt: skip
    link = None
    if study is not None:
        paths = [Path(p).parent / "timeseries.npz" for p in g["record_path"]]
        title = f"doorknob, slide friction {_frictions(g)} N"
        link = study.draw(
            "after_span_doorknob_slide_friction.png",
            lambda path: after_span_figure(path, title, g, "articulation"),
            "the doorknob on a slide with friction: the object error after the hand lets go",
            data=next((p for p in paths if not p.is_file()), None),
        )
    return (
        head
        + pipe_table(cols, "rrlrlr", rows)
        + "\n*ended*: clean = finished cleanly, done = completed but not settled, failed = not completed.\n\n"
        + ";\n".join(lines)
        + ".\n"
        + (f"\n{link}\n" if link else "")
    )


SCREEN = "release_screen"
SCREEN_RUN = "bash studies/method/run_release_screen.sh"


def _screen_lever(record_path) -> str:
    """A release screen trial's lever (:func:`lever_of` without the screen's ``job.start_time``): ``""``
    for the method itself."""
    return " ".join(p for p in lever_of(record_path).split() if not p.startswith("job.start_time="))


def _still_weight(lever: str) -> float | None:
    """The rest weight (s^2) of a screened ``release=still`` lever (``cost.rest_weight`` beside it, else
    its own 100); ``None`` for any other lever."""
    parts = lever.split()
    weights = [p.split("=", 1)[1] for p in parts if p.startswith("cost.rest_weight=")]
    if "release=still" not in parts or len(parts) != 1 + len(weights) or len(weights) > 1:
        return None
    return float(weights[0]) if weights else 100.0


def _screen_name(lever: str, method: str = METHOD) -> str:
    """How the screen's table names ``lever``: the method its trials without a lever ran (``method``),
    ``release=still`` at its rest weight, or the lever's overrides."""
    weight = _still_weight(lever)
    if not lever:
        return f"`{method}`"
    return f"`release=still`, {weight:g} s^2" if weight is not None else f"`{lever}`"


def _screen_order(lever: str) -> tuple:
    """The screen table's order: the method, ``release=still`` by rest weight, then the other levers."""
    weight = _still_weight(lever)
    if not lever:
        return (0, 0.0, "")
    return (1, weight, "") if weight is not None else (2, 0.0, lever)


EARLY = 0.25  # s: a plant contact ending this long before the reference's last one (more than a plan period)


def _let_go_early(g: pd.DataFrame) -> str:
    """Of the screen trials ``g`` whose records have ``last_contact_time``, how many were off the knob
    more than :data:`EARLY` before the reference's last expected contact; ``—`` where none has it."""
    if "last_contact_time" not in g:
        return "—"
    last = pd.to_numeric(g["last_contact_time"], errors="coerce")
    have = last.notna()
    if not have.any():
        return "—"
    early = last[have] < pd.to_numeric(g.loc[have, "contact_span_end"], errors="coerce") - EARLY
    return of(int(early.sum()), int(have.sum()))


def release_screen(study) -> str:
    """The doorknob's release screened (:data:`SCREEN`: trials started 4 s before the reference lets go,
    ``run_release_screen.sh``): per lever (``release=still`` at each rest weight, ``cost.rest_weight``;
    the other release levers screened; none: the method), the trials that count, completed, finished
    cleanly and the final error, and each lever against the method on the same seeds. The full trials of
    ``release=still`` are in the levers' table."""
    head = (
        "The method's doorknob trials end unsettled because its release sets the frictionless knob moving "
        "(*Where the method falls short*). `release=still` prices the object's speed after the reference "
        "lets go (`cost.rest_weight`, s^2 against the squared error; not the paper's), so the plans prefer "
        "a release that leaves it still. Screened from 47.5 s, the plant at the reference's state 4 s before "
        f"the reference lets go, to the trial's end (`job.start_time`; `{SCREEN_RUN}`, kept in `{SCREEN}/`; "
        '`LEVERS="..."` screens others): the method, `release=still` at four weights and the other release '
        "levers screened, on the same seeds. The full trials of `release=still` are in the levers' table "
        "(*Levers on the method, full trials*).\n\n"
    )
    df = frame(study, SCREEN)
    ok = df[df["counted"] & df["task"].eq("doorknob")] if len(df) else df
    if not len(ok):
        return head + "No screen trial is kept yet.\n"
    ok = ok.assign(
        lever=[_screen_lever(p) for p in ok["record_path"]],
        processor=[online_cpu(json.loads(Path(p).read_text())) for p in ok["record_path"]],
    )
    base = ok[ok["lever"].eq("")].set_index("seed")
    method = built_on(base)  # the method of their time, the paper doorknob's default when they ran
    rows, lines, texts = [], [], []
    for lever in sorted(set(ok["lever"]), key=_screen_order):
        g = ok[ok["lever"].eq(lever)]
        name = _screen_name(lever, method)
        final = 1e3 * g["_final"]
        rows.append(
            f"| {name} | {seeds(g['seed'])} | {of(int(g['completed'].sum()), len(g))} "
            f"| {of(int(g['finished_cleanly'].sum()), len(g))} | {_let_go_early(g)} | {median(final)} "
            f"| {median(g['cpu_seconds'])} | {', '.join(sorted(set(g['processor'])))} |"
        )
        if lever and len(base):
            same = base.loc[base.index.intersection(g["seed"])]
            lines += [
                f"- {name}, " + line[2:]
                for line in _against(g[g["seed"].isin(same.index)], same, "with it", f"`{method}`")
                if "finished cleanly" in line
            ]
        if lever and (_still_weight(lever) is None or lever == "release=still"):
            texts.append(f"- {_lever_text(lever)}")
    cols = (
        "method", "seeds", "completed", "finished cleanly", "off the knob before the reference lets go",
        "median final error (mm)", "median CPU-s", "processor",
    )  # fmt: skip
    out = head + pipe_table(cols, "llrrrrrl", rows) + "\n" + (";\n".join(lines) + ".\n" if lines else "")
    out += (
        "\n*Off the knob before the reference lets go*: trials whose last logged hand-knob contact "
        f"(`last_contact_time`) came more than {EARLY:g} s before the reference's last expected contact "
        "(`contact_span_end`): the knob had left the hand before any release lever acted, so a lever cannot "
        "change how those trials end (— where the records predate the field). *Processor*: where the "
        "trials ran; a lever and the method on different processors are different draws of the same "
        "seeds, so only their counts compare.\n"
    )
    shares = {
        lever: (g["finished_cleanly"].mean(), int(g["finished_cleanly"].sum()), len(g))
        for lever, g in ok.groupby("lever")
        if lever
    }
    if shares:
        best = max(shares, key=lambda lever: (shares[lever][0], shares[lever][2]))
        share, k, n = shares[best]
        out += (
            f"\nThe screen's most clean finishes, as a share of its seeds: {_screen_name(best, method)}, "
            f"{of(k, n)}" + ("" if share >= 0.8 else "; none reaches the target's share, 8 of 10") + ".\n"
        )
    return out + ("\nThe levers screened:\n\n" + "\n".join(texts) + "\n" if texts else "")


def _against(a: pd.DataFrame, b: pd.DataFrame, name_a: str, name_b: str) -> list[str]:
    """Bullets, completed and finished cleanly: ``a``'s count (``name_a``), and where ``b`` has trials its
    count on the same seeds (``name_b``), the difference with Newcombe's interval and Barnard's p."""
    lines = []
    for what, col in (("completed", "completed"), ("finished cleanly", "finished_cleanly")):
        k, m = int(a[col].sum()), int(b[col].sum())
        line = f"- {what}: {of(k, len(a))} {name_a}"
        if len(b):
            d, lo, hi = newcombe(k, len(a), m, len(b))
            p, _ = completion_test(k, len(a), m, len(b))
            line += (
                f", {of(m, len(b))} {name_b} on the same seeds: {100 * d:+.0f} points "
                f"[{100 * lo:+.0f}, {100 * hi:+.0f}], Barnard p = {Fmt.p(p)}"
            )
        lines.append(line)
    return lines


def rough_method(ok: pd.DataFrame) -> str:
    """The project's method the doorknob trials on a slide with friction (``ok``: :func:`rough_frame`) ran
    (:func:`built_on` of those not of the paper's method)."""
    return built_on(ok[ok["variant"] != BASELINE] if len(ok) else ok)


def rough_summary(ok: pd.DataFrame) -> str:
    """One sentence for the findings: how the project's method's doorknob trials on a slide with friction
    (``ok``: :func:`rough_frame`) ended; ``""`` without any."""
    on = rough_method(ok)
    g = cell(ok, "doorknob", on) if len(ok) else ok
    if not len(g):
        return ""
    friction = _frictions(g)
    k, c, n = int(g["completed"].sum()), int(g["finished_cleanly"].sum()), len(g)
    return (
        f"\nThe doorknob's shortfall is the authors' frictionless slide: on a slide with {friction} N of dry "
        f"friction (not the authors' model; *The doorknob on a slide with friction*) `{on}` completes "
        f"{of(k, n)} and finishes {of(c, n)} cleanly on seeds {seeds(g['seed'])}.\n"
        if c == n
        else f"\nOn a slide with {friction} N of dry friction (not the authors' model; *The doorknob on a "
        f"slide with friction*) `{on}` completes the doorknob {of(k, n)} and finishes {of(c, n)} "
        f"cleanly on seeds {seeds(g['seed'])}.\n"
    )


def _friction(r: dict) -> float:
    """The slide friction (N) a record's config gave its task (0: the authors' slide): its
    ``task.slide_friction`` column where the records differ in it, else read from its record."""
    value = pd.to_numeric(pd.Series([r.get("task.slide_friction")]), errors="coerce").iloc[0]
    if pd.isna(value) and r.get("record_path"):
        task = json.loads(Path(r["record_path"]).read_text()).get("config", {}).get("task", {})
        value = task.get("slide_friction", 0.0)
    return 0.0 if pd.isna(value) else float(value)


def kept(study, folder: str) -> list[dict]:
    """The records kept beside the sweep's, one a run: ``<study>/<folder>/<run>/trial.json``, by run name."""
    return [json.loads(p.read_text()) for p in sorted((study.dir / folder).glob("*/trial.json"))]


def online(study) -> str:
    """``job=online`` runs (``online/<run>/trial.json``, made by ``run_online.sh``): one row a run, and per
    task and method the smallest slowdown at which every run completed on 2 threads."""
    records = kept(study, "online")
    head = (
        "`job=online` runs the plant in wall-clock time and the planner in a second thread on 2 planning "
        "threads here (`planner.nthread=2`), at each paper task's default preset (the latency is the real "
        "one, not the preset's); `job.slowdown` s stands in for real time on 2s threads of this CPU (2 "
        "and 3: 4 and 6 threads). Per task and method, slowdown 1, then 2, then 3, until both runs (seeds 0 "
        "and 1) complete (`bash studies/method/run_online.sh`, other jobs stopped while it runs; "
        '`SLOWDOWNS="6 8"` goes on further); `SLOWDOWNS=1 '
        'SEEDS="2 3 4 5 6 7 8 9"` adds seeds at one slowdown: how often the method completes there, '
        "counted in the second table. *Paced N ms*: the planner "
        "started a plan at most every N ms of control time (`job.min_interval`, not the paper's: the rate of "
        "the simulated loop at the calibrated latency) instead of continuously. *Held to N ms*: each plan "
        "acted no sooner than N ms of control time after its state (`job.apply_after`, not the paper's: a "
        "plan ready sooner waits, so plans act at the simulated trial's fixed latency where the machine "
        "plans within it). *Latency by samples*: each plan predicted its state (`compensation=predict`) as "
        "far ahead as the last plans that drew the samples it was expected to draw took "
        "(`job.latency_by_samples`, not the paper's), not the last plans whatever they drew (`EXTRA="
        '"job.latency_by_samples=true" SUFFIX=_bysamples bash studies/method/run_online.sh`). '
        "A run's wall-clock time is its processor's: runs on another processor than the "
        "one most runs ran on are named with theirs (*on ...*) and counted apart.\n\n"
    )
    if not records:
        return head + "No online run is kept yet.\n"
    rank = {t: i for i, t in enumerate(TASK_ORDER)} | {m: i for i, m in enumerate(ORDER)}

    def order(r: dict) -> tuple:
        task = r.get("task", "").removeprefix("paper_")
        method = rank.get(method_name(r), 99), r.get("min_interval") or 0.0, r.get("apply_after") or 0.0
        return rank.get(task, 99), method, r.get("slowdown") or 0, r.get("seed") or 0

    records.sort(key=order)
    usual = usual_cpu(records)
    rows = [_online_row(r, usual) for r in records]
    cols = (
        "task", "method", "seed", "slowdown", "real-time factor", "replan interval, median (ms)",
        "plan latency, median (ms)", "grasp's plans, median (ms wall)", "later plans, median (ms wall)",
        "completed", "finished cleanly", "TTF", "trials at once", "model switched (s)",
    )  # fmt: skip
    name = lambda r: f"{r.get('task', '').removeprefix('paper_')} {online_method(r, usual)}"  # noqa: E731
    table, prose, _ = by_slowdown(records, name)
    return (
        head
        + pipe_table(cols, "lllrrrrrrllrrr", rows)
        + "\n*Trials at once*: the most trials running on the machine while the run ran, itself included "
        "(the record's `concurrent_trials`; — where the record predates it): a run beside others planned on "
        "a busier machine, so its plans took longer than the same run's alone. *Grasp's plans*: the median "
        "wall time of the plans planned from 1 s before to 2 s after the reference's first expected contact, "
        "where `effort=acquire` draws its 128 samples; *later plans*: of those planned after (the record's "
        "`plan_seconds_grasp_median`, `plan_seconds_after_grasp_median`; — where the record predates "
        "them). *Model switched*: when the "
        "planning model switched (`planner.switch_timestep`; the record's `switch_time`), in seconds after "
        "the first expected contact; — for a method without a switch.\n"
        + "\nHow many threads real time needs:\n\n"
        + markdown(pd.DataFrame(table))
        + "\n- "
        + ";\n- ".join(prose)
        + ".\n"
        + grasp_plans(records, usual)
        + online_against(records)
    )


def online_against(records: list[dict]) -> str:
    """Per processor and task, each method's online runs in real time (slowdown 1, replanning
    continuously, alone on the machine) against the default method's on the same processor and seeds:
    completed and finished cleanly, with Barnard's test; empty where no such pair was run."""
    alone = [r for r in records if real_time(r) and int(r.get("concurrent_trials") or 1) == 1]
    groups: dict[tuple, dict[int, dict]] = {}
    for r in alone:
        key = (online_cpu(r), r.get("task", "").removeprefix("paper_"), method_name(r) or METHOD)
        groups.setdefault(key, {})[int(r.get("seed", -1))] = r  # a re-run of a seed: the last kept
    lines = []
    for (cpu, task, method), runs in sorted(groups.items()):
        base = groups.get((cpu, task, METHOD))
        same = sorted(set(runs) & set(base or {}))
        if method == METHOD or len(same) < 5:
            continue
        mine, theirs = tally([runs[s] for s in same]), tally([base[s] for s in same])
        p_done = completion_test(mine[0], len(same), theirs[0], len(same))[0]
        p_clean = completion_test(mine[1], len(same), theirs[1], len(same))[0]
        lines.append(
            f"- {task}, on {cpu}, seeds {seeds(same)}: `{method}` completed {of(mine[0], len(same))} and "
            f"finished {mine[1]} cleanly, `{METHOD}` {theirs[0]} and {theirs[1]} (Barnard p = "
            f"{Fmt.p(p_done)} completed, {Fmt.p(p_clean)} clean)"
        )
    if not lines:
        return ""
    return (
        "\nIn real time on 2 threads (slowdown 1, alone on the machine), each method against "
        f"`{METHOD}` on the same processor and seeds:\n\n" + ";\n".join(lines) + ".\n"
    )


def grasp_plans(records: list[dict], usual: str | None = None) -> str:
    """Per task and method, over its runs alone on the machine that record them: the median of the runs'
    grasp-window plan wall times (``plan_seconds_grasp_median``) and of their later plans', per slowdown,
    beside the runs completed; empty where no run records them."""
    rows = {}
    for r in records:
        grasp, later = r.get("plan_seconds_grasp_median"), r.get("plan_seconds_after_grasp_median")
        if grasp is None or later is None or int(r.get("concurrent_trials") or 1) > 1:
            continue
        key = (r.get("task", "").removeprefix("paper_"), online_method(r, usual), r.get("slowdown"))
        rows.setdefault(key, []).append((grasp, later, bool(r.get("completed"))))
    if not rows:
        return ""
    lines = [
        f"| {task} | `{method}` | {Fmt.num(slowdown, 0)} | {len(v)} | "
        f"{1e3 * np.median([g for g, _, _ in v]):.0f} | {1e3 * np.median([x for _, x, _ in v]):.0f} | "
        f"{of(sum(c for _, _, c in v), len(v))} |"
        for (task, method, slowdown), v in sorted(rows.items(), key=lambda kv: (str(kv[0]), kv[0][2] or 0))
    ]
    return (
        "\nWhat the grasp's plans cost online, per task, method and slowdown over the runs that record it, "
        "alone on the machine: the median over runs of each run's median plan wall time, of the plans "
        "planned from a state 1 s before to 2 s after the first expected contact (where `effort=acquire` "
        "draws its 128 samples), and after that. The window is the state's time: with "
        "`compensation=predict` a plan starts from the state predicted as far ahead as the last plans "
        "took, so a slow plan late in the window plans past the acquire window, with the later plans' "
        "samples, and the window's median mixes both kinds (lower, the slower the plans). A plan's "
        "control-time latency is its wall time / the slowdown; the simulated trials charge every plan the "
        "calibrated 170 ms.\n\n"
        "| task | method | slowdown | runs | grasp's plans, median (ms wall) | later plans (ms wall) | "
        "completed |\n|---|---|--:|--:|--:|--:|--:|\n" + "\n".join(lines) + "\n"
    )


# --------------------------------------------------------------------------------------------- shortfall


def _span_final(df: pd.DataFrame) -> pd.Series:
    """Each trial's object error at the end of its contact span (the task's kind, as ``_final``)."""
    kinds = df.attrs.get("error_kinds", {})
    column = lambda task: f"{release.ERRORS[kinds.get(task, 'position')]}_span_final"  # noqa: E731
    values = [r.get(column(r["task"]), math.nan) for r in df.to_dict("records")]
    return pd.to_numeric(pd.Series(values, index=df.index, dtype=object), errors="coerce")


def _seeds(values) -> str:
    return ("seeds " if len(values) > 1 else "seed ") + seeds(values)


def after_span_figure(path: Path, task: str, trials: pd.DataFrame, kind: str) -> None:
    """The object error over time, from 5 s before the end of the contact span (where the hand lets go)
    to the trial's end, one line per trial (``trials``: rows with ``record_path``, ``seed``,
    ``contact_span_end``, ``finished_cleanly``; the method they ran, :func:`built_on`): grey, finished
    cleanly; coloured, not."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    key = release.ERRORS[kind]
    fig = Figure(figsize=(7.0, 3.2), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    colors = iter(("#d62728", "#1f77b4", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22"))
    for r in trials.sort_values("seed").itertuples():
        series = np.load(Path(r.record_path).parent / "timeseries.npz")
        t = series["time"] - r.contact_span_end
        keep = t >= -5.0
        clean = bool(r.finished_cleanly)
        ax.plot(t[keep], 1e3 * series[key][keep], color="0.6" if clean else next(colors, "0.2"),
                lw=1.0 if clean else 1.6, label=f"seed {r.seed}" + (" (clean)" if clean else ""))  # fmt: skip
    ax.axvline(0.0, color="k", lw=0.8, ls="--")
    ax.set_xlabel("time from the end of the contact span (s)")
    unit = "mm" if kind == "position" else "x 1e-3 (m on the slide)"
    ax.set_ylabel(f"object error ({unit})")
    ax.set_title(f"{task}, {built_on(trials)}: the object after the hand lets go", fontsize=10)
    ax.legend(fontsize=7, ncol=2, frameon=False)
    fig.savefig(path, dpi=110)


def leaving_speed(path: Path, settle: float) -> tuple[float, float] | None:
    """An articulated object's speed after the hand lets go, and the most it could have kept: from the
    trial's time series (``path``), the mean speed of its first joint (m/s on a slide) from 0.2 s to 1.2 s
    after the last sample at which a hand link touches it, and ``settle`` (the task's tolerance on the
    final configuration) over the time from that sample to the trial's end: any faster, and an object
    nothing stops (a slide with no friction or damping) is outside the tolerance by the end however
    close it was when the hand let go. ``None`` without a time series, a contact, or a second after it."""
    if not path.is_file():
        return None
    series = np.load(path)
    t, q, touching = series["time"], series["object_qpos"][:, 0], series["contacts"].any(axis=1)
    if not touching.any():
        return None
    last = t[np.flatnonzero(touching)[-1]]
    if t[-1] < last + 1.2:
        return None
    speed = abs(np.interp(last + 1.2, t, q) - np.interp(last + 0.2, t, q))  # over 1 s
    return float(speed), settle / float(t[-1] - last)


def _task_class(task: str):
    """The paper task's class (``contactmpc.tasks``), by the task's name without ``paper_``."""
    import contactmpc.tasks as tasks

    return next((c for c in vars(tasks).values() if getattr(c, "name", None) == f"paper_{task}"), None)


#: A free object "toppled" after the hand let go: its rotation error under TOPPLE_FROM degrees where the
#: contact span ends and at least TOPPLE_TO degrees at the trial's end.
TOPPLE_FROM, TOPPLE_TO = 45.0, 60.0


def endings(done: pd.DataFrame, task: str) -> dict[str, list[int]]:
    """The seeds of a free object's completed trials that did not settle, by how they ended (from the
    records' errors where the contact span ends and at the end, against the task's ``SETTLE_*``
    tolerances): ``toppled`` (see :data:`TOPPLE_FROM`), ``off`` (not toppled, and already outside the
    tolerances where the span ends: dropped, or set down elsewhere), ``outside`` (inside them where the
    span ends, outside at the end, not toppled)."""
    cls = _task_class(task)
    if cls is None or not len(done):
        return {}
    out: dict[str, list[int]] = {"toppled": [], "off": [], "outside": []}
    for r in done.to_dict("records"):
        rot0, rot1 = (math.degrees(r.get(k, math.nan)) for k in ("object_rotation_error_span_final",
                                                                  "final_object_rotation_error"))  # fmt: skip
        pos0 = r.get("object_position_error_span_final", math.nan)
        if rot0 < TOPPLE_FROM and rot1 >= TOPPLE_TO:
            out["toppled"].append(int(r["seed"]))
        elif pos0 > cls.SETTLE_POSITION or rot0 > math.degrees(cls.SETTLE_ROTATION):
            out["off"].append(int(r["seed"]))
        elif not (math.isnan(pos0) or math.isnan(rot0)):
            out["outside"].append(int(r["seed"]))
    return {k: v for k, v in out.items() if v}


def _endings(done: pd.DataFrame, task: str) -> str:
    """:func:`endings` as a clause."""
    found = endings(done, task)
    if not found:
        return ""
    cls = _task_class(task)
    words = {
        "toppled": f"toppled after the hand let go (under {TOPPLE_FROM:.0f}° off the reference's "
        f"orientation where the span ends, {TOPPLE_TO:.0f}° or more at the end)",
        "off": "already outside the final tolerances where the span ends "
        f"({1e3 * cls.SETTLE_POSITION:.0f} mm, {math.degrees(cls.SETTLE_ROTATION):.0f}°: dropped, or set "
        "down elsewhere)",
        "outside": "inside them where the span ends and outside at the end",
    }
    return "; of those, " + ", ".join(f"{words[k]} on {_seeds(v)}" for k, v in found.items())


#: The speeds :func:`leaving_speed` read, by record folder: kept beside the figures, for the machines
#: without the time series (which are not in git), as the figures drawn from them are.
SPEEDS = "leaving_speed.csv"


def _speeds(done: pd.DataFrame, settle: float, study=None) -> list[tuple[float, float]]:
    """:func:`leaving_speed` of each trial of ``done``: from its time series where they are (and kept in
    :data:`SPEEDS` when the study writes its figures), else from :data:`SPEEDS`."""
    path = None if study is None else study.dir / "figures" / SPEEDS
    kept = pd.read_csv(path, index_col="record") if path is not None and path.is_file() else None
    found, read = [], {}
    for p in done["record_path"]:
        name = Path(p).parent.name
        speed = leaving_speed(Path(p).parent / "timeseries.npz", settle)
        if speed is not None:  # as the kept table holds them, so every machine reads the same
            speed = read[name] = tuple(float(f"{v:.6g}") for v in speed)
        elif kept is not None and name in kept.index:
            speed = (float(kept.loc[name, "speed"]), float(kept.loc[name, "bound"]))
        if speed is not None:
            found.append(speed)
    if read and study is not None and study.drawing:
        rows = {} if kept is None else {n: (r.speed, r.bound) for n, r in kept.iterrows()}
        rows |= read
        table = pd.DataFrame([(n, *v) for n, v in sorted(rows.items())], columns=["record", "speed", "bound"])
        table.to_csv(study.figure(SPEEDS), index=False, float_format="%.6g")
    return found


def _slide_speeds(done: pd.DataFrame, task: str, study=None) -> str:
    """For a task whose object is articulated, the speeds :func:`leaving_speed` reads, as a clause."""
    cls = _task_class(task)
    if cls is None or "record_path" not in done:
        return ""
    found = _speeds(done, cls.SETTLE_ARTICULATION, study)
    if not found:
        return ""
    speeds, bounds = np.array(found).T * 1e3
    fast = int((speeds > bounds).sum())
    return (
        f"; the object left the hand at {median(speeds)} mm/s (median; from 0.2 to 1.2 s after the "
        f"last contact) where it could keep at most {median(bounds, '{:.1f}')} mm/s and end within the "
        f"{1e3 * cls.SETTLE_ARTICULATION:.0f} mm tolerance (the tolerance over the time left), faster on "
        f"{of(fast, len(found))}: nothing stops the slide once the hand is off (no friction or damping), "
        "so settling asks for a release that leaves the object all but still"
    )


#: The doorknob's releases replayed from the method's trials (``release_replay.py`` writes it).
REPLAYS = "release_replay.csv"


def release_replays(table: pd.DataFrame) -> str:
    """What the replayed releases (:data:`REPLAYS`'s rows: ``seed``, ``release``, ``let_go``, ``speed``,
    ``bound``) did, as a paragraph: per release, the knob's speed after the hand let go (medians, ranges)
    and on how many replays it stayed under the bound, over the replays of the trials whose recorded
    release let go after the span's end (where a replay let go sooner, it is not near its trial)."""
    if not len(table):
        return ""
    friction = table["friction"] if "friction" in table else pd.Series(0.0, index=table.index)
    rough, table = table[friction > 0], table[friction == 0]
    rec = table[table["release"] == "recorded"]
    faithful = set(rec.loc[rec["let_go"] >= 0, "seed"])
    t = table[table["seed"].isin(faithful)]
    parts, medians = [], {}
    for name, g in t.groupby("release", sort=False):
        off = g[g["let_go"].notna()]
        v, b = 1e3 * off["speed"], 1e3 * off["bound"]
        held = len(g) - len(off)
        where = f"{of(len(off), len(g))} let go" + (
            f" (the hand still on the knob on {held})" if held else ""
        )
        if len(off):
            under = of(int((v <= b).sum()), len(off))
            medians[name] = (float(np.median(v)), int((v <= b).sum()), len(off))
            where += f", at {median(v)} mm/s (median; {span(v)}), under the bound on {under}"
        parts.append(f"*{name}*: {where}")
    methods = sorted({m for m in map(_run_method, table.get("record", [])) if m})
    whose = f" of {codes(methods)}" if methods else ""
    return (
        f"  Replayed from the state of each trial{whose} {table['before'].iloc[0]:g} s before the span ends,"
        " each release open-loop "
        "(`python studies/method/release_replay.py`; velocities zeroed, so a replay is near its trial, not "
        f"it; the {len(faithful)} trials whose replayed own release let go after the span's end): "
        + "; ".join(parts)
        + "."
        + _slowest(medians)
        + _rough(rough[rough["seed"].isin(faithful)])
    )


def _run_method(run: str) -> str | None:
    """The method of a run folder's name (``effort=acquire,experiment=method,...,variant=grasp_release_ahead``
    is ``grasp_release_ahead_acquire``), ``None`` for a name without a variant."""
    labels = dict(part.split("=", 1) for part in str(run).split(",") if "=" in part)
    return method_name(labels) if labels.get("variant") else None


def _rough(table: pd.DataFrame) -> str:
    """The trial's own release replayed on a slide with dry friction (the replays' ``friction`` N), as a
    sentence: the knob's speed once let go and how far from the reference's final position it ends."""
    if not len(table):
        return ""
    off = table[table["let_go"].notna()]
    v, b, d = 1e3 * off["speed"], 1e3 * off["bound"], 1e3 * off["off"]
    return (
        f" The trial's own release replayed on a slide with {table['friction'].iloc[0]:g} N of dry friction "
        "(`task.slide_friction`, not the authors' model) lets go on "
        f"{of(len(off), len(table))}, the knob at {median(v)} mm/s (median; {span(v)}), under the bound on "
        f"{of(int((v <= b).sum()), len(off))}, ending {median(d)} mm from the reference's final position "
        f"(median; {span(d)}; the tolerance is {1e3 * _task_class('doorknob').SETTLE_ARTICULATION:.0f} mm)."
    )


def _slowest(medians: dict[str, tuple[float, int, int]]) -> str:
    """The release (other than the trial's own and the grip held) that left the knob slowest, against
    the trial's own, as a sentence."""
    tried = {k: v for k, v in medians.items() if k not in ("recorded", "grip held")}
    if "recorded" not in medians or not tried:
        return ""
    name, (v, under, n) = min(tried.items(), key=lambda kv: kv[1][0])
    return (
        f" The slowest, *{name}*, leaves the knob {medians['recorded'][0] / v:.0f} times slower than the "
        f"trial's own release and under the bound on {of(under, n)}"
        + (": none of the open-loop releases tried would settle the knob." if 2 * under < n else ".")
    )


def from_figures(study, name: str, section, missing: str = "") -> str:
    """``section`` of the rows of the study's ``figures/<name>`` (a CSV a script of this folder writes), or
    ``missing`` where there is none (or no study)."""
    path = None if study is None else study.dir / "figures" / name
    return section(pd.read_csv(path)) if path is not None and path.is_file() else missing


LIFTS = "lift_replay.csv"


def lift_replays(rows: pd.DataFrame) -> str:
    """What the replayed grasps (:data:`LIFTS`'s rows: ``task``, ``seed``, ``model``, ``step``, ``lifted``,
    ``lifted_in_trial``, ``before``, ``after``; ``studies/method/lift_replay.py``) say, per task: of the
    replays the plant lifts, how many each planning model lifts too, and on how many trials it agrees with
    the plant; then, over the tasks, how many of the plant's lifts the method's (coarsest) model loses."""
    if not len(rows):
        return ""
    before, after = rows["before"].iloc[0], rows["after"].iloc[0]
    out = [
        f"Each of `{free_base()}`'s trials on the free objects replayed open-loop "
        f"(`python studies/method/lift_replay.py`): from its recorded configuration {before:g} s before its "
        "contact span starts (the hand not yet on the object; velocities zeroed, so a replay is near its "
        f"trial, not it), its recorded hand targets to {after:g} s after (past the reference's lift), in the "
        "plant and in the planning model stepped at each step below; lifted: the object ends at least 5 cm "
        "above where it started.\n"
    ]
    step = rows.loc[rows["model"] != "plant", "step"].max()  # the method's planning model
    lost, lifts = 0, 0
    for task in ordered(rows["task"].unique(), [f"paper_{t}" for t in TASK_ORDER]):
        mine = rows[rows["task"] == task]
        plant = mine[mine["model"] == "plant"].set_index("seed")["lifted"].astype(bool)
        n_trial = int(mine.drop_duplicates("seed")["lifted_in_trial"].sum())
        name = task.removeprefix("paper_")
        lines = []
        for model, g in mine[mine["model"] != "plant"].groupby("model", sort=False):
            lifted = g.set_index("seed")["lifted"].astype(bool).reindex(plant.index, fill_value=False)
            lines.append(
                f"- {model}: lifts it on {of(int((lifted & plant).sum()), int(plant.sum()))} of the replays "
                f"the plant lifts it on (and on {of(int((lifted & ~plant).sum()), int((~plant).sum()))} of "
                f"the others); agrees with the plant on {of(int((lifted == plant).sum()), len(plant))}"
            )
            if g["step"].iloc[0] == step:
                lost += int((plant & ~lifted).sum())
                lifts += int(plant.sum())
        out.append(
            f"\n**{name}**: the plant's replays lift the {name} on {of(int(plant.sum()), len(plant))} (seeds "
            f"{seeds(sorted(plant.index[plant]))}; the trials themselves lifted it on "
            f"{of(n_trial, len(plant))}: an open-loop replay is not its closed-loop trial).\n\n"
            + ";\n".join(lines)
            + f".\n\n![{name}: the grasp replayed](figures/lift_replay_{name}.png)\n"
        )
    if lifts and 2 * lost > lifts:
        out.append(
            f"\nSo the planning model the method rolls out ({1e3 * step:g} ms) loses the object on "
            f"{of(lost, lifts)} of the grasps that lift it in the plant: its rollouts cannot tell a grasp "
            "that holds from one that does not, so the plans are not chosen for the lift (`rollout=fine` "
            "plans at 5 ms).\n"
        )
    return "".join(out)


def switched(trials: pd.DataFrame) -> str:
    """When the trials' planning model switched (the records' ``switch_time``, after the first expected
    contact: ``contact_span_start``; and back, ``switch_back_time``, after the last: ``contact_span_end``),
    per seed; those that never did; "" where no record says (records before the field, or a member without
    a switch)."""
    if "switch_time" not in trials or not trials["switch_time"].notna().any():
        return ""
    told = trials[trials["switch_time"].notna()].sort_values("seed")
    back = "switch_back_time" in told and told["switch_back_time"].notna().any()

    def when(r) -> str:
        text = f"{int(r.seed)}: {_switch(r._asdict())} s"
        if back and pd.notna(r.switch_back_time):  # (switch_back_after) after the last expected contact
            text += f", back +{r.switch_back_time - r.contact_span_end:.2f} s after the last"
        return text

    after = ", ".join(when(r) for r in told.itertuples())
    never = trials[trials["switch_time"].isna() & trials["seed"].notna()]
    return f"; it switched (seed: after the first expected contact) {after}" + (
        f"; no switch time on seeds {seeds(sorted(never['seed']))} (it never switched, or the trial ran "
        "before the records said)"
        if len(never)
        else ""
    )


def coarser(method: str) -> str | None:
    """The method of :data:`ORDER` that ``method`` is with the scene's planning model (``rollout=paper``)
    where ``method`` selects another (``grasp_held_eased`` of ``grasp_held_eased_refined`` and of
    ``grasp_held_eased+rollout=fine``); ``None`` where it does not, or that method is not in it."""
    base, groups = _groups(method)
    if groups["rollout"] == GROUPS["rollout"]:
        return None
    coarse = (base, {**groups, "rollout": GROUPS["rollout"]})
    return next((m for m in ORDER if m != method and _groups(m) == coarse), None)


def finer_models(df: pd.DataFrame) -> str:
    """Per task, each method of :data:`ORDER` with another planning model than the scene's (a ``rollout``
    member) against the same method with the scene's (:func:`coarser`) on the same seeds: completed and
    finished cleanly (the tests are in *Each step, on the same seeds*), and when each switched its model."""
    ok = counted(df)
    finer = {m: base for m in ORDER if (base := coarser(m)) is not None}
    lines = []
    for task in ordered(ok["task"].unique(), TASK_ORDER) if len(ok) else []:
        parts = []
        for m, coarse in finer.items():
            base = cell(ok, task, coarse).set_index("seed")
            mine = cell(ok, task, m)
            mine = mine[mine["seed"].isin(base.index)]
            if not len(mine):
                continue
            theirs = base.loc[mine["seed"]]
            n = len(mine)
            rollout = method_labels({"variant": m})["rollout"]
            name = (
                f"`{m[len(coarse) + 1 :]}`" if m.startswith(coarse + "+") else f"`{m}` (`rollout={rollout}`)"
            )
            parts.append(
                f"{name} completes {of(int(mine['completed'].sum()), n)} and "
                f"finishes {int(mine['finished_cleanly'].sum())} cleanly, against "
                f"{int(theirs['completed'].sum())} and {int(theirs['finished_cleanly'].sum())} (seeds "
                f"{seeds(sorted(mine['seed']))}){switched(mine)}"
            )
        if parts:
            lines.append(f"- **{task}**: " + "; ".join(parts))
    if not lines:
        return ""
    return (
        "\nThe full trials with a finer planning model, each against the same method on the scene's planning "
        "model (`rollout=paper`) on the same seeds:\n\n" + ";\n".join(lines) + ".\n"
    )


#: One seed's outcome in :func:`finer_levers`: finished cleanly, completed only, not completed, not run.
OUTCOME_MARKS = {"clean": "✓", "completed": "c", "failed": "✗", "none": "·"}


def finer_levers(
    levers: pd.DataFrame,
    every: pd.DataFrame,
    match: str = "rollout=",
    which: str = "with another planning model (a `rollout=` override",
) -> str:
    """The lever trials with another planning model (a ``rollout=`` override, or whose lever names
    ``match``, described as ``which``; ``levers``: :func:`lever_frame`) beside the method each ran on (its
    trials in ``every``, :func:`with_heldout`), per task and block of ten seeds, seed by seed: the method's
    row, then each such lever's on it, on the seeds the levers ran; the counts over those seeds."""
    fine = levers[levers["lever"].str.contains(match, regex=False)] if len(levers) else levers
    if not len(fine):
        return ""

    def marks(trials: pd.DataFrame, seeds_: list[int]) -> tuple[str, int, int, int]:
        by_seed = trials.drop_duplicates("seed").set_index("seed")
        out = []
        for s in seeds_:
            r = by_seed.loc[s] if s in by_seed.index else None
            key = "none" if r is None else _outcome(r).replace("not completed", "failed")
            out.append(OUTCOME_MARKS[key])
        ran = by_seed.loc[[s for s in seeds_ if s in by_seed.index]]
        return "".join(out), len(ran), int(ran["completed"].sum()), int(ran["finished_cleanly"].sum())

    rows = []
    for task in ordered(fine["task"].unique(), TASK_ORDER):
        for on in sorted(fine.loc[fine["task"] == task, "on"].unique()):
            mine = fine[(fine["task"] == task) & (fine["on"] == on)]
            base = every[(every["task"] == task) & (every["variant"] == on)] if len(every) else every
            for block in sorted({int(s) // 10 for s in mine["seed"]}):
                seeds_ = list(range(10 * block, 10 * block + 10))
                shown = [(f"`{on}`", base)] + [
                    (f"`{' '.join(p for p in lever.split() if not p.startswith('variant='))}` on it", g)
                    for lever, g in mine.groupby("lever", sort=True)
                    if g["seed"].isin(seeds_).any()
                ]
                for name, trials in shown:
                    code, n, k, c = marks(trials[trials["seed"].isin(seeds_)], seeds_)
                    rows.append(
                        f"| {task} | {seeds_[0]}-{seeds_[-1]} | {name} | `{code}` | {of(k, n)} | {of(c, n)} |"
                    )
    return (
        f"\nSeed by seed, the lever trials {which}, kept in "
        f"`{LEVERS}/`) beside the method each ran on, in blocks of ten seeds (seeds {HELDOUT_SEEDS} held "
        f"out; `{OUTCOME_MARKS['clean']}` finished cleanly, `{OUTCOME_MARKS['completed']}` completed only, "
        f"`{OUTCOME_MARKS['failed']}` not completed, `{OUTCOME_MARKS['none']}` not run); the counts over the "
        "seeds each row ran:\n\n"
        "| task | seeds | trials | per seed | completed | finished cleanly |\n|---|---|---|---|--:|--:|\n"
        + "\n".join(rows)
        + "\n"
    )


PHYSICS = "model_physics.csv"


def physics_method() -> str:
    """The method whose held-out trials ``studies/method/model_physics.py`` replays (its ``METHOD``)."""
    m = re.search(r'^METHOD = "([^"]+)"', (HERE / "model_physics.py").read_text(), re.M)
    return m[1] if m else METHOD


def model_physics(rows: pd.DataFrame) -> str:
    """What the replays of :data:`PHYSICS` (``studies/method/model_physics.py``; rows: ``task``, ``seed``,
    ``model``, ``step``, ``lifted``, ``cpu``, ``before``, ``after``) say: per planning model (the method's
    10 ms, it with each physics option, 5 ms), of the replays the plant lifts, how many it lifts too, of
    the others, how many it lifts, on how many trials it agrees with the plant, per task and over them,
    and its replay's CPU against the 10 ms model's; then whether any option at 10 ms agrees as often as
    the finer step."""
    if not len(rows):
        return ""
    before, after = rows["before"].iloc[0], rows["after"].iloc[0]
    tasks = ordered(rows["task"].unique(), [f"paper_{t}" for t in TASK_ORDER])
    plant = rows[rows["model"] == "plant"].set_index(["task", "seed"])["lifted"].astype(bool)
    base_cpu = rows[rows["model"] == "10 ms"].groupby("task")["cpu"].median()
    agree: dict[str, int] = {}
    body = []
    for model, g in rows[rows["model"] != "plant"].groupby("model", sort=False):
        lifted = g.set_index(["task", "seed"])["lifted"].astype(bool).reindex(plant.index, fill_value=False)
        cells = []
        for task in [*tasks, None]:
            at = plant.index.get_level_values("task") == task if task else np.ones(len(plant), bool)
            p, m = plant[at], lifted[at]
            cells.append(
                f"{int((m & p).sum())}/{int(p.sum())}; {int((m & ~p).sum())}/{int((~p).sum())}; "
                f"{int((m == p).sum())}/{len(p)}"
            )
        agree[model] = int((lifted == plant).sum())
        cpu = float((g.groupby("task")["cpu"].median() / base_cpu).median())
        body.append(f"| {model} | " + " | ".join(cells) + f" | {cpu:.2f}x |")
    names = [t.removeprefix("paper_") for t in tasks]
    out = (
        f"Can the planning model keep its 10 ms step and hold the grasps the plant holds? Each of "
        f"`{physics_method()}`'s held-out trials on the free objects replayed open-loop as above "
        f"(`python studies/method/model_physics.py`: from {before:g} s before its contact span to "
        f"{after:g} s after it, its recorded hand targets), in the plant, in the method's planning model "
        "(10 ms), in that model with one physics option at a time (set on the planning model only; none "
        "is an option of the library), and in the model stepped at 5 ms. Each cell: of the replays the "
        "plant lifts, how many the model lifts too; of the others, how many it lifts; on how many it agrees "
        "with the plant; the last column, the CPU of a replay against the 10 ms model's (median over the "
        "tasks' medians).\n\n"
        + pipe_table(["planning model", *names, "all", "CPU"], "l" + "r" * (len(names) + 2), body)
    )
    options = {m: a for m, a in agree.items() if m.startswith("10 ms, ")}
    fine = {m: a for m, a in agree.items() if not m.startswith("10 ms")}
    if options and fine and "10 ms" in agree:
        best = max(options, key=options.get)
        step, fine_agree = max(fine.items(), key=lambda kv: kv[1])
        verdict = (
            "no physics option tried at 10 ms agrees with the plant as often as the finer step does; what "
            "the coarse model loses, these options do not win back"
            if options[best] < fine_agree
            else f"`{best}` agrees with the plant as often as the finer step: a 10 ms model worth trying in "
            "full trials"
        )
        out += (
            f"\nOver the {len(plant)} replays, the 10 ms model agrees with the plant on {agree['10 ms']}, "
            f"the best option at 10 ms (`{best}`) on {options[best]}, and the model stepped at {step} on "
            f"{fine_agree}: {verdict}.\n"
        )
    return out


FAILED_REST = "failed_rest.csv"
#: A lost object "where the reference expects it": moved at most this far across the table (m) and turned at
#: most this much (deg) from its start, so the reference's approach and grasp would meet it again.
REST_MOVE, REST_TURN = 0.02, 15.0


def failed_rest(rows: pd.DataFrame) -> str:
    """Where the free objects lie once their trials have lost them (:data:`FAILED_REST`'s rows: ``task``,
    ``lifted``, ``moved`` (mm) and ``turned`` (deg) from the trial's start, read ``after`` s after the
    failure; ``studies/method/failed_rest.py``): per task, the medians and 90th percentiles, and
    how many lie within :data:`REST_MOVE` of where they started, and also within :data:`REST_TURN`."""
    if not len(rows):
        return ""
    body = []
    for task in ordered(rows["task"].unique(), [f"paper_{t}" for t in TASK_ORDER]):
        g = rows[rows["task"] == task]
        near = g["moved"] <= 1e3 * REST_MOVE
        body.append(
            f"| {task.removeprefix('paper_')} | {len(g)} | {int((~g['lifted'].astype(bool)).sum())} | "
            f"{g['moved'].median():.0f} / {g['moved'].quantile(0.9):.0f} | "
            f"{g['turned'].median():.0f} / {g['turned'].quantile(0.9):.0f} | {int(near.sum())} | "
            f"{int((near & (g['turned'] <= REST_TURN)).sum())} |"
        )
    move, turn = f"{1e3 * REST_MOVE:.0f} mm", f"{REST_TURN:.0f}°"
    return (
        "Could a lost grasp be tried again from the reference's approach? Every kept trial of the levers "
        "and the held-out seeds on a free object that did not complete (`python studies/method/"
        f"failed_rest.py`; every option): the object {rows['after'].iloc[0]:g} s after the trial's failure "
        "time, against where it "
        "started: how far it moved across the table and how far it turned (median / 90th percentile), and "
        f"on how many it lies within {move} of its start, and within {move} and {turn} (where the "
        "reference's approach would meet it again; the apple is a sphere, whose turn does not stop a "
        "grasp).\n\n"
        + pipe_table(
            [
                "task",
                "lost",
                "never lifted",
                "moved (mm)",
                "turned (deg)",
                f"within {move}",
                f"within {move} and {turn}",
            ],
            "lrrrrrr",
            body,
        )
    )


PLAN_COSTS = "plan_benchmark.csv"


#: The paper point's plan, samples x rollout steps (128 x 2.5 s of 10 ms): what the calibrated latency prices.
PAPER_PLAN = (128, 250)


def plan_costs(rows: pd.DataFrame) -> str:
    """What one plan costs per planning model (:data:`PLAN_COSTS`'s rows: ``task``, ``rollout``, ``state``,
    ``plan_cpu_seconds``, ``plan_samples``, ``horizon_steps``; ``studies/method/plan_benchmark.py``): per
    task and state, a planning iteration's CPU seconds, its samples x steps, the CPU a sample-step costs,
    and the plan against the paper point's plan at the same state (:data:`PAPER_PLAN` at ``rollout=paper``'s
    cost a sample-step there, the plan the calibrated latency prices); then each model's largest ratio."""
    if not len(rows):
        return ""
    rows = rows.assign(
        step_us=1e6 * rows["plan_cpu_seconds"] / (rows["plan_samples"] * rows["horizon_steps"])
    )
    rollouts = list(dict.fromkeys(rows["rollout"]))
    samples, steps = PAPER_PLAN
    out = [
        "`job=benchmark` of each paper task's default method with each planning model, one thread, at the "
        "states of a replay of the reference (`python studies/method/plan_benchmark.py`): *approach* (half-"
        "way to the first expected contact, inside the acquire window where `effort=acquire` draws 128 "
        "samples a plan) and *contact* (the middle of the contact span, after it: 32). Each cell: the CPU "
        "seconds of one planning iteration; its samples x rollout steps; the CPU a sample-step costs (us); "
        f"and the plan against the paper point's plan at the same state ({samples} samples x {steps} steps "
        "at `rollout=paper`'s cost a sample-step there: the plan the calibrated 170 ms prices).\n\n"
        "| task | state | " + " | ".join(f"`rollout={r}`" for r in rollouts) + " |\n"
        "|---|---|" + "--:|" * len(rollouts) + "\n"
    ]
    worst = {}
    for task in ordered(rows["task"].unique(), [f"paper_{t}" for t in TASK_ORDER]):
        mine = rows[rows["task"] == task].set_index(["rollout", "state"])
        for state in ("approach", "contact"):
            if ("paper", state) not in mine.index:
                continue
            paper_plan = samples * steps * mine.loc[("paper", state), "step_us"] * 1e-6
            cells = []
            for r in rollouts:
                if (r, state) not in mine.index:
                    cells.append("")
                    continue
                row = mine.loc[(r, state)]
                ratio = row["plan_cpu_seconds"] / paper_plan
                worst[r] = max(worst.get(r, 0.0), ratio)
                size = f"{int(row['plan_samples'])} x {int(row['horizon_steps'])}"
                cells.append(
                    f"{row['plan_cpu_seconds']:.2f} s; {size}; {row['step_us']:.0f} us; {ratio:.2f}x"
                )
            out.append(f"| {task.removeprefix('paper_')} | {state} | " + " | ".join(cells) + " |\n")
    out.append(
        "\nThe largest plan of each against the paper point's plan at the same state: "
        + "; ".join(f"`rollout={r}` {v:.2f}x" for r, v in worst.items())
        + ". A model whose plans stay at or under 1x fits the latency its trials are charged (the preset's "
        "170 ms); one above it would be applied later on the paper's 7 threads than its trials assume.\n"
    )
    return "".join(out)


SETTLES = "settle.csv"


def settles(rows: pd.DataFrame) -> str:
    """Where each free object rests before the hand reaches it (:data:`SETTLES`'s rows: ``task``, ``start``,
    ``time``, ``position_mm``, ``rotation_deg``, ``hand_contacts``; ``studies/method/settle.py``): per task,
    its offset from the reference's first configuration where the trial starts it and where it rests, how
    long it takes to get there, against the task's final tolerances; then the apple started at the
    reference's first configuration itself."""
    if not len(rows):
        return ""
    out = [
        "Each free object started as a trial starts it (the task's start, the hand held at the reference's "
        "first configuration, out of contact), then left to rest (`python studies/method/settle.py`): its "
        "offset from the reference's first configuration, which the trials' object errors are measured "
        "against, where it starts and where it rests; against the tolerance the task's final check allows "
        "(from the reference's final configuration).\n\n"
        "| task | at the start | at rest | at rest after | the final check allows | hand contacts |\n"
        "|---|--:|--:|--:|--:|--:|\n"
    ]

    def ends(task: str, start: str):
        mine = rows[(rows["task"] == task) & (rows["start"] == start)].sort_values("time")
        return mine, mine.iloc[0], mine.iloc[-1]

    for task in ordered(rows["task"].unique(), [f"paper_{t}" for t in TASK_ORDER]):
        mine, first, last = ends(task, "task")
        near = (mine["rotation_deg"] - last["rotation_deg"]).abs().lt(0.5) & (
            mine["position_mm"] - last["position_mm"]
        ).abs().lt(0.5)
        since = mine["time"][~near].max() if (~near).any() else -1.0
        at_rest = mine["time"][mine["time"] > since].min()
        cls = _task_class(task.removeprefix("paper_"))
        allows = (
            f"{1e3 * cls.SETTLE_POSITION:.0f} mm, {math.degrees(cls.SETTLE_ROTATION):.0f}°" if cls else ""
        )
        out.append(
            f"| {task.removeprefix('paper_')} | "
            f"{first['position_mm']:.1f} mm, {first['rotation_deg']:.1f}° | "
            f"{last['position_mm']:.1f} mm, {last['rotation_deg']:.1f}° | {at_rest:.2f} s | {allows} | "
            f"{int(mine['hand_contacts'].max())} |\n"
        )
    if ((rows["task"] == "paper_apple") & (rows["start"] == "reference")).any():
        _, first, last = ends("paper_apple", "task")
        _, _, bare = ends("paper_apple", "reference")
        out.append(
            f"\nThe reference's first orientation of the apple is not one the model's apple rests in on the "
            f"table: it turns {last['rotation_deg']:.1f}° from it before the hand arrives. Started at the "
            "reference's first configuration itself (without the authors' "
            f"{first['position_mm']:.0f} mm start offset) it turns {bare['rotation_deg']:.1f}° and rests "
            f"{bare['position_mm']:.1f} mm from it: "
            "the offset moves where it rests, not how far it turns, so starting the apple elsewhere, or at "
            "rest, would not remove the turn. A grasp that keeps the apple as it finds it carries that turn "
            "to the set-down, where the final check allows "
            f"{math.degrees(_task_class('apple').SETTLE_ROTATION):.0f}° from the reference's final "
            "orientation.\n"
        )
    return "".join(out)


REFERENCE_GRASPS = "reference_grasp.csv"
#: the fingers from which reuse=elites_expected (planner.reuse_grasp) carries the runners-up in
REUSE_GRASP = OmegaConf.select(OmegaConf.load(CONF / "reuse" / "elites_expected.yaml"), "planner.reuse_grasp")


def reference_grasps(rows: pd.DataFrame) -> str:
    """When each task's reference closes its grasp (:data:`REFERENCE_GRASPS`'s rows: ``task``, ``time``,
    ``fingers``; ``studies/method/reference_grasp.py``): per task, when after its first expected contact
    the reference first expects two, three and four fingers on the object, and how long in the window it
    expects one finger alone."""
    if not len(rows):
        return ""
    window = float(rows["time"].max())
    out = [
        "From each paper task's reference, on the planning grid "
        "(`python studies/method/reference_grasp.py`): when, after its first expected contact, it first "
        "expects two, three and four fingers on the object (a finger: the links named `<finger>_*`; the "
        "palm is none), and how long in the first "
        f"{window:.0f} s it expects one finger alone. `reuse=elites_expected` (`planner.reuse_grasp` = "
        f"{REUSE_GRASP}) carries the last plan's runners-up into the plans from the {REUSE_GRASP}-finger "
        "instant on, and draws every sample fresh before it.\n\n"
        "| task | 2 fingers | 3 fingers | 4 fingers | one finger alone |\n|---|--:|--:|--:|--:|\n"
    ]
    for task in ordered(rows["task"].unique(), [f"paper_{t}" for t in TASK_ORDER]):
        mine = rows[rows["task"] == task].sort_values("time")
        step = float(mine["time"].diff().median())

        def first(n, mine=mine):
            at = mine["time"][mine["fingers"] >= n]
            return f"+{at.min():.2f} s" if len(at) else "never"

        alone = step * int((mine["fingers"] == 1).sum())
        out.append(
            f"| {task.removeprefix('paper_')} | {first(2)} | {first(3)} | {first(4)} | {alone:.2f} s |\n"
        )
    return "".join(out)


DECIDED = "decided.csv"
#: after the reference's first expected contact (s): the window ``effort=acquire`` gives the grasp
GRASP_WINDOW = 2.0
#: s: an object that leaves the reference this close to the reference's lift is lost at the lift
AT_LIFT = 0.5


def decided_figure(path: Path, rows: pd.DataFrame) -> None:
    """Per task, each failed trial's parting from its clean twin against when its object left the reference
    (both s after the reference's first expected contact): a cross where it was not completed, a dot where
    it was but not cleanly; the reference's lift dotted."""
    import matplotlib.pyplot as plt

    tasks = ordered(rows.loc[rows["off"].notna(), "task"].unique(), TASK_ORDER)  # those whose object left
    fig, axes = plt.subplots(1, len(tasks), figsize=(3.6 * len(tasks), 3.4), squeeze=False)
    for ax, task in zip(axes[0], tasks, strict=True):
        g = rows[rows["task"] == task]
        for done, marker, color, label in (
            (False, "x", "C3", "not completed"),
            (True, "o", "0.5", "not clean"),
        ):
            h = g[g["completed"] == done]
            ax.scatter(h["parted"] - h["first_contact"], h["off"] - h["first_contact"], marker=marker, s=16,
                       color=color, alpha=0.7, label=label)  # fmt: skip
        if g["lift"].notna().any():
            ax.axvline((g["lift"] - g["first_contact"]).median(), color="k", lw=0.7, ls=":")
        ax.axline((0, 0), slope=1, color="0.8", lw=0.7)
        ax.set_title(task)
        ax.set_xlabel("paths part, s after the first expected contact")
    axes[0][0].set_ylabel("object off the reference, s after it")
    axes[0][-1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def decided(rows: pd.DataFrame, study=None) -> str:
    """Where a seed's outcome is decided (:data:`DECIDED`'s rows: ``task``, ``seed``, ``run``, ``twin``,
    ``completed``, ``first_contact``, ``lift``, ``parted``, ``off``; ``studies/method/decided.py``): per
    task and kind of failure, how many failed trials parted from their clean twin before the reference's
    first expected contact, within :data:`GRASP_WINDOW` after it and later, the median parting and the
    median instant the object left the reference, beside the reference's lift; with a figure."""
    if not len(rows):
        return "No trial that did not finish cleanly has a clean trial of its seed on its processor.\n"
    rel = rows.assign(parted=rows["parted"] - rows["first_contact"], off=rows["off"] - rows["first_contact"],
                      lift=rows["lift"] - rows["first_contact"])  # fmt: skip
    table, grasp, lines = [], [], []
    for task in ordered(rel["task"].unique(), TASK_ORDER):
        for done, kind in ((False, "not completed"), (True, "completed, not clean")):
            g = rel[(rel["task"] == task) & (rel["completed"] == done)]
            if not len(g):
                continue
            before = int((g["parted"] < 0).sum())
            within = int(((g["parted"] >= 0) & (g["parted"] < GRASP_WINDOW)).sum())
            lift = g["lift"].median()
            left = g["off"].dropna()
            table.append(
                f"| {task} | {kind} | {len(g)} | {before} | {within} | {len(g) - before - within} "
                f"| {g['parted'].median():+.2f} | "
                + (f"{left.median():+.2f}" if len(left) else "never off")
                + " | "
                + (f"{lift:+.2f}" if pd.notna(lift) else "")
                + " |"
            )
            if not done:
                near = int(((g["off"] - g["lift"]).abs() <= AT_LIFT).sum()) if pd.notna(lift) else None
                grasp.append((task, len(g), len(g) - before, within, near))
    cols = ("task", "failure", "trials", "parted before the first expected contact",
            f"in the {GRASP_WINDOW:g} s after it", "later", "parting, median s",
            "object off the reference, median s", "the reference's lift, s")  # fmt: skip
    for task, n, after, within, near in grasp:
        lines.append(
            f"{task}: {of(after, n)} trials not completed followed a clean trial of their seed past the "
            f"reference's first expected contact ({within} parting within {GRASP_WINDOW:g} s of it)"
            + (
                f", and {of(near, n)} lost the object within {AT_LIFT:g} s of the reference's lift"
                if near is not None
                else ""
            )
        )
    link = (
        study.draw(
            "decided.png",
            lambda path: decided_figure(path, rows),
            "where failed trials part from a clean trial of their seed",
        )  # fmt: skip
        if study is not None
        else None
    )
    return (
        "Trials of one task and seed on one processor start in the same state and draw the same random "
        "numbers, so they follow one path until their options first act. For each kept trial that did not "
        "finish cleanly and has a trial of its task and seed on its processor that did "
        f"(`python studies/method/decided.py`; {len(rows)} such trials, any method or lever), the clean "
        "trial that follows it longest (the hand within 0.01 rad and the object within 1 mm at every "
        "sample): when their paths part, and when the failed trial's object first leaves the reference "
        "(40 mm or 30° for 0.3 s, as the timelines read it), in s after the reference's first expected "
        "contact, with the reference's lift (its free object 2 cm from where it starts).\n\n"
        + pipe_table(cols, "llrrrrrrr", table)
        + "\n"
        + (
            "; ".join(lines)
            + ": from one approach and first touch, a seed both failed and finished cleanly, as the plans "
            "after the first contact went.\n"
            if lines
            else ""
        )
        + (f"\n{link}\n" if link else "")
    )


GRASP_CONTACTS = "grasp_contacts.csv"
#: the index alone on the object for more than this share of the grasp's window: "mostly alone"
ALONE = 0.5


OPTION_COLUMNS = ("task", "option", "trials", "lifted", "thumb", "index alone", "index mostly alone",
                  "first touch")  # fmt: skip


def grasp_figure(path: Path, rows: pd.DataFrame) -> None:
    """Per task, each trial's first touch (s after the first expected contact) against the share of the
    grasp window with the index alone on the object (each jittered a little: both lie on the plans'
    grid); filled where the trial lifted the object, a cross where it did not; reuse's options (a
    ``reuse=`` in the option) in colour."""
    import matplotlib.pyplot as plt

    tasks = ordered(rows["task"].unique(), [f"paper_{t}" for t in TASK_ORDER])
    fig, axes = plt.subplots(1, len(tasks), figsize=(4.2 * len(tasks), 3.6), squeeze=False, sharey=True)
    reuse = rows["option"].astype(str).str.contains("reuse=")
    for ax, task in zip(axes[0], tasks, strict=True):
        mine = rows["task"] == task
        for kind, color in ((~reuse, "0.55"), (reuse, "C3")):
            for lifted, marker in ((True, "o"), (False, "x")):
                g = rows[mine & kind & (rows["lifted"] == lifted)]
                jitter = np.random.default_rng(0).uniform(-1, 1, (2, len(g))) * [[0.03], [0.015]]
                label = f"{'reuse' if color == 'C3' else 'other'}, {'lifted' if lifted else 'not lifted'}"
                x, y = g["first_touch"] + jitter[0], g["index_alone"] + jitter[1]
                ax.scatter(x, y, s=14, marker=marker, color=color, alpha=0.7, label=label)
        ax.axhline(ALONE, color="k", lw=0.6, ls=":")
        ax.set_title(task.removeprefix("paper_"))
        ax.set_xlabel("first touch, s after the first expected contact")
    axes[0][0].set_ylabel("share of the grasp window with the index alone")
    axes[0][-1].legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def grasp_contacts(rows: pd.DataFrame, study=None) -> str:
    """Which links are on the object while the grasp is won (:data:`GRASP_CONTACTS`' rows: ``task``,
    ``option``, ``thumb``, ``index_alone``, ``any`` (shares of the window's samples), ``first_touch`` (s
    after the first expected contact; optional), ``lifted``, ``grasp``; ``studies/method/grasp_contacts.py``):
    per task, the mean shares of the trials that lifted the object and of those that did not; the trials
    with the index mostly alone on it, and how many of them lifted it (Barnard's test against the others);
    per option with at least 5 trials of a task, the same and the median first touch."""
    if not len(rows):
        return ""
    window = float(rows["grasp"].iloc[0])
    out = [
        "Every kept trial of this study on a free object whose time series is kept (the levers' and the "
        f"held-out trials; `python studies/method/grasp_contacts.py`; {len(rows)} trials of every option): "
        f"over the {window:g} s from the reference's first expected contact (effort=acquire's window, where "
        "the grasp is won), the share of the logged samples on which a thumb link touches the object, on "
        "which an index link does and no other link (*index alone*), and on which any link does; the mean "
        "over the trials that lifted the object and over those that did not.\n\n"
        "| task | lifted: trials | thumb | index alone | any link | not lifted: trials | thumb | index alone "
        "| any link |\n|---|--:|--:|--:|--:|--:|--:|--:|--:|\n"
    ]
    lines = []
    for task in ordered(rows["task"].unique(), [f"paper_{t}" for t in TASK_ORDER]):
        mine = rows[rows["task"] == task]
        cells = []
        for lifted in (True, False):
            g = mine[mine["lifted"] == lifted]
            shares = [f"{g[c].mean():.2f}" if len(g) else "—" for c in ("thumb", "index_alone", "any")]
            cells += [str(len(g)), *shares]
        name = task.removeprefix("paper_")
        out.append(f"| {name} | " + " | ".join(cells) + " |\n")
        alone = mine["index_alone"] > ALONE
        if alone.sum() and (~alone).sum():
            a, b = mine[alone], mine[~alone]
            p, _ = completion_test(int(a["lifted"].sum()), len(a), int(b["lifted"].sum()), len(b))
            lines.append(
                f"- {name}: with the index alone on it for more than {ALONE:.0%} of the window, lifted "
                f"{of(int(a['lifted'].sum()), len(a))}; otherwise {of(int(b['lifted'].sum()), len(b))} "
                f"(Barnard p = {Fmt.p(p)})."
            )
    per_option = []
    touch = rows["first_touch"] if "first_touch" in rows else pd.Series(np.nan, index=rows.index)
    for (task, name), g in rows.groupby(["task", "option"], sort=True):
        if len(g) >= 5:
            first = touch[g.index].dropna()
            per_option.append(
                f"| {task.removeprefix('paper_')} | `{name}` | {len(g)} "
                f"| {of(int(g['lifted'].sum()), len(g))} | {g['thumb'].mean():.2f} "
                f"| {g['index_alone'].mean():.2f} | {int((g['index_alone'] > ALONE).sum())} "
                f"| {f'{first.median():.2f} s' if len(first) else '—'} |"
            )
    text = "".join(out) + ("\n" + "\n".join(lines) + "\n" if lines else "")
    if per_option:
        text += (
            "\nPer option with at least 5 trials of a task (a lever's overrides after its method's name, "
            "`+`): the trials, those that lifted the object, the mean shares, the trials with the index "
            "alone on it for more than half of the window, and when a link first touched it (the median, s "
            "after the first expected contact; the series are logged once a plan).\n\n"
            + pipe_table(OPTION_COLUMNS, "llrrrrrr", per_option)
        )
    if study is not None and "first_touch" in rows:
        link = study.draw(
            "grasp_contacts.png",
            lambda path: grasp_figure(path, rows),
            "per trial, the first touch against the share of the grasp window with the index alone",
        )
        text += (
            "\nEach trial's first touch against its share of the window with the index alone (filled: "
            "lifted; a cross: not; red: an option with `reuse=`):\n\n" + link + "\n"
        )
    return text


FIRST_TOUCHES = "first_touch.csv"
#: The bins of the first touch (s after the reference's first expected contact) and their names.
TOUCH_BINS = (-np.inf, -0.01, 0.2, 0.7, np.inf)
TOUCH_NAMES = ("before it", "0-0.2 s after", "0.2-0.7 s after", "0.7 s or more after")


def first_touches(rows: pd.DataFrame) -> str:
    """When the hand first touched the object (:data:`FIRST_TOUCHES`' rows: ``task``, ``shaping``,
    ``first_touch`` (s after the reference's first expected contact), ``displaced_mm``, ``lifted``,
    ``completed``, ``finished_cleanly``; ``studies/method/first_touch.py``): per task, of the trials with the
    clearance term, the trials, those that lifted the object, completed and finished cleanly per bin of the
    first touch; and per task, the trials first touching within 0.2 s of the expected contact against those
    touching later (Barnard's test on completion)."""
    rows = rows[(rows["shaping"] == "clearance") & rows["first_touch"].notna()].copy()
    if not len(rows):
        return ""
    rows["bin"] = pd.cut(rows["first_touch"], TOUCH_BINS, labels=TOUCH_NAMES)
    out = [
        "Every kept trial of this study with the clearance term whose time series is on this machine "
        f"(`python studies/method/first_touch.py`; {len(rows)} trials of every method, latency and loop, "
        "the sweep's, held-out, levers' and loop trials): when the hand first touched the object, against "
        "when the reference first expects it to (`contact_span_start`; the series are logged once a plan, "
        "so the instants are a plan's interval apart), and the object's displacement from where it started "
        "0.5 s after that expected contact (median). Each cell: lifted / completed / finished cleanly, of "
        "the trials (the doorknob has no lift: completed twice).\n\n"
        "| task | " + " | ".join(f"first touch {n}" for n in TOUCH_NAMES) + " |\n"
        "|---|" + "--:|" * len(TOUCH_NAMES) + "\n"
    ]
    lines = []
    for task in ordered(rows["task"].unique(), [f"paper_{t}" for t in TASK_ORDER]):
        mine = rows[rows["task"] == task]
        cells = []
        for name in TOUCH_NAMES:
            g = mine[mine["bin"] == name]
            if not len(g):
                cells.append("—")
                continue
            lifted = g["lifted"] if g["lifted"].notna().any() else g["completed"]
            counts = " / ".join(str(int(x.fillna(False).astype(bool).sum())) for x in
                                (lifted, g["completed"], g["finished_cleanly"]))  # fmt: skip
            cells.append(f"{counts} of {len(g)}; {g['displaced_mm'].median():.1f} mm")
        out.append(f"| {task.removeprefix('paper_')} | " + " | ".join(cells) + " |\n")
        soon = mine["bin"].isin(TOUCH_NAMES[:2])
        a, b = mine[soon], mine[~soon]
        if len(a) and len(b):
            ka, kb = int(a["completed"].astype(bool).sum()), int(b["completed"].astype(bool).sum())
            p = completion_test(ka, len(a), kb, len(b))[0]
            lines.append(
                f"- {task.removeprefix('paper_')}: first touching before or within 0.2 s of the expected "
                f"contact, {of(ka, len(a))} completed; later, {of(kb, len(b))} (Barnard p = {Fmt.p(p)})."
            )
    return (
        "".join(out)
        + "\n"
        + "\n".join(lines)
        + "\n\nThese are associations over trials of many configurations, not a lever's effect: the "
        "method screen's `links5` (`cost.clearance_links=5`, every link held off until the reference "
        "expects five links at once) tests holding the hand off on the same seeds.\n"
    )


def links_screen() -> str:
    """What the method screen's ``links5`` (``cost.clearance_links=5`` on top of its method) did against
    that method's own screen trials on the same seeds, per task: lifted, and the lever's median first touch
    (s after the first expected contact); empty without such trials."""
    from analysis.study import Study

    screen = Study("method_screen")
    df = screen.records()
    if "cost.clearance_links" not in df or not len(df):
        return ""
    at = planned_latency() or math.nan  # the calibrated latency, plans that often
    calibrated = ((df["latency"] - at).abs() < 1e-6) & ((df["replan_interval"] - at).abs() < 1e-6)
    df = df[(df["variant"] == screen.spec.METHOD) & calibrated]
    if "planner.approach_reset" in df:
        df = df[df["planner.approach_reset"].isna()]
    df = df.assign(lever=[screen.spec.method_lever(r) for r in df.to_dict("records")])
    parts = []
    for task in ordered(df["task"].unique(), [f"paper_{t}" for t in TASK_ORDER]):
        mine, base = (df[(df["task"] == task) & (df["lever"] == x)] for x in ("links5", ""))
        both = sorted(set(mine["seed"]) & set(base["seed"]))
        if not both:
            continue
        a, b = (g[g["seed"].isin(both)].drop_duplicates("seed") for g in (mine, base))
        ka, kb = (int(g["milestone_lifted"].fillna(False).astype(bool).sum()) for g in (a, b))
        touch = (
            (a["first_contact_time"] - a["contact_span_start"]).dropna() if "first_contact_time" in a else []
        )
        when = (
            f", its first touch a median {touch.median():.2f} s after the expected contact"
            if len(touch)
            else ""
        )
        p = completion_test(ka, len(both), kb, len(both))[0]
        parts.append(
            f"{task.removeprefix('paper_')} (seeds {seeds(both)}): lifted {of(ka, len(both))} against "
            f"{of(kb, len(both))} (Barnard p = {Fmt.p(p)}){when}"
        )
    if not parts:
        return ""
    return (
        f"\nIn the screen (`{screen.spec.METHOD}` at {1e3 * at:.0f} ms, with `links5` against without): "
        + "; ".join(parts)
        + " (the method screen's report, *Levers on top of the method*).\n"
    )


def shortfall(df: pd.DataFrame, study=None) -> str:
    """Per task, why ``METHOD``'s trials that did not finish cleanly did not: those not completed (the
    milestones they missed, when the failure rule fired) and those completed but not settled (the object
    error at the end of the contact span, where the hand lets go, against the trial's end: an object that
    was where the reference has it when the hand let go and moved on afterwards)."""
    ok = counted(df)
    if not len(ok):
        return "Not measured yet.\n"
    kinds = ok.attrs.get("error_kinds", {})
    out = []
    for task in plan()[0]:
        g = cell(ok, task, METHOD)
        if not len(g):
            continue
        unit = "mm" if kinds.get(task) == "position" else "x 1e-3 (rad, or m for a slide)"
        scale = 1e3
        short = g[~g["finished_cleanly"]]
        head = f"- **{task}**: {of(int(g['finished_cleanly'].sum()), len(g))} finished cleanly"
        if not len(short):
            out.append(head + ".")
            continue
        parts = []
        failed = short[~short["completed"]]
        if len(failed):
            missed = {}
            for r in failed.to_dict("records"):
                for k, v in r.items():
                    if k.startswith("milestone_") and isinstance(v, bool | np.bool_) and not v:
                        missed.setdefault(k.removeprefix("milestone_"), []).append(int(r["seed"]))
            parts.append(
                f"not completed on {_seeds(failed['seed'])} ("
                + "; ".join(f"`{m}` not reached on {seeds(s)}" for m, s in missed.items())
                + ")"
            )
        done = short[short["completed"]]
        if len(done):
            at_span, final = _span_final(done) * scale, done["_final"] * scale
            moved = done[(final > 2 * at_span.clip(lower=1e-9)).to_numpy()]
            parts.append(
                f"completed but not settled on {_seeds(done['seed'])}: the object error where the "
                f"contact span ends (where the hand lets go) median {at_span.median():.0f} {unit}, at the "
                f"trial's end {final.median():.0f} {unit}"
                + (
                    f"; on {of(len(moved), len(done))} it at least doubled after the span: the object moved "
                    "on after the hand let go"
                    if len(moved)
                    else ""
                )
                + (
                    _slide_speeds(done, task, study)
                    if kinds.get(task) == "articulation"
                    else _endings(done, task)
                )
            )
        out.append(head + "; " + "; ".join(parts) + ".")
        if study is not None and len(done):
            paths = [Path(p).parent / "timeseries.npz" for p in g["record_path"]]
            missing_series = next((p for p in paths if not p.is_file()), None)
            link = study.draw(
                f"after_span_{task}.png",
                lambda path, task=task, g=g: after_span_figure(path, task, g, kinds.get(task, "position")),
                f"{task}: the object error after the hand lets go",
                data=missing_series,
            )
            if link:
                out += ["", f"  {link}", ""]
        if (
            kinds.get(task) == "articulation"
            and len(done)
            and (replayed := from_figures(study, REPLAYS, release_replays))
        ):
            out += [replayed, ""]
    return "\n".join(out).rstrip("\n") + "\n"


# ---------------------------------------------------------------------------------------------- latency


def with_heldout(study, df: pd.DataFrame) -> pd.DataFrame:
    """The trials that count, the sweep's (:func:`counted`) and the held-out ones (:func:`heldout_frame`)."""
    ok = counted(df)
    held = heldout_frame(study, df)[0]
    return pd.concat([x for x in (ok, held) if len(x)]) if len(ok) or len(held) else ok


def latency_section(study, df: pd.DataFrame) -> str:
    """Simulated trials of a method at another latency than the calibrated one
    (``latency/<run>/trial.json``, made by ``run_latency.sh``): per task and seed, completed / finished
    cleanly at each latency, beside the same method's trial of the same seed at the calibrated latency (the
    study's records)."""
    records = kept(study, "latency")
    ran = list(dict.fromkeys(method_name(r) or METHOD for r in records)) or [METHOD]
    head = (
        f"{codes(ran)}'s trials at the calibrated latency beside the same seeds with each plan applied "
        "sooner or later (`planner.latency`), plans still started every 170 ms "
        "(`planner.replan_period=0.17`) or as often as the latency allows (`EVERY=`; a latency over 170 ms "
        "starts them that often), as a faster or a slower machine would apply them; `bash "
        "studies/method/run_latency.sh`. An online run on a machine that plans faster than the calibrated "
        "latency is such a trial, in wall-clock time; the grasp's plans of `effort=acquire` take longer "
        "than the calibrated latency on the paper's 7 threads of this CPU (*What a plan costs with each "
        "planning model*), which a trial at a longer latency charges every plan. *Approach reset*: the "
        "lever `planner.approach_reset` on top of the method (`EXTRA=`): that many seconds before the "
        "first expected contact the committed control points go back to the reference's own, so the hand "
        "meets the object as a screen trial starts it.\n\n"
    )
    if not records:
        return head + "No such trial is kept yet.\n"
    ok = with_heldout(study, df)
    calibrated = 1e3 * (planned_latency() or math.nan)

    def at_calibrated(task: str, seeds: list, method: str) -> pd.DataFrame:
        """``method``'s trials at the calibrated latency on ``task`` and ``seeds`` (the sweep's, or
        held out: :func:`heldout_frame`)."""
        g = cell(ok, task, method) if len(ok) else ok
        return g[g["seed"].isin(seeds)] if len(g) else g

    def yes_no(completed, clean) -> str:
        return f"{'yes' if completed else 'no'} / {'yes' if clean else 'no'}"

    def approach(r: dict) -> float | None:
        """The run's ``planner.approach_reset`` (a lever on top of the method; ``None``: off)."""
        return ((r.get("config") or {}).get("planner") or {}).get("approach_reset")

    rows = []
    order = lambda r: (r.get("task", ""), r.get("latency") or 0, approach(r) or 0, r.get("seed") or 0)  # noqa: E731
    for r in sorted(records, key=order):
        task = r.get("task", "").removeprefix("paper_")
        base = at_calibrated(task, [r.get("seed")], method_name(r) or METHOD)
        at = yes_no(base["completed"].iloc[0], base["finished_cleanly"].iloc[0]) if len(base) else "—"
        rows.append(
            f"| {task} | {r.get('seed')} | {1e3 * (r.get('latency') or 0):.0f} "
            f"| {1e3 * (r.get('replan_interval') or 0):.0f} "
            f"| {'—' if approach(r) is None else f'{approach(r):g}'} "
            f"| {yes_no(r.get('completed'), r.get('finished_cleanly'))} "
            f"| {Fmt.num(r.get('ttf', math.nan), 2)} | {at} |"
        )
    cols = (
        "task", "seed", "latency (ms)", "a plan every (ms)", "approach reset (s)", "completed / clean", "TTF",
        f"at {calibrated:.0f} ms: completed / clean",
    )  # fmt: skip
    lines = []
    condition = lambda r: (  # noqa: E731
        r.get("task"),
        method_name(r) or METHOD,
        r.get("latency"),
        r.get("replan_interval"),
        approach(r) or 0.0,
    )
    for task, method, latency, every, reset in sorted({condition(r) for r in records}):
        group = [r for r in records if condition(r) == (task, method, latency, every, reset)]
        name = str(task).removeprefix("paper_")
        base = at_calibrated(name, [r.get("seed") for r in group], method)
        done = sum(bool(r.get("completed")) for r in group)
        p = (
            completion_test(done, len(group), int(base["completed"].sum()), len(base))[0]
            if len(base)
            else None
        )
        lines.append(
            f"- {name}" + (f", `{method}`" if len(ran) > 1 else "") + f", {1e3 * (latency or 0):.0f} ms, "
            f"a plan every {1e3 * (every or 0):.0f} ms"
            + (
                f", the approach reset {reset:g} s before the first contact (`planner.approach_reset`)"
                if reset
                else ""
            )
            + ": "
            f"{of(done, len(group))} completed, "
            f"{sum(bool(r.get('finished_cleanly')) for r in group)} cleanly; the same seeds at "
            f"{calibrated:.0f} ms: "
            + (
                f"{of(int(base['completed'].sum()), len(base))} completed, "
                f"{int(base['finished_cleanly'].sum())} cleanly (completion, Barnard's exact test: p = "
                f"{Fmt.p(p)})"
                if len(base)
                else "not measured"
            )
            + "."
        )
    needs = threads_needed(study, records, ok, calibrated)
    table = head + pipe_table(cols, "lrrrrlrl", rows) + "\n" + "\n".join(lines) + "\n"
    return table + (f"\n{needs}\n\n" if needs else "") + held_online(study)


def threads_needed(study, records: list[dict], ok: pd.DataFrame, calibrated_ms: float) -> str:
    """Per task, :data:`METHOD`'s completions at each latency it ran on the sweep's seeds (plans every
    latency, or every 170 ms below it; the calibrated latency's from the study's records), beside the
    threads of this CPU its grasp plans (``effort=acquire``'s, the plan benchmark's *approach* row at
    ``rollout=paper``, one thread) need to take effect within that latency; empty without the
    benchmark."""
    path = None if study is None else study.dir / "figures" / PLAN_COSTS
    if path is None or not path.is_file():
        return ""
    costs = pd.read_csv(path)
    costs = costs[(costs["rollout"] == "paper") & (costs["state"] == "approach")].set_index("task")
    sweep = set(plan()[1])
    out = []
    for task in sorted({r.get("task") for r in records if method_name(r) == METHOD}):
        name = str(task).removeprefix("paper_")
        if task not in costs.index:
            continue
        cpu = float(costs.loc[task, "plan_cpu_seconds"])
        mine = [r for r in records if r.get("task") == task and method_name(r) == METHOD]
        mine = [r for r in mine if r.get("seed") in sweep and (r.get("latency") or 0) * 1e3 > calibrated_ms]
        base = cell(ok, name, METHOD) if len(ok) else ok
        base = base[base["seed"].isin(sweep)] if len(base) else base
        if not mine or not len(base):
            continue
        at = {calibrated_ms: (int(base["completed"].sum()), len(base))}
        for latency in sorted({1e3 * r["latency"] for r in mine}):
            group = [r for r in mine if abs(1e3 * r["latency"] - latency) < 1e-6]
            at[latency] = (sum(bool(r.get("completed")) for r in group), len(group))
        parts = [
            f"{of(k, n)} completed at {ms:.0f} ms (its grasp plans need {1e3 * cpu / ms:.1f} threads)"
            for ms, (k, n) in sorted(at.items())
        ]
        out.append(
            f"- {name}: `{METHOD}` on the sweep's seeds: " + "; ".join(parts) + f". A grasp plan costs "
            f"{cpu:.2f} CPU-s on one thread of this CPU (*What a plan costs with each planning model*); "
            "the threads are that CPU time over the latency, a lower bound (perfect scaling, nothing else "
            "running)."
        )
    if not out:
        return ""
    return "What the method's latency asks of the machine:\n\n" + "\n".join(out)


def held_online(study) -> str:
    """Online runs of a method held to the calibrated latency (``job.apply_after``, kept under ``online/``)
    beside the same method's runs at the same slowdown that were not: whether the simulated trial's fixed
    latency is what the method lacks online, as a line per task, method and slowdown; and, where both ran
    on one processor and the same seeds (with or without ``job.latency_by_samples`` alike), the pairs
    counted together, with Barnard's test."""
    calibrated = planned_latency()
    runs = kept(study, "online")
    held = [r for r in runs if calibrated and abs((r.get("apply_after") or 0.0) - calibrated) < 1e-9]
    lines, pairs = [], []
    key = lambda r: (r.get("task", ""), method_name(r) or "", r.get("slowdown"))  # noqa: E731
    done = lambda rs: sum(bool(r.get("completed")) for r in rs)  # noqa: E731
    count = lambda rs: f"{of(done(rs), len(rs))} completed"  # noqa: E731
    for task, method, slowdown in sorted({key(r) for r in held}):
        same = [r for r in runs if key(r) == (task, method, slowdown)]
        group = [r for r in same if r in held]
        free = [r for r in same if not (r.get("apply_after") or r.get("min_interval"))]
        ms = f"{1e3 * calibrated:.0f} ms"
        paired = []
        for cpu in sorted({online_cpu(r) for r in group}):
            for by_samples in (False, True):
                mine, theirs = (
                    {
                        int(r.get("seed", -1)): r
                        for r in rs
                        if online_cpu(r) == cpu and bool(r.get("latency_by_samples")) == by_samples
                    }
                    for rs in (group, free)
                )
                if both := sorted(set(mine) & set(theirs)):
                    a, b = [mine[k] for k in both], [theirs[k] for k in both]
                    pairs.append((a, b))
                    paired.append(
                        f"on {cpu}, seeds {seeds(both)}{', latency by samples' if by_samples else ''}: "
                        f"{done(a)} against {done(b)} of {len(both)}"
                    )
        lines.append(
            f"- online, {task.removeprefix('paper_')}, `{method}` at slowdown {Fmt.num(slowdown, 0)}, each "
            "plan held to "
            f"act {ms} after its state and paced to one every {ms} (`job.apply_after`, `job.min_interval`: "
            f"the simulated trial's timing, `job.simulated_timing=true`): {count(group)}; continuous "
            "replanning at the same slowdown: "
            + (count(free) if free else "not run")
            + " (the online table above)"
            + ("; on the same processor and seeds, completed with the timing against without it: "
               + "; ".join(paired) if paired else "")  # fmt: skip
            + "."
        )
    if pairs:
        a = [r for x, _ in pairs for r in x]
        b = [r for _, y in pairs for r in y]
        p = completion_test(done(a), len(a), done(b), len(b))[0]
        lines.append(
            "- Over every such pair (one processor, one seed, one slowdown; every method and task "
            f"together): with the simulated trial's timing {of(done(a), len(a))} completed, replanning "
            f"continuously {of(done(b), len(b))} (Barnard p = {Fmt.p(p)}; the pairs are not independent "
            "draws of one rate: the tasks and slowdowns differ)."
        )
    return "\n".join(lines) + "\n" if lines else ""


def loop_threads(r: dict) -> int | None:
    """The threads a ``loop=per_plan`` record's latency model prices its plans on (``None``: another
    loop)."""
    planner = (r.get("config") or {}).get("planner") or {}
    if not planner.get("latency_per_plan"):
        return None
    return (planner.get("latency_model") or {}).get("threads")


def tally(records: list[dict]) -> tuple[int, int]:
    """``(completed, finished cleanly)``: how many of ``records`` did each."""
    return sum(bool(r.get("completed")) for r in records), sum(
        bool(r.get("finished_cleanly")) for r in records
    )


def loop_section(study, df: pd.DataFrame) -> str:
    """Simulated trials in MuJoCo MPC's loop on a machine of N threads (``loop=per_plan``,
    ``loop/<run>/trial.json``, made by ``run_loop.sh``): per task and thread count, completed / finished
    cleanly beside the same method's trials of the same seeds at the calibrated fixed latency (the study's
    records) and, on 2 threads, beside its online runs in real time on this machine's 2 threads."""
    records = [r for r in kept(study, "loop") if loop_threads(r)]
    calibrated = 1e3 * (planned_latency() or math.nan)
    head = (
        "A simulated trial charges every plan the calibrated latency, what the grasp's plans of "
        f"`effort=acquire` (128 samples) cost on the paper's 7 threads: {calibrated:.0f} ms. In MuJoCo "
        "MPC's loop each plan takes what its own samples cost. `loop=per_plan` "
        "(`planner.latency_per_plan`) applies each plan its own price after its state (its sample-steps at "
        "`preset=paper_calibrated`'s per sample-step cost, over the model's threads) and starts the next "
        "plan then: the plans after the grasp (32 samples) land 4 times sooner and come 4 times as often. "
        "`planner.latency_model.threads` sets the machine: 7, the paper's; 2, this machine's cores, which "
        "the online runs plan on (*Online, in wall-clock time*). Reproducible, unlike an online run: the "
        "latencies are priced from the config, not measured (`THREADS=7 bash studies/method/run_loop.sh`). "
        "*Plans land after*: the grasp's plans' latency and the later plans' (the record's "
        "`plan_latencies`).\n\n"
    )
    if not records:
        return head + "No such trial is kept yet.\n"
    ok = with_heldout(study, df)
    online_runs = kept(study, "online")
    usual = usual_cpu(online_runs)
    runs = [r for r in online_runs if real_time(r) and online_cpu(r) == usual]
    key = lambda r: (r.get("task", ""), method_name(r) or METHOD, loop_threads(r))  # noqa: E731
    rank = {t: i for i, t in enumerate(TASK_ORDER)}
    everything = sorted({key(r) for r in records}, key=lambda k: (rank.get(k[0][6:], 99), k[1], -k[2]))
    conditions = [k for k in everything if k[1] == METHOD]  # levers on it: their own table (loop_levers)
    machines = pd.Series([str(r.get("cpu") or "unknown CPU") for r in records]).value_counts()
    head += "The trials ran on " + Fmt.listing([f"{m} ({n})" for m, n in machines.items()]) + ".\n\n"
    rows, lines, bars = [], [], []
    for task, method, threads in conditions:
        group = sorted((r for r in records if key(r) == (task, method, threads)), key=lambda r: r["seed"])
        name = task.removeprefix("paper_")
        seed_list = [r["seed"] for r in group]
        base = cell(ok, name, method) if len(ok) else ok
        base = base[base["seed"].isin(seed_list)] if len(base) else base
        lats = sorted({float(v) for r in group for v in (r.get("plan_latencies") or {})})
        land = f"{1e3 * lats[-1]:.0f} / {1e3 * lats[0]:.0f}" if lats else "—"
        done, clean = tally(group)
        fixed, p = "—", None
        if len(base):
            base_done = int(base["completed"].sum())
            fixed = f"{of(base_done, len(base))} / {int(base['finished_cleanly'].sum())}"
            p = completion_test(done, len(group), base_done, len(base))[0]
        live = [r for r in runs if r.get("task") == task and (method_name(r) or METHOD) == method]
        live = live if threads == 2 else []  # the online runs plan on this machine's 2 threads
        online_cell = f"{of(tally(live)[0], len(live))} / {tally(live)[1]}" if live else "—"
        if not any(b[0] == name for b in bars) and len(base):  # the fixed latency's once a task
            base_all = cell(ok, name, method)
            base_all = base_all[base_all["seed"].isin({r["seed"] for r in records if r["task"] == task})]
            count = (int(base_all["completed"].sum()), int(base_all["finished_cleanly"].sum()))
            bars.append((name, f"fixed {calibrated:.0f} ms", len(base_all), *count))
        bars.append((name, f"{threads} threads", len(group), done, clean))
        if live:
            bars.append((name, "online, 2 threads", len(live), *tally(live)))
        rows.append(
            f"| {name} | `{method}` | {threads} | {land} | {seeds(seed_list)} | {of(done, len(group))} "
            f"| {clean} | {median([r.get('ttf') for r in group], '{:.2f}')} "
            f"| {median([r.get('cpu_seconds') for r in group])} | {fixed} "
            f"| {Fmt.p(p) if p is not None else '—'} | {online_cell} |"
        )
        if len(base):  # seed by seed only where both ran on one processor (else another draw)
            cpus = base["cpu"] if "cpu" in base else pd.Series([None] * len(base), index=base.index)
            was = {
                sd: {"completed": bool(c), "cpu": cpu}
                for sd, c, cpu in zip(base["seed"], base["completed"], cpus, strict=True)
            }
            gained, lost, apart = seeds_apart(group, was, "completed")
            if gained or lost or apart:
                lines.append(
                    f"- {name}, {threads} threads: completed only here on "
                    f"{_seeds(gained) if gained else 'no seed'}; only at the fixed {calibrated:.0f} ms on "
                    f"{_seeds(lost) if lost else 'no seed'}"
                    + (
                        f" ({apart} of {len(group)} trials ran on another processor than their seed's at "
                        "the fixed latency: for those only the counts compare)"
                        if apart
                        else ""
                    )
                    + "."
                )
    cols = (
        "task", "method", "threads", "plans land after (ms): grasp / later", "seeds", "completed",
        "finished cleanly", "median TTF", "median CPU-s", f"fixed {calibrated:.0f} ms, same seeds: "
        "completed / clean", "Barnard p (completed)", "online, 2 threads, real time: completed / clean",
    )  # fmt: skip
    note = (
        "\n*Online*: the method's runs at slowdown 1 (every run of it on the processor most online runs ran "
        f"on, {usual}: seeds 0-9 and re-runs), which plan "
        "continuously on this machine's 2 threads while the plant steps in a third thread on the same 2 "
        "cores; their grasp plans take longer than the model's 2 threads price (*Online, in wall-clock "
        "time*: their measured medians).\n"
    )
    levers, lever_bars = loop_levers(records, [k for k in everything if k[1] != METHOD], key)
    bars += lever_bars
    measured = measured_prices(study, sorted({k[2] for k in conditions}))
    link = study.draw(
        "loop.png",
        lambda path: loop_figure(path, bars),
        "the method at the fixed latency, on machines of N threads and online: trials completed and "
        "finished cleanly, per task",
    )
    return (
        head
        + pipe_table(cols, "lllllrrrrlrl", rows)
        + note
        + ("\n" + "\n".join(lines) + "\n" if lines else "")
        + (f"\n{levers}" if levers else "")
        + (f"\n{link}\n" if link else "")
        + (f"\n{measured}\n" if measured else "")
    )


def seeds_apart(group: list[dict], base: dict[int, dict], field: str) -> tuple[list, list, int]:
    """Seed by seed, ``group``'s trials against ``base`` (a record, or its ``field`` and ``cpu``, by
    seed) where both ran on one processor (on another, the same seed is another draw): the seeds on which
    ``field`` holds only in ``group``, only in ``base``, and how many of ``group``'s trials have no such
    counterpart."""
    same = [r for r in group if r["seed"] in base and base[r["seed"]].get("cpu") == r.get("cpu")]
    gained = [r["seed"] for r in same if r.get(field) and not base[r["seed"]].get(field)]
    lost = [r["seed"] for r in same if not r.get(field) and base[r["seed"]].get(field)]
    return gained, lost, len(group) - len(same)


def loop_levers(records: list[dict], conditions: list[tuple], key) -> tuple[str, list[tuple]]:
    """Levers on the method in the per-plan loop (``run_loop.sh`` with ``EXTRA``): per task, lever and
    thread count, completed / finished cleanly beside the method's own trials in the same loop on the same
    seeds (Barnard's test on each; seed by seed where both ran on one processor). Returns the table (empty
    without such trials) and the figure's bars, ``(task, label, trials, completed, clean)``."""
    if not conditions:
        return "", []
    rows, bars, lines = [], [], []
    for task, method, threads in conditions:
        group = sorted((r for r in records if key(r) == (task, method, threads)), key=lambda r: r["seed"])
        seed_list = {r["seed"] for r in group}
        base = {r["seed"]: r for r in records if key(r) == (task, METHOD, threads) and r["seed"] in seed_list}
        name, lever = task.removeprefix("paper_"), method.removeprefix(f"{METHOD}+")
        lats = sorted({float(v) for r in group for v in (r.get("plan_latencies") or {})})
        land = f"{1e3 * lats[-1]:.0f} / {1e3 * lats[0]:.0f}" if lats else "—"
        done, clean = tally(group)
        base_done, base_clean = tally(list(base.values()))
        p_done = completion_test(done, len(group), base_done, len(base))[0] if base else None
        p_clean = completion_test(clean, len(group), base_clean, len(base))[0] if base else None
        gained, lost, apart = seeds_apart(group, base, "finished_cleanly")
        method_cell = f"{of(base_done, len(base))} / {base_clean}" if base else "—"
        tests = [Fmt.p(p) if p is not None else "—" for p in (p_done, p_clean)]
        rows.append(
            f"| {name} | `{lever}` | {threads} | {land} | {seeds(sorted(seed_list))} "
            f"| {of(done, len(group))} | {clean} | {method_cell} | {tests[0]} | {tests[1]} "
            f"| {_seeds(gained) if gained else 'none'} | {_seeds(lost) if lost else 'none'} "
            f"| {median([r.get('cpu_seconds') for r in group])} |"
        )
        if apart:
            lines.append(
                f"- {name} `{lever}`, {threads} threads: {apart} of {len(group)} trials "
                "have no trial of the method on their seed on the same processor: for those only the counts "
                "compare."
            )
        bars.append((name, f"{threads} threads, {lever}", len(group), done, clean))
    cols = (
        "task", "lever", "threads", "plans land after (ms): grasp / later", "seeds", "completed",
        "finished cleanly", "the method in this loop, same seeds: completed / clean", "Barnard p (completed)",
        "Barnard p (clean)", "clean only with the lever", "clean only without", "median CPU-s",
    )  # fmt: skip
    head = (
        "**Levers on the method in this loop** (`run_loop.sh` with `EXTRA` overrides and a `TAG`), each "
        "against the method's own trials in the same loop, on the same machine of N threads and the same "
        "seeds:\n\n"
    )
    return head + pipe_table(cols, "llllllrlrrllr", rows) + (
        "\n" + "\n".join(lines) + "\n" if lines else ""
    ), bars


def measured_prices(study, threads: list[int]) -> str:
    """What the plan benchmark measured the method's plans to cost (``figures/plan_benchmark.csv``,
    ``rollout=paper``: the grasp's plan at the *approach* state, a later one at *contact*), over each of
    ``threads``, beside what the per-plan loop's model charges them; empty without the benchmark."""
    path = None if study is None else study.dir / "figures" / PLAN_COSTS
    if path is None or not path.is_file() or not threads:
        return ""
    costs = pd.read_csv(path)
    costs = costs[costs["rollout"] == "paper"].set_index(["task", "state"])["plan_cpu_seconds"]
    model = OmegaConf.select(OmegaConf.load(CONF / "loop" / "per_plan.yaml"), "planner.latency_model")
    step = float(model.sample_step_seconds)
    price = lambda n, samples: ComputeLatency(step, n).seconds(samples, 250, 0.001)  # noqa: E731
    parts, dearer, fixed_costs = [], 0, 0
    for task in (t for t in TASK_ORDER if (f"paper_{t}", "approach") in costs.index):
        grasp, later = (float(costs[(f"paper_{task}", state)]) for state in ("approach", "contact"))
        at = ", ".join(f"{1e3 * grasp / n:.0f} / {1e3 * later / n:.0f} ms on {n}" for n in threads)
        parts.append(f"{task} {at}")
        dearer += grasp > price(1, 128)
        fixed_costs += later > grasp / 4
    if not parts:
        return ""
    priced = ", ".join(f"{1e3 * price(n, 128):.0f} / {1e3 * price(n, 32):.0f} ms on {n}" for n in threads)
    return (
        f"*The model's prices against the plans' measured cost.* The model charges a sample-step "
        f"{1e6 * step:.0f} us (calibrated on the paper's method, `variant=full`): a grasp / later plan "
        f"{priced} threads. The method's own plans, measured on one thread of this CPU (*What a plan costs "
        "with each planning model*, `rollout=paper`) and divided by the threads (perfect scaling): "
        + "; ".join(parts)
        + f". A grasp plan costs more than the model charges on {dearer} of {len(parts)} tasks, and a later "
        f"plan more than a quarter of a grasp plan on {fixed_costs} of {len(parts)}: where it does, the "
        "model's machine is faster than this CPU with as many threads, and its trials are an optimistic "
        "estimate of what the method does on this CPU."
    )


def loop_figure(path: Path, bars: list[tuple[str, str, int, int, int]]) -> None:
    """Per task, the share of trials completed (pale) and finished cleanly (solid) in each loop: ``bars`` of
    ``(task, loop, trials, completed, clean)``."""
    import matplotlib.pyplot as plt

    tasks = list(dict.fromkeys(b[0] for b in bars))
    loops = list(dict.fromkeys(b[1] for b in bars))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    count = [max(3, sum(b[0] == t for b in bars)) for t in tasks]  # bars a task, a panel as wide as they
    fig, axes = plt.subplots(
        1, len(tasks), figsize=(1.15 * sum(count), 4.2), squeeze=False, sharey=True,
        gridspec_kw={"width_ratios": count},
    )  # fmt: skip
    for ax, task in zip(axes[0], tasks, strict=True):
        mine = [b for b in bars if b[0] == task]
        for i, (_, loop, n, done, clean) in enumerate(mine):
            c = colors[loops.index(loop) % len(colors)]
            ax.bar(i, done / n, width=0.7, color=c, alpha=0.35)
            ax.bar(i, clean / n, width=0.7, color=c)
            ax.text(i, done / n + 0.02, f"{clean}/{done}/{n}", ha="center", fontsize=7)
        ax.axhline(TARGET_CLEAN / TARGET_SEEDS, color="k", lw=0.8, ls="--")
        ax.set_title(task)
        labels = [b[1].replace(", ", ",\n").replace("+", "\n+") for b in mine]
        ax.set_xticks(range(len(mine)), labels, fontsize=7)
        ax.set_ylim(0, 1.12)
    axes[0][0].set_ylabel("finished cleanly (solid), completed (pale)")
    fig.suptitle(
        "the method (and levers on it) in each loop; clean/completed/trials (the fixed latency's on every "
        "seed a loop ran)",
        fontsize=8,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


# ---------------------------------------------------------------------------------------------- report


def findings(df: pd.DataFrame) -> str:
    ok = counted(df)
    tasks, planned_seeds = plan()
    if not len(ok):
        return (
            f"Not measured yet: no records. The target is per task ≥ {TARGET_COMPLETED}/{TARGET_SEEDS} "
            f"completed and ≥ {TARGET_CLEAN}/{TARGET_SEEDS} finished cleanly for `{METHOD}`.\n"
        )
    out = []
    verdicts = {}
    for task in tasks:
        g = cell(ok, task, METHOD)
        if not len(g):
            out.append(f"- **{task}**: `{METHOD}` not measured yet.")
            continue
        k, c, n = int(g["completed"].sum()), int(g["finished_cleanly"].sum()), len(g)
        verdicts[task] = target(k, c, n)
        out.append(
            f"- **{task}**: `{METHOD}` completes {of(k, n)} and finishes {of(c, n)} cleanly "
            f"(median {median(g['cpu_seconds'])} CPU-s a trial"
            + (f" on the {on}" if (on := cost_on(g)) else "")
            + f"); target {verdicts[task]}."
        )
    met = [t for t, v in verdicts.items() if v.startswith("met")]
    missed = [t for t, v in verdicts.items() if v.startswith("missed")]
    head = (
        f"For `{METHOD}`, of the {len(tasks)} tasks, the target is met on {len(met)} "
        f"({', '.join(met) or 'none'}), missed on {len(missed)} ({', '.join(missed) or 'none'}) and open on "
        f"{len(tasks) - len(met) - len(missed)}. Each is one draw of {TARGET_SEEDS} seeds: *On seeds it was "
        f"not chosen on* reads the target as the chance that {TARGET_SEEDS} new seeds meet it, from every "
        "seed the method has."
    )
    others_met = []
    for task in tasks:
        by = []
        for v in others():
            g = cell(ok, task, v)
            k, c, n = int(g["completed"].sum()), int(g["finished_cleanly"].sum()), len(g)
            if n and target(k, c, n).startswith("met"):
                by.append(f"`{v}` ({k}/{n} completed, {c}/{n} finished cleanly)")
        if by:
            others_met.append(f"{task} by {Fmt.listing(by)}")
    tail = (
        "\n\nThe target is met by another method on: " + "; ".join(others_met) + "."
        if others_met
        else "\n\nNo other method meets the target on any task."
    )
    return head + tail + "\n\n" + "\n".join(out) + "\n"


#: What two records of one trial must hold alike to count as the same record (:func:`reproduced`).
SAME_RECORD = ("completed", "finished_cleanly", "ttf", "final_object_position_error",
               "final_object_rotation_error", "final_object_articulation_error")  # fmt: skip


def read_record(path) -> dict:
    """A record (``trial.json``) as a dict."""
    return json.loads(Path(path).read_text())


def _trial_key(record: dict, seed: int | None = None) -> str | None:
    """A record's resolved config (its output folder left out) and processor, as one string: two records
    with the same key ran the same trial on the same processor; ``None`` for a record without a config.
    With ``seed``, the key of the same trial on that seed."""
    config = dict(record.get("config") or {})
    config.pop("output_dir", None)
    if seed is not None and config:
        config["seed"] = seed
    return json.dumps([config, record.get("cpu")], sort_keys=True) if config else None


def stand_ins(study, df: pd.DataFrame, own: pd.DataFrame, method: str = METHOD) -> pd.DataFrame:
    """Lever trials (:data:`LEVERS`) on the held-out seeds that are :data:`METHOD`'s trials in all but their
    name: the same resolved config (the seed aside) on the same processor as one of the method's trials
    (``df``, the sweep's), on a task and seed the method has no held-out trial of its own (``own``); with
    ``variant`` set to :data:`METHOD` and ``stand_in`` the lever's name. Same config and seed, same record on
    one processor (31 of 31 agree where both ran: :func:`reproduced`)."""
    mine = counted(df)
    mine = mine[mine["variant"] == method] if len(mine) else mine
    mine = mine[mine["stand_in"].isna()] if "stand_in" in mine else mine
    if not len(mine) or "record_path" not in mine:
        return mine.iloc[0:0]
    levers = lever_frame(study)
    if not len(levers):
        return levers
    keys = {_trial_key(read_record(path), seed=0) for path in mine["record_path"]} - {None}
    have = set(zip(own["task"], own["seed"], strict=True)) if len(own) else set()
    held = levers[(levers["seeds"] == "held out") & levers["counted"]]
    rows = []
    for i, r in held.iterrows():
        if (r["task"], r["seed"]) not in have and _trial_key(read_record(r["record_path"]), seed=0) in keys:
            rows.append(i)
            have.add((r["task"], r["seed"]))
    return held.loc[rows].assign(stand_in=held.loc[rows, "lever"], variant=method)


def reproduced(study, df: pd.DataFrame) -> str:
    """Of :data:`METHOD`'s trials, those a lever (:data:`LEVERS`) ran before the method was named with the
    same resolved config on the same processor, and on how many the two records agree (:data:`SAME_RECORD`),
    as a sentence; ``""`` where there are none."""
    mine = own_trials(counted(df))
    levers = lever_frame(study)
    if not len(mine) or not len(levers):
        return ""
    by_key = {}
    for path, lever in zip(levers["record_path"], levers["lever"], strict=True):
        record = read_record(path)
        if (key := _trial_key(record)) is not None:
            by_key.setdefault(key, (record, lever))
    same, names, n = 0, set(), 0
    for path in mine["record_path"]:
        a = read_record(path)
        if (found := by_key.get(_trial_key(a))) is None:
            continue
        n += 1
        b, lever = found
        names.add(lever)
        same += all(a.get(k) == b.get(k) for k in SAME_RECORD)
    if not n:
        return ""
    return (
        f"\nOf `{METHOD}`'s {len(mine)} trials, {n} ran the same resolved config on the same processor as a "
        f"lever trial kept in `{LEVERS}/` before the method was named ({codes(sorted(names))}); the two "
        f"records agree (completion, finishing cleanly, TTF and the final errors) on {of(same, n)}.\n"
    )


def levers_target(study) -> str:
    """Which levers meet the issue's target (:func:`target`) on which task, on the sweep's seeds, counted only
    where a lever ran all of them; the tasks on which none does."""
    ok = lever_frame(study)
    tasks, seeds = plan()
    if not len(ok):
        return ""
    ok = ok[ok["seeds"] == "sweep"]
    met: dict[str, list[str]] = {}
    for (lever, task), g in ok.groupby(["lever", "task"]):
        k, c, n = int(g["completed"].sum()), int(g["finished_cleanly"].sum()), len(g)
        if n == len(seeds) and target(k, c, n) == "met":
            met.setdefault(task, []).append(f"`{lever}` ({k}/{n} completed, {c}/{n} finished cleanly)")
    found = [f"{task} by {', '.join(met[task])}" for task in tasks if task in met]
    everywhere = [
        lever
        for lever in sorted(set(ok["lever"]))
        if all(any(x.startswith(f"`{lever}` ") for x in met.get(task, [])) for task in tasks)
    ]
    nowhere = ", ".join(t for t in tasks if t not in met) or "no task"
    return (
        "\nOf the levers (*Levers on the method, full trials*; those run on all of the sweep's seeds of a "
        "task): "
        + (f"the target is met on {'; '.join(found)}." if found else "none meets the target on any task.")
        + f" On all {len(tasks)} tasks: "
        + (", ".join(f"`{x}`" for x in everywhere) if everywhere else "none")
        + f"; on none by any lever: {nowhere}. These are the seeds the levers were chosen on; their "
        "held-out rows in the levers' table say whether a count holds.\n"
    )


def rescue_rows(study, df: pd.DataFrame) -> list[tuple[str, dict[str, tuple[int, int, int, int]]]]:
    """Per option against :data:`METHOD` seed by seed (the sweep's seeds and the held-out ones, its
    stand-ins counted in): each other method of the sweep and each lever run on :data:`METHOD` or a method
    it is built on (:func:`built_chain`), per task ``(rescued, unclean, lost, clean)``: of
    the method's trials that did not finish cleanly on the seeds the option ran, how many the option
    finishes cleanly, and of those that did, how many it does not."""
    held, _, _ = heldout_frame(study, df)
    every = pd.concat([counted(df), held]) if len(held) else counted(df)  # the sweep's and held-out seeds
    mine = every[every["variant"] == METHOD] if len(every) else every
    clean_of = {(r["task"], int(r["seed"])): bool(r["finished_cleanly"]) for r in mine.to_dict("records")}
    options: dict[str, pd.DataFrame] = {}
    for method in ORDER:
        if method in (METHOD, free_base()) or not len(every):
            continue
        g = every[every["variant"] == method]
        if "stand_in" in g and method not in EQUIVALENT:  # a method with stand-ins has its trials in them
            g = g[g["stand_in"].isna()]
        if len(g):
            options[method] = g
    levers = lever_frame(study)
    equivalent = {name for folder, name in EQUIVALENT.get(METHOD, {}).values() if folder == LEVERS}
    for lever, g in levers.groupby("lever", sort=True) if len(levers) else ():
        on = built_on(g)
        if on in built_chain() and lever not in equivalent:
            options[lever if on == METHOD else f"{lever}` on `{on}"] = g
    rows = []
    for name, g in options.items():
        cells = {}
        for task in plan()[0]:
            pairs = [
                (bool(r["finished_cleanly"]), clean_of[(task, int(r["seed"]))])
                for r in g[g["task"] == task].to_dict("records")
                if (task, int(r["seed"])) in clean_of
            ]
            if pairs:
                cells[task] = (
                    sum(a and not b for a, b in pairs),
                    sum(not b for _, b in pairs),
                    sum(b and not a for a, b in pairs),
                    sum(b for _, b in pairs),
                )
        if cells:
            rows.append((name, cells))
    return rows


def rescues(study, df: pd.DataFrame) -> str:
    """Which options finish the trials :data:`METHOD` does not, and what they cost it on the other tasks
    (:func:`rescue_rows`): a table and, per task where the method misses the target, a sentence."""
    rows = rescue_rows(study, df)
    if not rows:
        return ""
    tasks = plan()[0]
    head = (
        f"What the other methods and the levers on `{METHOD}` do on the seeds where it fails and where it "
        "does not (seed by seed, the sweep's seeds and the held-out ones): per task, of the method's trials "
        "that did not finish cleanly on the seeds the option ran, how many the option finishes cleanly "
        "(*rescued*), and of those that did, how many it does not (*lost*). A trial run on another "
        "processor than the method's is another draw of the same seed, so a few of these pairs compare "
        "draws, not the option alone.\n\n"
    )

    def fmt(cell):
        if cell is None:
            return ""
        rescued, unclean, lost, clean = cell
        return f"{rescued} of {unclean} / {lost} of {clean}"

    cols = ["option"] + [f"{t}: rescued / lost" for t in tasks]
    body = [
        "| " + " | ".join([f"`{name}`"] + [fmt(cells.get(t)) for t in tasks]) + " |" for name, cells in rows
    ]
    out = head + pipe_table(cols, "l" + "r" * len(tasks), body) + "\n"
    ok = counted(df)
    lines = []
    for task in tasks:
        g = cell(ok, task, METHOD)
        if not target(int(g["completed"].sum()), int(g["finished_cleanly"].sum()), len(g)).startswith(
            "missed"
        ):
            continue
        good = [
            (name, cells)
            for name, cells in rows
            if task in cells and cells[task][1] >= 2 and 2 * cells[task][0] >= cells[task][1]
        ]
        if not good:
            lines.append(f"- **{task}** (target missed): no option finishes half of the method's failures.")
            continue
        parts = []
        for name, cells in good:
            rescued, unclean = cells[task][:2]
            cost = [
                f"{t}: loses {c[2]} of {c[3]}"
                for t, c in ((t, cells.get(t)) for t in tasks)
                if t != task and c
            ]
            parts.append(
                f"`{name}` finishes {rescued} of the {unclean}"
                + (
                    f" ({'; '.join(cost)} of the method's clean trials it ran)"
                    if cost
                    else " (run on no other task)"
                )
            )
        lines.append(
            f"- **{task}** (target missed): the options that finish at least half of the method's trials "
            "that did not finish cleanly (of at least 2 they ran): " + "; ".join(parts) + "."
        )
    return out + ("\n" + "\n".join(lines) + "\n" if lines else "")


def report(study) -> str:
    df = frame(study)
    rough = rough_frame(study)
    ok = counted(df)
    side, notes = paired(df)
    per_seed = release.paired_markdown(ok, error="final", order=ORDER, unpaired=True) if len(ok) else ""
    return (
        what(study)
        + "\n"
        + point(study, df)
        + "\n"
        + study.provenance(df)
        + "\n\nWhat is kept of the planned sweep:\n\n"
        + missing(df)
        + "\n## What the records show\n\n"
        + findings(df)
        + reproduced(study, df)
        + equivalents_note(df)
        + levers_target(study)
        + rough_summary(rough)
        + f"\n*The seeds are not held out*: `{METHOD}`'s groups were chosen by what they did on these "
        "tasks at these seeds (the screen's seeds and the method's own trials), so its counts here are an "
        "optimistic estimate of what it does on seeds it was not chosen on; a held-out sweep (seeds "
        f"{HELDOUT_SEEDS}, "
        "kept apart from these: *On seeds it was not chosen on*, below) is the unbiased one.\n"
        + "\n## Where the method falls short\n\n"
        + f"Per task, `{METHOD}`'s trials that did not finish cleanly, and what kept them from it (from the "
        "records: the milestones they missed; the object error where the contact span ends against the "
        "trial's end). The timelines of the trials that failed are under *Failures*.\n\n"
        + shortfall(df, study)
        + "\n## Where each option rescues the method and where it costs it\n\n"
        + rescues(study, df)
        + "\n## Per task and method\n\n"
        "Trials: those that ran to their end (a diverged trial counts, not completed), of the planned seeds. "
        "The object error is the free body's position (mm), or on the doorknob its articulations "
        "(x 1e-3 rad, or m for a slide); medians over the trials. The target is the issue's: "
        f"≥ {TARGET_COMPLETED} of {TARGET_SEEDS} seeds completed and ≥ {TARGET_CLEAN} of {TARGET_SEEDS} "
        "finished cleanly; with fewer seeds kept, whether it can still be met.\n\n"
        + table(df)
        + "\n"
        + cost_note(df)
        + "\n## Each step, on the same seeds\n\n"
        "Each method against the one it adds a step to ("
        + "; ".join(f"`{a}` against `{b}`" for a, b in pairs())
        + "), per task on the seeds both have: the counts, the difference in rate (the method − the other, "
        "points) with Newcombe's 95 % interval, Barnard's exact two-sided p (`analysis.inference`; the seeds "
        "are paired, the test treats the two sides as independent samples) and the smallest p any outcome "
        "could give at these counts; the seeds only one of them completes (or finishes cleanly).\n\n"
        + (side + "\n" if side else "")
        + notes
        + "\n## On seeds it was not chosen on\n\n"
        + heldout(study, df)
        + "\n## Levers on the method, full trials\n\n"
        + levers_section(study, df)
        + "\n## The planning model and the lift\n\n"
        + from_figures(study, LIFTS, lift_replays, "Not replayed yet.\n")
        + finer_models(df)
        + finer_levers(lever_frame(study), with_heldout(study, df))
        + "\n## The planning model's physics\n\n"
        + from_figures(study, PHYSICS, model_physics, "Not replayed yet.\n")
        + "\n## What a plan costs with each planning model\n\n"
        + from_figures(
            study,
            PLAN_COSTS,
            plan_costs,
            "Not benchmarked yet (`python studies/method/plan_benchmark.py`).\n",
        )
        + "\n## Who is on the object while the grasp is won\n\n"
        + from_figures(
            study,
            GRASP_CONTACTS,
            lambda rows: grasp_contacts(rows, study),
            "Not measured yet (`python studies/method/grasp_contacts.py`).\n",
        )
        + "\n## When the reference closes its grasp\n\n"
        + from_figures(
            study,
            REFERENCE_GRASPS,
            reference_grasps,
            "Not measured yet (`python studies/method/reference_grasp.py`).\n",
        )
        + "\n## When the hand first touches the object\n\n"
        + from_figures(
            study,
            FIRST_TOUCHES,
            first_touches,
            "Not measured yet (`python studies/method/first_touch.py`).\n",
        )
        + links_screen()
        + "\n## Where a seed's outcome is decided\n\n"
        + from_figures(
            study,
            DECIDED,
            lambda rows: decided(rows, study),
            "Not measured yet (`python studies/method/decided.py`).\n",
        )
        + "\n## Where a lost object lies\n\n"
        + from_figures(
            study, FAILED_REST, failed_rest, "Not measured yet (`python studies/method/failed_rest.py`).\n"
        )
        + "\n## Where the object rests before the hand arrives\n\n"
        + from_figures(study, SETTLES, settles, "Not run yet (`python studies/method/settle.py`).\n")
        + paced_lift(study, df)
        + retried_grasps(study, df)
        + error_effort(study, df)
        + "\n## What holds the carried object\n\n"
        + grasp_section(study)
        + "\n## Letting go\n\n"
        + release_section(study)
        + "\n### Where the object is set down\n\n"
        + set_down(study)
        + paced_release(study, df)
        + "\n## The doorknob on a slide with friction\n\n"
        + rough_slide(rough, df, study)
        + "\n## The doorknob's release, screened\n\n"
        + release_screen(study)
        + "\n## Online, in wall-clock time\n\n"
        + online(study)
        + "\n## At another latency\n\n"
        + latency_section(study, df)
        + "\n## On a machine of N threads\n\n"
        + loop_section(study, df)
        + "\n## Per seed\n\n"
        + (
            "The final object error (mm, or x 1e-3 on the doorknob) and how each trial ended (clean = "
            "finished cleanly, done = completed but not settled, failed = not completed); blank: no trial "
            "that counts (not run yet, or among the records that do not count, above).\n\n" + per_seed
            if per_seed
            else "Not measured yet.\n"
        )
        + "\n## Failures\n\n"
        "Every trial that did not complete or lost contact (a TTF failure), with its timeline "
        "(`python -m analysis.timeline`) where its time series is on this machine or the figure is kept; "
        "the time series are not kept in git.\n\n" + failures(study, df)
    )


def every_task(ok: pd.DataFrame, methods: list[str]) -> str | None:
    """Of ``methods``, the one that does every planned task best: each has all :data:`TARGET_SEEDS` of the
    sweep's seeds on every task (``ok``: the counted trials, stand-ins in), ranked by its worst task's
    lower bound of the 95 % Wilson interval of completing, then of finishing cleanly; ``None`` where none
    has every task's seeds."""
    from analysis.inference import wilson

    tasks, seeds_ = plan()
    best, key = None, None
    for method in methods:
        cells = [cell(ok, task, method) if len(ok) else ok for task in tasks]
        cells = [g[g["seed"].isin(seeds_)] for g in cells]
        if not tasks or any(len(g) < TARGET_SEEDS for g in cells):
            continue
        worst = tuple(
            min(wilson(int(g[col].sum()), len(g))[0] for g in cells)
            for col in ("completed", "finished_cleanly")
        )
        if key is None or worst > key:
            best, key = method, worst
    return best


def glance(study) -> list[dict]:
    """Each of the study's methods that is a variant (:data:`ORDER`) per paper task, where it has trials;
    the paper tasks' default marked, and the one method that does every task best (:func:`every_task`)."""
    ok = counted(frame(study))
    default_tasks = {t for t, v in task_defaults("variant").items() if v == METHOD}
    methods = [m for m in ORDER if m != BASELINE and "+" not in m]
    one = every_task(ok, methods) if len(ok) else None  # (frame counts the stand-ins in)
    rows = []
    for task in plan()[0]:
        for method in methods:
            g = cell(ok, task, method) if len(ok) else ok
            if len(g):
                row = glance_row(
                    f"paper {task}",
                    f"`preset=paper_32samples_calibrated variant={method}`"
                    + (" (the default)" if method == METHOD and task in default_tasks else "")
                    + (f" {ALL_TASKS}" if method == one else ""),
                    g.assign(compute=g["cpu_seconds"]),
                )
                if on := cost_on(g):  # whose seconds they are
                    row["median CPU-s per trial"] += f" on {on}"
                rows.append(row)
    return rows
