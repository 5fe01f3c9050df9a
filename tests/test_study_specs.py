"""The study specs of the operating point, the stapler and the release: what they read, how they label it."""

from __future__ import annotations

from pathlib import Path

import pytest

from analysis.study import Study

RELEASE = Path(__file__).resolve().parent.parent / "studies" / "release" / "records"


@pytest.mark.skipif(not (RELEASE / "release_flat").is_dir(), reason="no release records here")
def test_release_flat_records_are_shown_as_release_flat_and_no_others() -> None:
    """Design 8's records say ``release_backoff`` (made with ``sampler.release_backoff=0``): the report shows
    exactly those records, and no design-7 record, as ``release_flat``."""
    study = Study("release")
    df = study.spec.relabel(study.records())
    flat = {Path(p).parent.parent.name for p in df.loc[df["variant"] == "release_flat", "record_path"]}
    assert flat == {"release_flat", "release_flat_lite"}
    made_flat = df["record_path"].str.contains("/release_flat")
    assert (df.loc[made_flat, "variant"] == "release_flat").all()


def test_the_glance_rows_name_a_configuration_and_its_counts() -> None:
    for name in ("operating_point", "stapler", "release", "method"):
        for row in Study(name).glance():
            assert row["configuration"] and row["task"].startswith("paper ")
            done, n = map(int, row["completed"].split("/"))
            clean, n2 = map(int, row["finished cleanly"].split("/"))
            assert n == n2 > 0 and clean <= done <= n
            # the seconds, and for the method study the processor they were measured on
            seconds, *on = row["median CPU-s per trial"].split(" on ")
            assert float(seconds) > 0 and all(p.startswith(("AMD", "Intel")) for p in on)


def test_the_method_study_reads_its_groups_and_plan_from_conf_and_judges_the_target() -> None:
    """studies/method: the method is the paper tasks' default variant, its groups from its
    ``conf/variant`` file, the plan from ``experiment=method``; the issue's target (>= 9/10 completed,
    >= 8/10 clean) is met, missed or still open by the seeds left."""
    spec = Study("method").spec
    assert spec.METHOD == spec.default_method() in spec.ORDER
    assert set(spec.task_defaults("variant").values()) == {spec.METHOD}
    assert {g: m for g, m, _ in spec.groups("grasp_release")} == {
        "wrist": "acquire",
        "shaping": "clearance",
        "release": "flat",
    }
    assert {g: m for g, m, _ in spec.groups("grasp_release_ahead")} == {
        "wrist": "acquire",
        "shaping": "clearance",
        "release": "flat",
        "compensation": "predict",
    }
    # the method's groups, read from its conf/variant file, are those its name stands for in the label map
    from contactmpc.labels import NAMED_METHODS

    assert {g: m for g, m, _ in spec.groups()} == {
        g: m for g, m in NAMED_METHODS[spec.METHOD].items() if g != "variant"
    }
    assert all(text for _, _, text in spec.groups())
    tasks, seeds = spec.plan()
    assert tasks == ["doorknob", "apple", "bottle", "stapler"] and seeds == list(range(10))
    assert spec.variants() == list(spec.ORDER)
    after = spec.ORDER[spec.ORDER.index(spec.METHOD) + 1 :]
    assert after == (
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
    assert spec.others() == [v for v in spec.ORDER if v != spec.METHOD] and "full" in spec.others()
    assert spec.target(9, 8, 10) == "met" and spec.target(10, 7, 10) == "missed"
    assert spec.target(9, 8, 9).startswith("met (already") and spec.target(2, 1, 4).startswith(
        "missed (already"
    )
    assert spec.target(4, 4, 4).startswith("open: 4 of 10 seeds kept; of the 6 left, needs 5 more completed")
    # Barnard's test at 10 a side: 0 of 10 against 4 of 10 is the least difference it calls (p < 0.05)
    assert spec.smallest_difference(0, 10) == 4 and spec.smallest_difference(1, 2) is None


def test_the_method_study_compares_costs_on_one_processor_and_says_why_a_trial_is_not_clean() -> None:
    """The costs come from the processor most records ran on (another's seconds are not compared); the
    shortfall names the milestones a trial missed and whether the object moved on after the span."""
    import pandas as pd

    spec = Study("method").spec
    df = pd.DataFrame({"processor": ["A", "B", "B", None]})
    assert spec.cost_processor(df) == "B"
    assert spec.cost_processor(pd.DataFrame({"processor": ["B", "A"]})) == "A"  # a tie: the first by name
    # two processors of one brand string are told apart by the host's family and model
    assert spec.cost_processor(pd.DataFrame({"cpu": ["A", "A"]})) is None
    assert spec.cost_processor(pd.DataFrame({"x": [1]})) is None
    method, seeds = spec.METHOD, [0, 1, 2]
    trials = pd.DataFrame(
        {
            "task": ["doorknob"] * 3,
            "variant": [method] * 3,
            "seed": seeds,
            "status": ["ok"] * 3,
            "counted": [True] * 3,
            "completed": [True, True, False],
            "finished_cleanly": [True, False, False],
            "milestone_pulled": [True, True, False],
            "object_articulation_error_span_final": [0.01, 0.02, 0.2],
            "_final": [0.01, 0.3, 0.2],
        }
    )
    trials.attrs["error_kinds"] = {"doorknob": "articulation"}
    text = spec.shortfall(trials)
    assert "1 of 3 finished cleanly" in text
    assert "not completed on seed 2 (`pulled` not reached on 2)" in text
    assert "completed but not settled on seed 1" in text and "median 20 x 1e-3" in text
    assert "at the trial's end 300" in text and "the object moved on after the hand let go" in text


def test_the_method_study_reads_the_target_as_a_chance_over_new_seeds() -> None:
    """The rates the target asks for meet it that often (binomial); the chance that new seeds meet it
    rises with the clean trials, is near 1 after many clean ones and near 0 after many failures, and sums
    with the chance of missing it to the whole predictive (the three outcomes' counts over ten seeds)."""
    from scipy.stats import binom, dirichlet_multinomial

    spec = Study("method").spec
    n = spec.TARGET_SEEDS
    for k in (spec.TARGET_COMPLETED, spec.TARGET_CLEAN):
        p = spec.needed_rate(k)
        assert 0 < p < 1 and abs(binom.sf(k - 1, n, p) - spec.TARGET_ODDS) < 1e-9
    assert spec.needed_rate(spec.TARGET_COMPLETED) > spec.needed_rate(spec.TARGET_CLEAN)
    chances = [spec.meets_target_chance(c, 2, 20 - c) for c in (0, 6, 12, 18)]
    assert chances == sorted(chances) and chances[0] < 0.01
    assert spec.meets_target_chance(200, 0, 0) > 0.95 and spec.meets_target_chance(0, 0, 200) < 1e-6
    alpha = [13 + 1, 4 + 1, 3 + 1]
    total = sum(
        dirichlet_multinomial.pmf([a, b, n - a - b], alpha, n) for a in range(n + 1) for b in range(n - a + 1)
    )
    assert abs(total - 1) < 1e-9 and 0 < spec.meets_target_chance(13, 4, 3) < 1


def test_the_method_study_ranks_the_methods_by_their_chance_on_every_task() -> None:
    """Only a method with ten seeds on every planned task is ranked; its last column is the product of its
    tasks' chances, and the likelier method comes first."""
    import pandas as pd

    spec = Study("method").spec
    tasks = spec.plan()[0]
    rows = []
    for method, clean in (("full", 7), ("grasp_held_retract", 9), ("grasp_held_eased", 10)):
        for task in tasks if method != "grasp_held_eased" else tasks[:-1]:
            for seed in range(10):
                rows.append(dict(task=task, variant=method, seed=seed, completed=True,
                                 finished_cleanly=seed < clean))  # fmt: skip
    text = spec.every_task_odds(pd.DataFrame(rows), pd.DataFrame())
    ranked = [line for line in text.splitlines() if line.startswith("| `")]
    assert [line.split("`")[1] for line in ranked] == ["grasp_held_retract", "full"]
    chance = {c: spec.meets_target_chance(c, 10 - c, 0) for c in (7, 9)}
    for line, c in zip(ranked, (9, 7), strict=True):
        assert line.rstrip(" |").endswith(f"{100 * chance[c] ** len(tasks):.0f} %")
        assert line.count(f"10 / {c} of 10 ({100 * chance[c]:.0f} %)") == len(tasks)
    assert spec.every_task_odds(pd.DataFrame(rows[: 10 * len(tasks) - 1]), pd.DataFrame()) == ""


def test_the_method_study_says_where_failed_trials_part_from_a_clean_trial_of_their_seed() -> None:
    """decided: per task and kind of failure, the failed trials counted by when they parted from their clean
    twin (before the first expected contact, in the grasp window, later) and by how close to the reference's
    lift their object left it; no rows, one line."""
    import pandas as pd

    spec = Study("method").spec
    rows = pd.DataFrame(
        dict(task="stapler", seed=[0, 1, 2, 3], run="r", twin="t", completed=[False, False, False, True],
             first_contact=10.0, lift=12.0, parted=[9.0, 10.5, 13.0, 11.0], off=[12.2, 12.4, 14.0, None])
    )  # fmt: skip
    text = spec.decided(rows)
    row = next(line for line in text.splitlines() if line.startswith("| stapler | not completed"))
    cells = [c.strip() for c in row.strip("|").split("|")][2:]
    assert cells == ["3", "1", "1", "1", "+0.50", "+2.40", "+2.00"]
    assert "2 of 3 trials not completed followed a clean trial" in text
    assert "and 2 of 3 lost the object within 0.5 s of the reference's lift" in text
    done = next(line for line in text.splitlines() if line.startswith("| stapler | completed, not clean"))
    assert "never off" in done
    assert spec.decided(rows.iloc[:0]).count("\n") == 1


def test_decided_parts_two_paths_where_the_hand_or_the_object_first_differs(monkeypatch) -> None:
    """studies/method/decided.py: two series part at the first sample where a hand joint differs by more than
    HAND or an object coordinate by more than OBJECT; never where they stay within those; not compared
    where their sample times differ (another pacing)."""
    import importlib
    import sys

    import numpy as np

    folder = Path(__file__).resolve().parent.parent / "studies" / "method"
    monkeypatch.syspath_prepend(str(folder))
    decided = importlib.import_module("decided")
    t = np.arange(10) * 0.1
    a = dict(time=t, hand_qpos=np.zeros((10, 3)), object_qpos=np.zeros((10, 7)))
    b = {k: v.copy() for k, v in a.items()}
    b["hand_qpos"][:, 1] += 0.5 * decided.HAND  # within: the same path
    b["object_qpos"][:, 2] += 0.5 * decided.OBJECT
    assert decided.parted(a, b) is None
    b["object_qpos"][6:, 2] += decided.OBJECT
    assert decided.parted(a, b) == t[6]
    b["hand_qpos"][4:, 0] += 2 * decided.HAND
    assert decided.parted(a, b) == t[4]
    assert decided.parted(a, dict(b, time=t + 0.05)) is None
    sys.modules.pop("decided", None)


def test_the_method_studys_after_span_figure_draws_each_trial_from_its_time_series(tmp_path) -> None:
    import numpy as np
    import pandas as pd

    spec = Study("method").spec
    rows = []
    for seed in (0, 1):
        run = tmp_path / f"run{seed}"
        run.mkdir()
        t = np.linspace(0.0, 20.0, 101)
        np.savez(run / "timeseries.npz", time=t, object_articulation_error=0.01 * np.maximum(t - 10.0, 0))
        rows.append({"record_path": str(run / "trial.json"), "seed": seed, "contact_span_end": 10.0,
                     "finished_cleanly": seed == 0})  # fmt: skip
    out = tmp_path / "after.png"
    spec.after_span_figure(out, "doorknob", pd.DataFrame(rows), "articulation")
    assert out.is_file() and out.stat().st_size > 1000


def test_online_runs_name_the_slowdowns_each_method_was_tried_at() -> None:
    from analysis.online import by_slowdown

    def run(task, slowdown, completed):
        return {"task": task, "variant": "m", "completed": completed, "replan_interval_median": 0.1,
                "config": {"job": {"slowdown": slowdown}}}  # fmt: skip

    records = [run("a", 1, False), run("b", 1, True), run("b", 1, False), run("b", 2, True)]
    records += [run("b", 2, True), run("c", 1, True), run("c", 1, True)]
    table, prose, _ = by_slowdown(records)
    assert table["task and variant"] == ["a m", "b m", "c m"]
    assert table["slowdown 2 (4 threads): completed, replan ms"] == ["—", "2 of 2, 100", "—"]
    assert prose == [
        "a m: no slowdown tried (1) completes every run",
        "b m: every run completes from slowdown 2 (real time on 4 threads of this CPU)",
        "c m: every run completes in real time on 2 threads",
    ]


def test_the_method_studys_latency_section_sets_each_trial_beside_its_seed_at_the_calibrated_latency(
    tmp_path, monkeypatch
) -> None:
    """latency_section: each run beside the same method's trial of its seed at the calibrated latency, the
    sweep's or a held-out one (heldout_frame); a line per condition with Barnard's test."""
    import json
    from types import SimpleNamespace

    import pandas as pd

    spec = Study("method").spec
    for seed, done, reset in ((0, False, None), (1, True, None), (0, True, 3.0)):
        run = tmp_path / "latency" / f"run{seed}{reset}"
        run.mkdir(parents=True)
        record = {"task": "paper_stapler", "seed": seed, "latency": 0.06, "replan_interval": 0.17,
                  "completed": done, "finished_cleanly": done, "ttf": 1.0,
                  "config": {"planner": {"approach_reset": reset}}}  # fmt: skip
        (run / "trial.json").write_text(json.dumps(record))
    base = pd.DataFrame({"task": ["stapler"], "variant": [spec.METHOD], "seed": [0], "counted": [True],
                         "completed": [True], "finished_cleanly": [False]})  # fmt: skip
    held = base.assign(seed=[12], finished_cleanly=[True])  # a held-out trial at the calibrated latency
    monkeypatch.setattr(spec, "heldout_frame", lambda study, chosen: (held, held, held.iloc[:0]))
    run = tmp_path / "latency" / "run12"
    run.mkdir(parents=True)
    record = {"task": "paper_stapler", "seed": 12, "latency": 0.06, "replan_interval": 0.17,
              "completed": False, "finished_cleanly": False, "ttf": 0.2}  # fmt: skip
    (run / "trial.json").write_text(json.dumps(record))
    text = spec.latency_section(SimpleNamespace(dir=tmp_path), base)
    assert "| stapler | 12 | 60 | 170 | — | no / no | 0.20 | yes / yes |" in text
    assert "| stapler | 0 | 60 | 170 | — | no / no | 1.00 | yes / no |" in text
    assert "| stapler | 1 | 60 | 170 | — | yes / yes | 1.00 | — |" in text
    assert "| stapler | 0 | 60 | 170 | 3 | yes / yes | 1.00 | yes / no |" in text
    lever = "- stapler, 60 ms, a plan every 170 ms, the approach reset 3 s before the first contact "
    assert lever + "(`planner.approach_reset`): 1 of 1 completed, 1 cleanly; the same seeds at 170 ms" in text
    summary = "- stapler, 60 ms, a plan every 170 ms: 1 of 3 completed, 1 cleanly; the same seeds at 170 ms: "
    assert summary + "2 of 2 completed, 1 cleanly (completion, Barnard's exact test: p = " in text
    assert "No such trial" in spec.latency_section(SimpleNamespace(dir=tmp_path / "none"), base)


def test_the_method_studys_machine_section_sets_per_plan_trials_beside_the_fixed_latency_and_online(
    tmp_path, monkeypatch
) -> None:
    """loop_section: per task and thread count, the per-plan trials' counts beside the same seeds at the
    calibrated fixed latency (Barnard's test) and, on 2 threads, the method's online runs at slowdown 1 in
    real time (not those held or paced); the seeds that differ from the fixed latency named."""
    import json
    from types import SimpleNamespace

    import pandas as pd

    spec = Study("method").spec

    def write(folder: str, name: str, record: dict) -> None:
        run = tmp_path / folder / name
        run.mkdir(parents=True)
        (run / "trial.json").write_text(json.dumps(record))

    for threads, seed, done in ((7, 0, True), (7, 1, True), (2, 0, False), (2, 1, True)):
        planner = {"latency_per_plan": True, "latency_model": {"threads": threads}}
        lat = {"0.170": 10, "0.043": 90} if threads == 7 else {"0.593": 5, "0.148": 60}
        write("loop", f"t{threads}s{seed}", {"task": "paper_stapler", "seed": seed, "completed": done,
              "finished_cleanly": done, "ttf": 1.0 if done else 0.3, "cpu_seconds": 100.0 * threads,
              "plan_latencies": lat, "config": {"planner": planner}, "cpu": "A"})  # fmt: skip
    other = {"task": "paper_stapler", "seed": 3, "completed": True, "config": {"planner": {}}}
    write("loop", "fixed", other)  # another loop: left out
    for seed, clean in ((0, True), (1, False)):  # a lever on the method in the 2-thread loop
        planner = {"latency_per_plan": True, "latency_model": {"threads": 2}}
        write("loop", f"lever{seed}", {"task": "paper_stapler", "seed": seed, "variant": spec.METHOD,
              "grip": "squeeze", "completed": True, "finished_cleanly": clean, "cpu": "A",
              "cpu_seconds": 300.0, "plan_latencies": {"0.593": 5, "0.148": 60},
              "config": {"planner": planner}})  # fmt: skip
    for seed, done, held in ((0, True, None), (1, False, None), (2, True, 0.17)):
        run = {"task": "paper_stapler", "seed": seed, "slowdown": 1.0, "completed": done,
               "finished_cleanly": False, "apply_after": held}  # fmt: skip
        write("online", f"o{seed}", run)
    base = pd.DataFrame({"task": ["stapler"] * 2, "variant": [spec.METHOD] * 2, "seed": [0, 1],
                         "counted": [True] * 2, "completed": [True, False],
                         "finished_cleanly": [True, False], "cpu": ["A", "B"]})  # fmt: skip
    monkeypatch.setattr(spec, "heldout_frame", lambda study, chosen: (base.iloc[:0],) * 3)
    drawn = []
    study = SimpleNamespace(
        dir=tmp_path, draw=lambda name, make, alt: drawn.append(name) or make(tmp_path / name)
    )
    text = spec.loop_section(study, base)
    assert drawn == ["loop.png"] and (tmp_path / "loop.png").stat().st_size > 1000
    row7 = f"| stapler | `{spec.METHOD}` | 7 | 170 / 43 | 0 and 1 | 2 of 2 | 2 | 1.00 | 700 | 1 of 2 / 1 | "
    assert row7 in text and text.split(row7)[1].split("\n")[0].endswith("| — |")  # no online beside 7
    row2 = f"| stapler | `{spec.METHOD}` | 2 | 593 / 148 | 0 and 1 | 1 of 2 | 1 | 0.65 | 200 | 1 of 2 / 1 | "
    assert row2 in text and text.split(row2)[1].split("\n")[0].endswith("| 1 of 2 / 0 |")
    apart = "(1 of 2 trials ran on another processor than their seed's at the fixed latency: for those only"
    assert (
        "- stapler, 7 threads: completed only here on no seed; only at the fixed 170 ms on no seed " + apart
        in text
    )
    assert (
        "- stapler, 2 threads: completed only here on no seed; only at the fixed 170 ms on seed 0 " + apart
        in text
    )
    assert "The trials ran on A (6)." in text
    lever = "| stapler | `grip=squeeze` | 2 | 593 / 148 | 0 and 1 | 2 of 2 | 1 | 1 of 2 / 1 | "
    assert lever in text and text.split(lever)[1].split("\n")[0].endswith("| seed 0 | seed 1 | 300 |")
    assert f"`{spec.METHOD}+grip=squeeze`" not in text  # not a row of the method's own table
    assert "No such trial" in spec.loop_section(SimpleNamespace(dir=tmp_path / "none", draw=None), base)


def test_the_machine_section_sets_the_models_prices_beside_the_benchmarks_measured_plans(tmp_path) -> None:
    """measured_prices: the per-plan model's grasp / later prices on each thread count beside the plan
    benchmark's (rollout=paper) over the same threads, and on how many tasks the plans cost more."""
    from types import SimpleNamespace

    spec = Study("method").spec
    (tmp_path / "figures").mkdir()
    rows = ["task,rollout,state,plan_cpu_seconds", "paper_apple,paper,approach,1.4",
            "paper_apple,paper,contact,0.5", "paper_apple,fine,approach,9.0",
            "paper_stapler,paper,approach,1.0", "paper_stapler,paper,contact,0.2"]  # fmt: skip
    (tmp_path / "figures" / spec.PLAN_COSTS).write_text("\n".join(rows) + "\n")
    text = spec.measured_prices(SimpleNamespace(dir=tmp_path), [7, 2])
    assert "a grasp / later plan 170 / 43 ms on 7, 592 / 148 ms on 2 threads" in text
    assert "apple 200 / 71 ms on 7, 700 / 250 ms on 2; stapler 143 / 29 ms on 7, 500 / 100 ms on 2." in text
    assert "more than the model charges on 1 of 2 tasks" in text and "a grasp plan on 1 of 2" in text
    assert spec.measured_prices(SimpleNamespace(dir=tmp_path / "none"), [7]) == ""


def test_the_method_study_reads_how_fast_a_slide_leaves_the_hand(tmp_path) -> None:
    """leaving_speed: the slide's mean speed from 0.2 to 1.2 s after the last contact, against the
    settle tolerance over the time left; None without a contact or a second after it."""
    import numpy as np

    spec = Study("method").spec
    t = np.arange(0.0, 11.0 + 1e-9, 0.1)
    q = np.where(t <= 1.0, 0.25, 0.25 - 0.1 * (t - 1.0))[:, None]  # let go at 1 s, then 0.1 m/s back
    contacts = np.zeros((len(t), 3), bool)
    contacts[t <= 1.0, 1] = True
    np.savez(tmp_path / "a.npz", time=t, object_qpos=q, contacts=contacts)
    speed, bound = spec.leaving_speed(tmp_path / "a.npz", settle=0.05)
    assert speed == pytest.approx(0.1) and bound == pytest.approx(0.05 / 10.0)
    np.savez(tmp_path / "b.npz", time=t, object_qpos=q, contacts=np.zeros_like(contacts))
    assert spec.leaving_speed(tmp_path / "b.npz", settle=0.05) is None
    late = contacts.copy()
    late[t > 10.5, 0] = True  # touched until less than 1.2 s before the end
    np.savez(tmp_path / "c.npz", time=t, object_qpos=q, contacts=late)
    assert spec.leaving_speed(tmp_path / "c.npz", settle=0.05) is None
    assert spec.leaving_speed(tmp_path / "missing.npz", settle=0.05) is None


def test_fig3_gives_more_seeds_to_the_cells_whose_completion_differs_by_two_or_more() -> None:
    """more_seeds_cells: under the text's reading, at seeds 0-5, a full method and an ablation whose
    completed counts differ by 2 or more both get seeds 6-9; 1 apart, or the authors' code's, do not;
    the trials at seeds 6-9 do not change which cells are chosen."""
    import pandas as pd

    spec = Study("fig3_paper").spec
    rows = []
    done = {
        ("apple", "full"): 6,
        ("apple", "no_contact"): 4,
        ("apple", "joint_space"): 5,
        ("bottle", "full"): 3,
    }
    done |= {("bottle", "no_contact"): 2, ("bottle", "joint_space"): 2}
    for (task, variant), k in done.items():
        for fid in ("paper", "authors_code"):
            for seed in range(10 if (task, variant) == ("bottle", "joint_space") else 6):
                completed = seed < k if fid == "paper" and seed < 6 else seed % 2 == 0
                rows.append(dict(fidelity=fid, task=task, variant=variant, seed=seed, status="ok", ttf=1.0,
                                 completed=completed))  # fmt: skip
    df = pd.DataFrame(rows)
    assert spec.more_seeds_cells(df) == [("apple", "full"), ("apple", "no_contact")]
    df.loc[
        (df["task"] == "bottle") & (df["variant"] == "full") & (df["fidelity"] == "paper"), "completed"
    ] = True
    assert spec.more_seeds_cells(df) == [
        ("apple", "full"), ("apple", "no_contact"), ("bottle", "full"), ("bottle", "no_contact"),
        ("bottle", "joint_space"),
    ]  # fmt: skip


def test_the_method_study_says_how_an_unsettled_free_object_ended() -> None:
    """endings: toppled (under 45° off where the span ends, 60° or more at the end), already off where
    the span ends (outside the task's tolerances), or outside only at the end."""
    import math

    import pandas as pd

    spec = Study("method").spec
    deg = math.radians
    rows = [
        dict(seed=1, object_rotation_error_span_final=deg(20), final_object_rotation_error=deg(90),
             object_position_error_span_final=0.02),
        dict(seed=2, object_rotation_error_span_final=deg(99), final_object_rotation_error=deg(99),
             object_position_error_span_final=0.4),
        dict(seed=3, object_rotation_error_span_final=deg(10), final_object_rotation_error=deg(12),
             object_position_error_span_final=0.2),
        dict(seed=4, object_rotation_error_span_final=deg(21), final_object_rotation_error=deg(16),
             object_position_error_span_final=0.036),
    ]  # fmt: skip
    found = spec.endings(pd.DataFrame(rows), "bottle")
    assert found == {"toppled": [1], "off": [2, 3], "outside": [4]}
    assert spec.endings(pd.DataFrame(rows), "no_such_task") == {}


def test_the_method_study_s_online_row_says_how_many_trials_ran_at_once() -> None:
    """_online_row: a run's row ends with the trials running at once while it ran (its record's
    concurrent_trials), a dash for a record without it, then when its planning model switched."""
    spec = Study("method").spec
    run = {"task": "paper_apple", "variant": spec.METHOD, "seed": 0, "slowdown": 1.0, "real_time_factor": 1.0,
           "replan_interval_median": 0.1, "plan_latency_median": 0.1, "completed": True,
           "finished_cleanly": False, "ttf": 1.0}  # fmt: skip
    assert spec._online_row(run | {"concurrent_trials": 5}).endswith("| yes | no | 1.00 | 5 | — |")
    assert spec._online_row(run).startswith(f"| apple | {spec.METHOD} | 0 | 1 |")
    assert spec._online_row(run).endswith("| 1.00 | — | — |")
    # ... then when its planning model switched, after the first expected contact (switch_timestep)
    switching = run | {"contact_span_start": 14.45, "switch_time": 16.78}
    assert spec._online_row(switching).endswith("| — | +2.33 |")
    assert spec._online_row(switching | {"switch_time": None}).endswith("| — | never |")
    # a run beside others is named apart from the same method's runs alone
    assert spec.online_method(run | {"concurrent_trials": 5}) == f"{spec.METHOD}, beside 4 other trials"
    assert spec.online_method(run | {"concurrent_trials": 2}) == f"{spec.METHOD}, beside 1 other trial"
    assert spec.online_method(run | {"concurrent_trials": 1}) == spec.online_method(run) == spec.METHOD


def test_the_method_study_names_an_online_run_on_another_processor_apart() -> None:
    """online_method: wall-clock runs on different processors are not counted together: a run on another
    processor than the usual one (the one most online runs ran on) is named with its processor."""
    spec = Study("method").spec
    milan = {
        "variant": spec.METHOD,
        "host": {"cpu": "AMD EPYC (AuthenticAMD, family 25, model 1, stepping 1)"},
    }
    genoa = milan | {"host": {"cpu": "AMD EPYC (AuthenticAMD, family 25, model 17, stepping 1)"}}
    assert spec.online_cpu(milan) == "AMD EPYC (family 25, model 1)"
    assert spec.online_cpu({"cpu": "AMD EPYC"}) == "AMD EPYC"  # a record without its host's
    assert spec.usual_cpu([milan, genoa, genoa]) == "AMD EPYC (family 25, model 17)"
    assert spec.usual_cpu([]) is None
    assert spec.online_method(milan, "AMD EPYC (family 25, model 17)") == (
        f"{spec.METHOD}, on AMD EPYC (family 25, model 1)"
    )
    assert spec.online_method(genoa, "AMD EPYC (family 25, model 17)") == spec.online_method(genoa)


def test_the_method_study_sets_online_methods_against_the_default_on_one_processor() -> None:
    """online_against: real-time runs alone on the machine, each method against the default method on the
    same processor and seeds (at least 5); other processors, slowdowns and busy runs stay apart."""
    spec = Study("method").spec
    cpu = {"host": {"cpu": "AMD EPYC (AuthenticAMD, family 25, model 1, stepping 1)"}}
    other = {"host": {"cpu": "AMD EPYC (AuthenticAMD, family 25, model 17, stepping 1)"}}

    def run(seed, variant, done, **more):
        clean = done and seed % 2 == 0
        return {"task": "paper_apple", "variant": variant, "seed": seed, "slowdown": 1.0, "completed": done,
                "finished_cleanly": clean, "concurrent_trials": 1, **cpu, **more}  # fmt: skip

    lever = f"{spec.METHOD}+effort=uniform"
    records = [run(s, spec.METHOD, s < 2) for s in range(6)] + [run(s, lever, s < 5) for s in range(6)]
    records += [run(s, lever, True, **other) for s in range(6)]  # no default-method runs on that CPU
    records += [run(s, lever, False, slowdown=2.0) for s in range(6)]
    records += [run(s, lever, False, concurrent_trials=3) for s in range(6)]
    text = spec.online_against(records)
    assert text.count("\n- ") == 1
    assert f"apple, on AMD EPYC (family 25, model 1), seeds 0-5: `{lever}` completed 5 of 6" in text
    assert f"`{spec.METHOD}` 2 and 1 (Barnard p = " in text
    assert spec.online_against(records[:6]) == ""


def test_the_method_study_names_each_screened_release_lever() -> None:
    """The release screen's levers, from their run folders' names: the method, release=still at each rest
    weight (cost.rest_weight beside it, in either order; its own 100 without), any other lever as it is."""
    spec = Study("method").spec
    folder = "experiment=method,job.start_time=47.5,{}seed=0,task=paper_doorknob/trial.json"
    lever = lambda s: spec._screen_lever(folder.format(s))  # noqa: E731
    assert lever("") == "" and spec._screen_name("") == f"`{spec.METHOD}`"
    assert spec._still_weight(lever("release=still,")) == 100.0
    assert spec._still_weight(lever("cost.rest_weight=30,release=still,")) == 30.0
    assert spec._screen_name(lever("cost.rest_weight=30,release=still,")) == "`release=still`, 30 s^2"
    assert spec._still_weight(lever("release=still_wrist,")) is None
    assert spec._screen_name(lever("release=still_wrist,")) == "`release=still_wrist`"
    order = sorted(["release=still_wrist", "cost.rest_weight=300 release=still", "", "release=still"],
                   key=spec._screen_order)  # fmt: skip
    assert order == ["", "release=still", "cost.rest_weight=300 release=still", "release=still_wrist"]


def test_the_method_study_sets_online_runs_held_to_the_calibrated_latency_beside_those_not(tmp_path) -> None:
    """held_online: per task and slowdown, the method's online runs held to the calibrated latency
    (apply_after) against its continuously replanning runs at the same slowdown; nothing without them."""
    import json
    from types import SimpleNamespace

    from contactmpc.labels import method_labels

    spec = Study("method").spec
    labels = method_labels({"variant": spec.METHOD}) | {"variant": spec.METHOD}
    latency = spec.planned_latency()
    runs = {"free0": (0.0, 0.0, True), "free1": (0.0, 0.0, False), "held0": (latency, latency, False)}
    runs |= {"held1": (latency, latency, True), "paced": (latency, 0.0, True)}
    for name, (paced, held, done) in runs.items():
        (tmp_path / "online" / name).mkdir(parents=True)
        record = labels | {"task": "paper_stapler", "slowdown": 6.0, "min_interval": paced,
                           "apply_after": held, "completed": done}  # fmt: skip
        (tmp_path / "online" / name / "trial.json").write_text(json.dumps(record))
    text = spec.held_online(SimpleNamespace(dir=tmp_path))
    assert text.startswith(
        f"- online, stapler, `{spec.METHOD}` at slowdown 6, each plan held to act 170 ms after its state"
    )
    assert ": 1 of 2 completed; continuous replanning at the same slowdown: 1 of 2 completed" in text
    assert spec.held_online(SimpleNamespace(dir=tmp_path / "none")) == ""


def test_the_method_screen_sets_the_method_at_two_latencies_beside_its_full_trials() -> None:
    """method_section: per latency and half of the seeds, the screen's counts beside the full trials', the
    screen against the full trials and 170 against 60 ms on every seed, and the two halves against each
    other."""
    import pandas as pd

    spec = Study("method_screen").spec
    assert spec.script()["method"][0] == [f"variant={spec.METHOD}"]  # the method is not a lever
    assert all(f"variant={spec.METHOD}" not in lever for lever in spec.script()["levers"])
    rows = []
    for seed in range(12):
        for lat in (170, 60):
            lifted = seed % 2 == 0 or lat == 170
            rows.append({"where": "screen", "latency_ms": lat, "seed": seed, "lifted": lifted,
                         "completed": lifted, "status": "ok", "ttf": 1.0, "cpu_seconds": 100.0})  # fmt: skip
    rows += [{"where": "full", "latency_ms": 60, "seed": s, "lifted": s < 6, "completed": s < 6,
              "status": "ok", "ttf": 1.0, "cpu_seconds": 300.0} for s in range(10)]  # fmt: skip
    df = pd.DataFrame(rows).assign(task="paper_stapler")
    df["half"] = [spec.HALVES[0] if s in spec.CHOSEN_ON else spec.HALVES[1] for s in df["seed"]]
    text = spec.method_section(df)
    assert (
        spec.method_section(pd.concat([df, df.assign(task="paper_apple", lifted=False)])) == text
    )  # stapler
    assert "| screen | 60 | 2 | 1/2 | 1/2 | 1.00 | 100 | 10 and 11 |" in text
    assert "- 60 ms, the screen (every seed) against the full trials: lifted 6 of 12 against 6 of 10" in text
    assert (
        "- the screen, 170 against 60 ms (every seed): lifted 12 of 12 against 6 of 12, a difference of +50"
        in text
    )
    assert "- the screen at 60 ms, seeds 0-9 against 10-19: lifted 5 of 10 against 1 of 2" in text
    assert spec.method_section(df[df["where"] == "full"]) == ""  # no screen trial yet: no section


def test_the_method_screen_reads_how_long_a_paced_reference_waited_from_the_time_series(tmp_path) -> None:
    """pacing_waits: from each paced trial's reference_time, how far it fell behind, whether it spent the
    whole budget, when it first waited against where the reference starts lifting, and how far the object
    rose while the reference stood still; None without a paced trial's time series."""
    import json

    import numpy as np
    import pandas as pd

    spec = Study("method_screen").spec
    t = np.round(np.arange(0, 4.0, 0.1), 10)
    reference = np.where(t < 2.0, t, np.maximum(2.0, t - 1.0))  # stands still from 2.0 to 3.0 s: 1 s behind
    expected = np.stack([np.zeros_like(t)] * 2 + [np.where(reference > 1.5, 0.1 * (reference - 1.5), 0.0)], 1)
    rows = []
    for seed, rise in ((0, 0.0), (1, 0.01)):
        run = tmp_path / str(seed)
        run.mkdir()
        obj = np.zeros((len(t), 3))
        obj[:, 2] = np.where(t > 2.0, rise, 0.0)
        np.savez(run / "timeseries.npz", time=t, reference_time=reference, object_qpos=obj,
                 expected_object_qpos=expected)  # fmt: skip
        (run / "trial.json").write_text(json.dumps({"config": {"planner": {"pace_budget": 1.0}}}))
        rows.append({"record_path": str(run / "trial.json"), "contact_span_start": 1.0, "status": "ok"})
    text = spec.pacing_waits(pd.DataFrame(rows))
    assert "the reference waited in 2 of 2, falling 1.0 s behind (median), the whole budget in 2" in text
    assert "the first wait began +0.40 s from where the reference starts lifting" in text  # 2.0 - (1.5 + 0.1)
    assert "the stapler rose 5.0 mm (median; 0.0 to 10.0)" in text
    assert (
        spec.pacing_waits(pd.DataFrame(rows).assign(record_path=str(tmp_path / "none" / "trial.json")))
        is None
    )


def test_the_method_screen_sets_each_lever_on_the_method_against_the_method_on_the_same_seeds() -> None:
    """method_lever names a trial by the options it changes on the method ("" for the method itself);
    method_levers_section: a table row per lever and the method, and per lever its counts against the
    method's at the calibrated latency on the seeds both have; no lever trial, no section."""
    import pandas as pd

    spec = Study("method_screen").spec
    assert spec.method_lever({"planner.acquire_until": 3.0}) == "until3"
    assert spec.method_lever({"sampler.root_sigma2": 4e-4}) == "wristvar0.0004"
    assert spec.method_lever({"planner.acquire_until": float("nan"), "sampler.root_sigma2": None}) == ""
    assert spec.method_lever({"cost.lambda_c": 3.0, "cost.surface_weight": 0.0}) == "contact3"
    assert spec.method_lever({"cost.lambda_o": 1.0, "cost.surface_weight": 1.0}) == "surface1"
    assert spec.method_lever({"pacing": "hold"}) == "pacehold" and spec.method_lever({"pacing": "none"}) == ""
    assert spec.method_lever({"sampler.root_rotation_sigma2": 0.0025}) == "wristrot0.0025"
    assert spec.method_lever({"pacing": "hold", "planner.pace_rate": 0.3}) == "pacehold rate0.3"
    assert spec.method_lever({"retarget": "wrist"}) == "retarget=wrist"
    assert spec.method_lever({"retarget": float("nan")}) == spec.method_lever({"retarget": "none"}) == ""
    assert spec.method_lever({"retarget": None, "cost.lambda_c": 3.0}) == "contact3"
    common = {"where": "screen", "latency_ms": spec.CALIBRATED_MS, "task": "paper_stapler", "status": "ok",
              "ttf": 1.0, "cpu_seconds": 100.0}  # fmt: skip
    method = pd.DataFrame([{**common, "seed": s, "lifted": s < 3, "completed": s < 3} for s in range(6)])
    method = pd.concat([method, method.assign(latency_ms=60, lifted=False, completed=False)])
    levers = pd.DataFrame([{**common, "seed": s, "lifted": True, "completed": True, "method_lever": "until3",
                            "cpu_seconds": 150.0} for s in range(4)])  # fmt: skip
    text = spec.method_levers_section(levers, method)
    assert f"| {spec.METHOD} until3 | paper_stapler | 4 | 4/4 | 4/4 |" in text
    assert f"| {spec.METHOD} | paper_stapler | 6 | 3/6 | 3/6 |" in text  # the calibrated latency's only
    assert "- paper_stapler, `until3` against the method, seeds 0-3: lifted 4 of 4 against 3 of 4" in text
    assert "CPU-s × 1.50" in text
    assert text.endswith("more often than the method on the same seeds (Barnard p < 0.05): none.\n")
    assert "`until3`: the grasp's phase" in text and "`contact3`" not in text  # only the levers it shows
    assert spec.method_levers_section(levers.iloc[:0], method) == ""
    # the apple's screen (SET=method_lift TASKS=paper_apple): its own rows and comparison, per task
    apple = lambda df: df.assign(task="paper_apple")  # noqa: E731
    method = pd.concat([method, apple(method).assign(lifted=False, completed=False)])
    levers = pd.concat([levers, apple(levers)])
    text = spec.method_levers_section(levers, method)
    assert f"| {spec.METHOD} until3 | paper_apple | 4 | 4/4 | 4/4 |" in text
    assert "- paper_apple, `until3` against the method, seeds 0-3: lifted 4 of 4 against 0 of 4" in text
    assert "- paper_stapler, `until3` against the method, seeds 0-3: lifted 4 of 4 against 3 of 4" in text
    assert text.endswith("(Barnard p < 0.05): `until3` (apple).\n")  # 4 of 4 against 0 of 4


def test_the_method_study_reads_the_replayed_releases_over_the_replays_near_their_trials() -> None:
    """release_replays: a seed whose own release let go before the span's end in replay is left out; per
    release, how many let go, their median speed and how many stayed under the bound."""
    import pandas as pd

    spec = Study("method").spec
    rows = [(0, "recorded", 0.2, 0.2), (1, "recorded", 0.3, 0.1), (2, "recorded", -0.1, 0.05),
            (0, "slow", 1.0, 0.002), (1, "slow", 1.0, 0.02), (2, "slow", 1.0, 0.001),
            (0, "grip held", float("nan"), float("nan")), (1, "grip held", 2.0, 0.001),
            (2, "grip held", float("nan"), float("nan"))]  # fmt: skip
    table = pd.DataFrame(rows, columns=["seed", "release", "let_go", "speed"]).assign(bound=0.003, before=0.5)
    text = spec.release_replays(table)
    assert "the 2 trials whose replayed own release let go after the span's end" in text
    assert "*recorded*: 2 of 2 let go, at 150 mm/s (median; 100-200), under the bound on 0 of 2" in text
    assert "*grip held*: 1 of 2 let go (the hand still on the knob on 1), at 1 mm/s" in text
    assert (
        "The slowest, *slow*, leaves the knob 14 times slower than the trial's own release and under " in text
    )
    assert text.endswith("under the bound on 1 of 2.")
    assert spec.release_replays(table.iloc[:0]) == ""
    # the replays name the method whose trials they replayed, read from the run folders' names
    run = "effort=acquire,experiment=method,seed={},task=paper_doorknob,variant=grasp_release_ahead"
    named = spec.release_replays(table.assign(record=[run.format(s) for s in table["seed"]]))
    assert named.startswith("  Replayed from the state of each trial of `grasp_release_ahead_acquire` 0.5 s")
    # the own release on a slide with friction: its own sentence, over the same trials, not among the releases
    rough = pd.DataFrame(
        [(0, "recorded", 0.3, 0.0, 0.010), (1, "recorded", 0.4, 0.0, 0.030), (2, "recorded", 0.2, 0.0, 0.5)],
        columns=["seed", "release", "let_go", "speed", "off"],
    ).assign(bound=0.003, before=0.5, friction=0.5)
    both = spec.release_replays(pd.concat([table.assign(friction=0.0, off=0.2), rough], ignore_index=True))
    assert both.startswith(text[:-1])  # the frictionless replays read as before
    assert both.endswith(
        "with 0.5 N of dry friction (`task.slide_friction`, not the authors' model) lets go on 2 of 2, the "
        "knob at 0 mm/s (median; 0), under the bound on 2 of 2, ending 20 mm from the reference's final "
        "position (median; 10-30; the tolerance is 50 mm)."
    )


def test_fig3_counts_the_cells_a_sweep_plans_not_those_it_has_reached() -> None:
    """A partial sweep holds fewer cells than it plans: its status says "2 of 6 cells", not "every cell"."""
    spec = Study("fig3_paper").spec
    assert spec._cells_planned("fig3_paper") == 12  # 4 tasks x 3 variants
    assert spec._cells_planned("fig3_paper_hard") == 6  # 2 challenges x 3 variants


def test_the_method_study_lets_the_trials_of_an_equivalent_config_stand_in_for_the_method(
    monkeypatch, tmp_path
) -> None:
    """with_equivalents: on a free object grasp_held_retract's missing seeds are grasp_held_eased's trials,
    on the doorknob the retract lever's, each marked with what it ran as; a seed the method ran itself keeps
    its own trial, and its record is checked against the stand-in's (equivalents_note counts agreement)."""
    import json

    import pandas as pd

    spec = Study("method").spec
    assert spec.EQUIVALENT["grasp_held_retract"]["free"] == ("records", "grasp_held_eased")
    lever = spec.EQUIVALENT["grasp_held_retract"]["joints"][1]

    def trial(task, variant, seed, clean, error, folder="records"):
        path = tmp_path / folder / f"{variant}-{task}-{seed}" / "trial.json"
        path.parent.mkdir(parents=True)
        path.write_text(json.dumps({"completed": True, "finished_cleanly": clean, "ttf": 1.0}))
        return dict(task=task, variant=variant, seed=seed, counted=True, completed=True,
                    finished_cleanly=clean, object_position_error_mean=error,
                    record_path=str(path))  # fmt: skip

    df = pd.DataFrame(
        [trial("apple", "grasp_held_retract", 0, True, 0.01)]
        + [trial("apple", "grasp_held_eased", s, s != 2, 0.01) for s in range(3)]
        + [trial("doorknob", "grasp_held_eased", s, False, 0.0) for s in range(2)]
    )
    levers = pd.DataFrame(
        [trial("doorknob", "grasp_held_eased+release=retract", s, True, 0.0, folder=lever) for s in range(2)]
    )
    monkeypatch.setattr(spec, "frame", lambda study, folder=None: levers)
    monkeypatch.setattr(spec, "lever_of", lambda path: lever)
    out = spec.with_equivalents(None, df)
    # the methods whose levers have no trial here add no rows, and leave the flags' columns boolean
    assert out["counted"].dtype == bool and (~out["counted"]).sum() == 0
    mine = out[out["variant"] == "grasp_held_retract"].set_index(["task", "seed"]).sort_index()
    assert list(mine.index) == [("apple", 0), ("apple", 1), ("apple", 2), ("doorknob", 0), ("doorknob", 1)]
    assert mine["stand_in"].isna().tolist() == [True, False, False, False, False]
    assert (
        mine.loc[("apple", 2), "stand_in"] == "grasp_held_eased"
        and not mine.loc[("apple", 2), "finished_cleanly"]
    )
    assert mine.loc[("doorknob", 1), "stand_in"] == lever and mine.loc[("doorknob", 1), "finished_cleanly"]
    assert out.attrs["equivalent_checks"] == [("grasp_held_retract", "apple", 0, "grasp_held_eased", True)]
    note = spec.equivalents_note(out)
    assert (
        "apple: seeds 1 and 2 by `grasp_held_eased`" in note and "(apple 0)" in note and "on 1 of 1" in note
    )


def test_a_method_a_lever_stands_in_for_is_built_on_the_variant_it_names(monkeypatch, tmp_path) -> None:
    """grasp_held_expected's trials are the lever reuse=elites_expected on grasp_held_retract's: the method
    chain and the free objects' base follow the lever's variant, and the lever's trials, named
    grasp_held_expected by the label map, are on grasp_held_retract in the levers' table."""
    import pandas as pd

    spec = Study("method").spec
    lever = "reuse=elites_expected variant=grasp_held_retract"
    assert spec.EQUIVALENT["grasp_held_expected"] == {"free": ("levers", lever), "joints": ("levers", lever)}
    chain = ["grasp_held_expected", "grasp_held_retract", "grasp_held_eased"]
    assert spec.built_chain("grasp_held_expected") == chain
    assert spec.built_chain("grasp_held_expected_long") == ["grasp_held_expected_long", *chain]  # two levers
    assert spec.built_chain("grasp_held_expected_paced") == ["grasp_held_expected_paced", *chain]
    assert "grasp_held_expected" in spec.built_chain(spec.METHOD)
    assert spec.free_base() == "grasp_held_eased" == spec.free_base("grasp_held_eased")
    folders = [f"experiment=method,{lever.replace(' ', ',')},seed=0,task=paper_apple",
               "carry=held,experiment=method,seed=0,task=paper_apple"]  # fmt: skip
    df = pd.DataFrame({"task": "apple", "seed": 0, "counted": True,
                       "variant": ["grasp_held_expected", "grasp_held_eased+carry=held"],
                       "record_path": [str(tmp_path / f / "trial.json") for f in folders]})  # fmt: skip
    monkeypatch.setattr(spec, "frame", lambda study, folder=None: df)
    ok = spec.lever_frame(None)
    assert ok["lever"].tolist() == [lever, "carry=held"]
    assert ok["on"].tolist() == ["grasp_held_retract", "grasp_held_eased"]
    assert spec.lever_names(ok)[0] == {lever: "grasp_held_retract", "carry=held": "grasp_held_eased"}


def test_the_method_study_counts_where_each_option_rescues_the_method_and_where_it_costs_it(
    monkeypatch,
) -> None:
    """rescues: seed by seed against the method, per task, the method's unclean trials an option finishes
    cleanly and its clean ones the option does not; per task where the method misses the target, the
    options that finish at least half of its failures, with what they lose elsewhere."""
    import pandas as pd

    spec = Study("method").spec

    def trials(task, variant, seeds, clean, **extra):
        return pd.DataFrame({"task": task, "variant": variant, "seed": list(seeds), "counted": True,
                             "completed": True, "finished_cleanly": clean, **extra})  # fmt: skip

    method = spec.METHOD
    other = next(m for m in spec.ORDER if m not in (method, spec.free_base()))
    df = pd.concat([
        trials("apple", method, range(10), [s < 5 for s in range(10)]),
        trials("stapler", method, range(10), True),
        trials("apple", other, range(5, 10), True),
        trials("stapler", other, range(10), False),
    ], ignore_index=True)  # fmt: skip
    lever = trials("apple", method, [5, 6, 0], [True, False, False], lever="planner.reuse=4")
    monkeypatch.setattr(spec, "heldout_frame", lambda study, chosen: (df.iloc[0:0], None, None))
    monkeypatch.setattr(spec, "lever_frame", lambda study: lever)
    rows = dict(spec.rescue_rows(None, df))
    assert rows[other] == {"apple": (5, 5, 0, 0), "stapler": (0, 0, 10, 10)}
    assert rows["planner.reuse=4"] == {"apple": (1, 2, 1, 1)}
    text = spec.rescues(None, df)
    assert f"| `{other}` |  | 5 of 5 / 0 of 0 |  | 0 of 0 / 10 of 10 |" in text
    assert (
        f"`{other}` finishes 5 of the 5 (stapler: loses 10 of 10 of the method's clean trials it ran)" in text
    )
    assert "`planner.reuse=4` finishes 1 of the 2 (run on no other task)" in text
    assert "**stapler**" not in text  # the method meets the target there


def test_the_method_study_sets_its_held_out_seeds_beside_the_seeds_it_was_chosen_on(monkeypatch) -> None:
    """heldout: per method and task, the held-out trials' completed and clean counts beside the sweep's, with
    the difference and Barnard's test; a line where the method has none (the rows are another's); without a
    held-out trial, a line that says so."""
    import pandas as pd

    spec = Study("method").spec

    def trials(seeds, done, clean, variant=spec.METHOD):
        return pd.DataFrame({"task": "stapler", "variant": variant, "seed": seeds, "counted": True,
                             "completed": done, "finished_cleanly": clean})  # fmt: skip

    chosen = trials(range(10), [True] * 10, [True] * 6 + [False] * 4)
    monkeypatch.setattr(
        spec, "frame", lambda study, folder=None: trials([10, 11], [True, False], [False] * 2)
    )
    text = spec.heldout(None, chosen)
    assert f"| `{spec.METHOD}` | stapler | 10 and 11 | 1 of 2 | 0 of 2 | 10 of 10 | 6 of 10 |" in text
    assert f"- `{spec.METHOD}`, stapler, completed: 1 of 2 held out against 10 of 10, -50 points" in text
    assert "has no trial on these seeds yet" not in text
    # only an older method on the held-out seeds: its rows, and a line that the method has none
    older = spec.ORDER[spec.ORDER.index(spec.METHOD) + 1]
    monkeypatch.setattr(
        spec, "frame", lambda study, folder=None: trials([10, 11], [True, True], [True] * 2, older)
    )
    text = spec.heldout(None, pd.concat([chosen, chosen.assign(variant=older)]))
    assert (
        f"`{spec.METHOD}` has no trial on these seeds yet" in text and f"rows below are of `{older}`" in text
    )
    assert f"| `{older}` | stapler | 10 and 11 | 2 of 2 | 2 of 2 | 10 of 10 | 6 of 10 |" in text
    monkeypatch.setattr(spec, "frame", lambda study, folder=None: trials([], [], []))
    assert spec.heldout(None, chosen).endswith("No such trial is kept yet.\n")


def test_the_method_study_sets_a_method_with_held_out_trials_against_its_own_on_every_seed_both_have() -> (
    None
):
    """against_method: another method with held-out trials, per task on the seeds both have (the sweep's and
    the held-out ones) and over those tasks, beside the method's; a task where it has no held-out trial is
    left out, and so is a method without any; nothing at all without such trials."""
    import pandas as pd

    spec = Study("method").spec
    other = spec.ORDER[spec.ORDER.index(spec.METHOD) + 1]

    def trials(task, variant, seeds, clean):
        return pd.DataFrame({"task": task, "variant": variant, "seed": list(seeds), "counted": True,
                             "completed": True, "finished_cleanly": clean})  # fmt: skip

    sweep = pd.concat([
        trials("stapler", spec.METHOD, range(10), [True] * 9 + [False]),
        trials("stapler", other, range(10), [True] * 5 + [False] * 5),
        trials("apple", spec.METHOD, range(10), [True] * 10),
        trials("apple", other, range(10), [True] * 10),
    ])  # fmt: skip
    held = pd.concat([
        trials("stapler", spec.METHOD, range(10, 20), [True] * 10),
        trials("stapler", other, range(10, 15), [False] * 5),  # seeds 15-19: the method's alone
    ])  # fmt: skip
    text = spec.against_method(sweep, held, [spec.METHOD, other])
    assert f"| `{other}` | stapler | 0-14 | 15 of 15 | 5 of 15 | 15 of 15 | 14 of 15 |" in text
    assert "| apple |" not in text  # no held-out trial of the other method on the apple
    assert f"- `{other}` over those tasks: completed 15 of 15 against 15 of 15" in text
    assert "finished cleanly 5 of 15 against 14 of 15 (Barnard p = 0.00" in text
    assert spec.against_method(sweep, held, [spec.METHOD]) == ""
    assert spec.against_method(sweep, held.iloc[:0], [spec.METHOD, other]) == ""


def test_the_method_study_sets_each_lever_beside_the_method_on_the_same_seeds(monkeypatch, tmp_path) -> None:
    """levers_section: a lever is named by its run folder's overrides (not the experiment, seed or task), and
    per task its counts stand beside the method's on the seeds the lever has, with the seeds only one of
    them finished cleanly; without a lever trial, a line that says so."""
    import pandas as pd

    spec = Study("method").spec
    folder = "experiment=method,pacing=release,place=wrist,seed=3,task=paper_stapler"
    assert spec.lever_of(f"/x/levers/{folder}/trial.json") == "pacing=release place=wrist"

    def trials(seeds, clean, lever=None):
        name = folder.replace("seed=3", "seed={}") if lever else "x,seed={}"
        paths = [f"/x/{name.format(s)}/trial.json" for s in seeds]
        return pd.DataFrame({"task": "stapler", "variant": spec.METHOD, "seed": list(seeds), "counted": True,
                             "completed": True, "finished_cleanly": clean, "cpu_seconds": 300.0,
                             "status": "ok", "record_path": paths, "_span": 0.03,
                             "_final": 0.04})  # fmt: skip

    chosen = trials(range(10), [True] * 5 + [False, True] + [False] * 3)
    lever = trials([4, 5, 6, 12, 13], [True, True, False, True, True], True)
    held = trials([12], [False])  # the method's own trial on a held-out seed
    monkeypatch.setattr(spec, "frame", lambda study, folder=None: lever if folder == spec.LEVERS else held)

    def stand_ins(study, df, own, method=spec.METHOD):  # a trial of the method's config on held-out seed 13
        found = trials([13], [True]).assign(variant=method, stand_in="carry=held")
        return found if method == spec.METHOD else found.iloc[0:0]

    monkeypatch.setattr(spec, "stand_ins", stand_ins)

    class Drawn:
        def draw(self, name, make, alt, data=None):
            make(tmp_path / name)
            return f"![{alt}](figures/{name})"

    text = spec.levers_section(Drawn(), chosen)
    assert "| `pacing=release place=wrist` | stapler | 4-6 | 3 of 3 | 2 of 3 | 3 of 3 | 2 of 3 |" in text
    assert "| 5 | 6 | 30 / 30 | 40 / 40 | 1.00 |" in text  # clean only with the lever: 5; only without: 6
    # the lever's held-out seeds beside the method's held-out trials (its stand-ins counted in), on a row of
    # their own
    assert "| stapler (held out) | 12 and 13 | 2 of 2 | 2 of 2 | 2 of 2 | 1 of 2 |" in text
    assert "`place=wrist`: The wrist sampled while the object is set down" in text
    assert (tmp_path / "levers.png").stat().st_size > 0
    monkeypatch.setattr(spec, "frame", lambda study, folder=None: trials([], []))
    assert spec.levers_section(Drawn(), chosen).endswith("No such trial is kept yet.\n")
    assert "Pooled over" not in text  # (5 trials: too few to pool)
    # ten seeds: pooled against the method; the seeds whose trial ran on another processor than the method's
    lever = trials(range(10), [True] * 8 + [False] * 2, True).assign(cpu=["B"] * 3 + ["A"] * 7)
    monkeypatch.setattr(spec, "frame", lambda study, folder=None: lever if folder == spec.LEVERS else held)
    text = spec.levers_section(Drawn(), chosen.assign(cpu="A"))
    assert (
        "`pacing=release place=wrist` (stapler): 8 of 10 finished cleanly against 6 (+2), completed 10"
        in text
    )
    assert "`pacing=release place=wrist` 3 of 10 (stapler 0-2)" in text
    # levers run on an older method stand beside that method's trials, not the default's
    older = spec.ORDER[spec.ORDER.index(spec.METHOD) + 1]
    lever = lever.assign(variant=[f"{older}+carry=held"] * 6 + [older] * 4)
    monkeypatch.setattr(spec, "frame", lambda study, folder=None: lever if folder == spec.LEVERS else held)
    assert spec.built_on(lever) == older and spec.built_on(lever.iloc[:0]) == spec.METHOD
    mixed = pd.concat([chosen.assign(variant=older, finished_cleanly=False), chosen])
    text = spec.levers_section(Drawn(), mixed.assign(cpu="A"))
    assert f"Options on top of `{older}`" in text and f"`{older}`: completed" in text
    assert "8 of 10 finished cleanly against 0 (+8)" in text


def test_the_method_study_finds_the_method_s_trials_a_lever_ran_before_it_was_named(
    monkeypatch, tmp_path
) -> None:
    """reproduced: a trial of the method and a lever's with the same resolved config (the output folder
    aside) on the same processor are one trial, and the two records are compared; another config, or
    another processor, is not matched."""
    import json

    import pandas as pd

    spec = Study("method").spec

    def record(name, seed, cpu="A", ttf=1.0, out="x"):
        path = tmp_path / name / "trial.json"
        path.parent.mkdir(parents=True)
        config = {"seed": seed, "planner": {"num_samples": 32}, "output_dir": f"/{out}/{name}"}
        path.write_text(json.dumps({"config": config, "cpu": cpu, "ttf": ttf, "completed": True}))
        return str(path)

    mine = [record("m0", 0, out="y"), record("m1", 1, out="y"), record("m2", 2, out="y"), record("m3", 3)]
    levers = [record("carry=held,seed=0,task=paper_apple", 0), record("carry=held,seed=1,task=paper_apple", 1,
              ttf=0.5), record("carry=held,seed=2,task=paper_apple", 2, cpu="B")]  # fmt: skip
    frame = lambda paths, variant: pd.DataFrame({  # noqa: E731
        "task": "apple", "variant": variant, "seed": range(len(paths)), "counted": True, "record_path": paths,
        "completed": True, "finished_cleanly": False})  # fmt: skip
    monkeypatch.setattr(
        spec, "frame", lambda study, folder=None: frame(levers, spec.ORDER[-2] + "+carry=held")
    )
    text = spec.reproduced(None, frame(mine, spec.METHOD))
    assert f"Of `{spec.METHOD}`'s 4 trials, 2 ran the same resolved config on the same processor" in text
    assert "(`carry=held`); the two records agree" in text and "on 1 of 2." in text
    assert spec.reproduced(None, frame(mine, spec.ORDER[-2])) == ""  # no trial of the method


def test_the_method_study_lets_a_lever_trial_of_the_method_s_config_stand_in_on_a_held_out_seed(
    monkeypatch, tmp_path
) -> None:
    """stand_ins: a lever's held-out trial whose config is one of the method's trials' but for the seed (on
    the same processor) stands in for the method where it has no held-out trial of its own; another config,
    another processor, a seed the method has its own trial on, or a trial on the sweep's seeds does not."""
    import json

    import pandas as pd

    spec = Study("method").spec

    def record(name, seed, cpu="A", samples=32):
        path = tmp_path / name / "trial.json"
        path.parent.mkdir(parents=True)
        config = {"seed": seed, "planner": {"num_samples": samples}, "output_dir": f"/x/{name}"}
        path.write_text(json.dumps({"config": config, "cpu": cpu, "completed": True}))
        return str(path)

    mine = pd.DataFrame({"task": "apple", "variant": spec.METHOD, "seed": [0, 1], "counted": True,
                         "status": "ok", "record_path": [record("m0", 0), record("m1", 1)]})  # fmt: skip
    rows = [(10, "A", 32, "held out"), (11, "B", 32, "held out"), (12, "A", 64, "held out"),
            (13, "A", 32, "held out"), (2, "A", 32, "sweep")]  # fmt: skip
    levers = pd.DataFrame({
        "task": "apple", "seed": [r[0] for r in rows], "seeds": [r[3] for r in rows], "counted": True,
        "lever": "carry=held", "variant": spec.ORDER[-1],
        "record_path": [record(f"l{r[0]}", r[0], r[1], r[2]) for r in rows]})  # fmt: skip
    monkeypatch.setattr(spec, "lever_frame", lambda study: levers)
    monkeypatch.setattr(spec, "counted", lambda df: df)
    own = pd.DataFrame({"task": ["apple"], "seed": [13]})
    out = spec.stand_ins(None, mine, own)
    assert list(out["seed"]) == [10]
    assert set(out["variant"]) == {spec.METHOD} and set(out["stand_in"]) == {"carry=held"}


def test_the_method_study_sets_each_method_against_the_one_it_adds_a_step_to() -> None:
    """built_from: a name with a group on top of a method of ORDER is built from that method; any other
    from the next in ORDER that is not built on it; pairs holds each once."""
    spec = Study("method").spec
    assert spec.built_from("grasp_held_eased+rollout=fine") == "grasp_held_eased"
    assert spec.built_from("grasp_held_eased+retarget=wrist") == "grasp_held_eased"
    assert spec.built_from("grasp_held_eased") == "grasp_release_ahead_acquire"
    assert spec.built_from(spec.ORDER[-1]) is None
    pairs = spec.pairs()
    assert ("grasp_held_eased+rollout=fine", "grasp_held_eased") in pairs
    assert ("grasp_held_eased+rollout=fine", "grasp_held_eased+retarget=wrist") not in pairs
    assert len(pairs) == len(set(pairs))


def test_the_method_study_reads_the_replayed_lifts_per_task_and_planning_model() -> None:
    """lift_replays: per task and model, of the replays the plant lifts, how many the model lifts too, and
    its agreement with the plant; the closing reading only where the method's (coarsest) model loses most of
    the plant's lifts over the tasks; nothing without rows."""
    import pandas as pd

    spec = Study("method").spec
    plant = [True, True, True, False]
    rows = [("plant", 0.001, plant), ("planning model, 10 ms", 0.01, [False, False, True, True]),
            ("planning model, 5 ms", 0.005, [True, True, True, False])]  # fmt: skip
    df = pd.DataFrame([
        {"task": task, "seed": i, "model": m, "step": st, "lifted": lifted[i], "lifted_in_trial": True,
         "before": 0.3, "after": 3.5}
        for task in ("paper_stapler", "paper_apple")
        for m, st, lifted in rows for i in range(4)])  # fmt: skip
    text = spec.lift_replays(df)
    assert text.index("**apple**") < text.index("**stapler**")  # the tasks in the study's order
    assert "the plant's replays lift the apple on 3 of 4 (seeds 0-2;" in text
    assert (
        "- planning model, 10 ms: lifts it on 1 of 3 of the replays the plant lifts it on (and on 1 of 1"
        in text
    )
    assert "agrees with the plant on 1 of 4;" in text and "agrees with the plant on 4 of 4." in text
    assert "(10 ms) loses the object on 4 of 6 of the grasps that lift it in the plant" in text
    assert "figures/lift_replay_apple.png" in text
    kept = df[df["model"] != "planning model, 10 ms"]  # the coarsest model left keeps every lift
    assert "loses the object" not in spec.lift_replays(kept)
    assert spec.lift_replays(df.iloc[0:0]) == ""


def test_the_method_study_reads_the_planning_models_physics_per_task_and_over_them() -> None:
    """model_physics: per planning model, per task and over the tasks, its lifts of the plant's lifts, its
    lifts of the others and its agreement with the plant, and its CPU against the 10 ms model's; the closing
    reading names the best option at 10 ms and says whether it reaches the finer step's agreement."""
    import pandas as pd

    spec = Study("method").spec
    plant = [True, True, True, False]
    rows = [("plant", 0.001, plant, 9.0), ("10 ms", 0.01, [True, False, False, False], 1.0),
            ("10 ms, friction x2", 0.01, [True, True, False, True], 1.0),
            ("5 ms", 0.005, [True, True, True, False], 2.0)]  # fmt: skip
    df = pd.DataFrame([
        {"task": task, "seed": i, "model": m, "step": st, "lifted": lifted[i], "cpu": cpu,
         "before": 0.3, "after": 3.5}
        for task in ("paper_stapler", "paper_apple")
        for m, st, lifted, cpu in rows for i in range(4)])  # fmt: skip
    text = spec.model_physics(df)
    assert "| planning model | apple | stapler | all | CPU |" in text  # the tasks in the study's order
    assert "| 10 ms | 1/3; 0/1; 2/4 | 1/3; 0/1; 2/4 | 2/6; 0/2; 4/8 | 1.00x |" in text
    assert "| 10 ms, friction x2 | 2/3; 1/1; 2/4 | 2/3; 1/1; 2/4 | 4/6; 2/2; 4/8 | 1.00x |" in text
    assert "| 5 ms | 3/3; 0/1; 4/4 | 3/3; 0/1; 4/4 | 6/6; 0/2; 8/8 | 2.00x |" in text
    assert "the best option at 10 ms (`10 ms, friction x2`) on 4, and the model stepped at 5 ms on 8" in text
    assert "no physics option tried at 10 ms agrees with the plant as often as the finer step" in text
    fair = df.copy()  # an option that agrees as the finer step does
    fair.loc[fair["model"] == "10 ms, friction x2", "lifted"] = plant * 2
    assert "`10 ms, friction x2` agrees with the plant as often as the finer step" in spec.model_physics(fair)
    assert spec.model_physics(df.iloc[0:0]) == ""


def test_the_method_study_says_where_a_lost_object_lies_per_task() -> None:
    """failed_rest: per task, the lost trials, those never lifted, the medians and 90th percentiles of the
    move and the turn, and how many lie within 20 mm of their start, and within 20 mm and 15 degrees."""
    import pandas as pd

    spec = Study("method").spec
    moves = [(10.0, 5.0, False), (15.0, 40.0, True), (100.0, 5.0, False), (200.0, 170.0, False)]
    df = pd.DataFrame([
        {"task": task, "seed": i, "moved": m, "rose": 0.0, "turned": t, "lifted": lifted, "after": 1.0}
        for task in ("paper_stapler", "paper_apple") for i, (m, t, lifted) in enumerate(moves)])  # fmt: skip
    text = spec.failed_rest(df)
    assert text.index("| apple |") < text.index("| stapler |")  # the tasks in the study's order
    assert "| stapler | 4 | 3 | 58 / 170 | 22 / 131 | 2 | 1 |" in text
    assert "the object 1 s after the trial's failure time" in text
    assert spec.failed_rest(df.iloc[0:0]) == ""


def test_the_method_study_bins_the_trials_by_when_the_hand_first_touched_the_object() -> None:
    """first_touches: per task, of the trials with the clearance term, lifted / completed / clean and the
    median displacement per bin of the first touch (s after the first expected contact), the doorknob's
    completion standing in for a lift; those touching within 0.2 s against those touching later, with
    Barnard's test; trials without the clearance term or without a touch left out; nothing without rows."""
    import pandas as pd

    spec = Study("method").spec
    #              first touch, lifted, completed, clean, displaced
    stapler = [(-0.17, False, False, False, 3.0), (0.0, False, False, False, 2.0),
               (0.17, True, True, False, 1.0), (0.34, True, True, True, 0.5),
               (0.51, True, True, True, 0.7), (1.0, True, False, False, 0.2)]  # fmt: skip
    rows = [{"task": "paper_stapler", "shaping": "clearance", "first_touch": t, "lifted": lifted,
             "completed": done, "finished_cleanly": clean, "displaced_mm": mm}
            for t, lifted, done, clean, mm in stapler]  # fmt: skip
    rows += [{"task": "paper_doorknob", "shaping": "clearance", "first_touch": 0.9, "lifted": None,
              "completed": True, "finished_cleanly": False, "displaced_mm": 0.0},
             {"task": "paper_stapler", "shaping": "none", "first_touch": 0.0, "lifted": True,
              "completed": True, "finished_cleanly": True, "displaced_mm": 0.0},
             {"task": "paper_stapler", "shaping": "clearance", "first_touch": None, "lifted": False,
              "completed": False, "finished_cleanly": False, "displaced_mm": 0.0}]  # fmt: skip
    text = spec.first_touches(pd.DataFrame(rows))
    assert "| stapler | 0 / 0 / 0 of 1; 3.0 mm | 1 / 1 / 0 of 2; 1.5 mm | 2 / 2 / 2 of 2; 0.6 mm " in text
    assert "| 1 / 0 / 0 of 1; 0.2 mm |" in text  # 0.7 s or more after
    assert "| doorknob | — | — | — | 1 / 1 / 0 of 1; 0.0 mm |" in text  # completion as its lift
    assert text.index("| doorknob |") < text.index("| stapler |")  # the study's task order
    assert (
        "- stapler: first touching before or within 0.2 s of the expected contact, 1 of 3 completed; " in text
    )
    assert "later, 2 of 3 (Barnard p = " in text
    assert "7 trials of every method" in text  # the clearance term's, with a touch
    assert spec.first_touches(pd.DataFrame(rows).iloc[-2:]) == ""


def test_the_method_study_sets_each_planning_model_s_plan_against_the_paper_point_s_at_the_same_state() -> (
    None
):
    """plan_costs: per task and state, a plan's CPU seconds, samples x steps, CPU a sample-step, and its
    ratio to the paper point's plan at that state (128 x 250 sample-steps at rollout=paper's cost there);
    the largest ratio of each model; a state without rollout=paper's plan is left out; nothing without
    rows."""
    import pandas as pd

    spec = Study("method").spec
    # (rollout, state): CPU-s, samples, steps; rollout=paper: 50 us a sample-step approaching, 100 in contact
    plans = {("paper", "approach"): (1.6, 128, 250), ("paper", "contact"): (0.8, 32, 250),
             ("fine_budget", "approach"): (1.28, 64, 500), ("fine_budget", "contact"): (1.6, 32, 500),
             ("fine", "approach"): (3.2, 128, 500)}  # fmt: skip
    df = pd.DataFrame(
        [{"task": "paper_stapler", "rollout": r, "state": st, "plan_cpu_seconds": c, "plan_samples": n,
          "horizon_steps": h} for (r, st), (c, n, h) in plans.items()]
        + [{"task": "paper_apple", "rollout": "fine", "state": "approach", "plan_cpu_seconds": 9.0,
            "plan_samples": 128, "horizon_steps": 500}]
    )  # fmt: skip
    text = spec.plan_costs(df)
    assert (
        "| stapler | approach | 1.60 s; 128 x 250; 50 us; 1.00x | 1.28 s; 64 x 500; 40 us; 0.80x | "
        "3.20 s; 128 x 500; 50 us; 2.00x |" in text
    )
    assert (
        "| stapler | contact | 0.80 s; 32 x 250; 100 us; 0.25x | 1.60 s; 32 x 500; 100 us; 0.50x |  |" in text
    )
    assert "| apple |" not in text
    assert "`rollout=paper` 1.00x; `rollout=fine_budget` 0.80x; `rollout=fine` 2.00x." in text
    assert spec.plan_costs(df.iloc[0:0]) == ""


def test_the_method_study_says_where_each_free_object_rests_against_the_final_tolerance() -> None:
    """settles: per task, the offset where the trial starts the object and where it rests (the last row),
    the first time from which it stays within 0.5 mm and 0.5° of that, the task's final tolerance; the
    apple from the reference's own first configuration beside it; nothing without rows."""
    import pandas as pd

    spec = Study("method").spec
    rows = [
        ("paper_apple", "task", t, p, r)
        for t, p, r in ((0.0, 12.0, 0.0), (0.1, 6.0, 8.0), (0.2, 3.6, 11.1), (0.3, 3.5, 11.3))
    ]
    rows += [("paper_apple", "reference", t, p, r) for t, p, r in ((0.0, 0.0, 0.0), (0.3, 9.6, 11.3))]
    rows += [("paper_stapler", "task", t, 0.4 * t, 0.8 * t) for t in (0.0, 0.1, 0.2, 0.3)]  # fmt: skip
    df = pd.DataFrame(rows, columns=["task", "start", "time", "position_mm", "rotation_deg"]).assign(
        hand_contacts=0
    )
    text = spec.settles(df)
    assert "| apple | 12.0 mm, 0.0° | 3.5 mm, 11.3° | 0.20 s | 50 mm, 30° | 0 |" in text
    assert "| stapler | 0.0 mm, 0.0° | 0.1 mm, 0.2° | 0.00 s | 50 mm, 30° | 0 |" in text
    assert "it turns 11.3° from it before the hand arrives" in text
    assert "12 mm start offset) it turns 11.3° and rests 9.6 mm from it" in text
    assert "offset) it turns" not in spec.settles(df[df["start"] == "task"])
    assert spec.settles(df.iloc[0:0]) == ""


def test_the_method_study_says_when_each_reference_closes_its_grasp() -> None:
    """reference_grasps: per task, the first time after the first expected contact with at least two, three
    and four fingers expected on the object ("never" where it has not that many), and the time with one
    finger alone (the grid's step per row); nothing without rows."""
    import pandas as pd

    fingers = {"paper_stapler": [1, 1, 2, 1, 3, 3, 4], "paper_apple": [1, 3, 3, 3, 3, 3, 3]}
    df = pd.DataFrame(
        [(task, round(0.1 * k, 6), n) for task, ns in fingers.items() for k, n in enumerate(ns)],
        columns=["task", "time", "fingers"],
    )
    spec = Study("method").spec
    text = spec.reference_grasps(df)
    assert "| apple | +0.10 s | +0.10 s | never | 0.10 s |" in text
    assert "| stapler | +0.20 s | +0.40 s | +0.60 s | 0.30 s |" in text
    assert text.index("| apple |") < text.index("| stapler |")  # the paper's order
    assert spec.reference_grasps(df.iloc[0:0]) == ""


def test_the_method_study_sets_each_finer_planning_model_beside_the_method_on_the_same_seeds() -> None:
    """finer_models: per task, each ``+rollout=`` method on top of the method against the method's trials on
    the seeds it ran (a seed the method lacks is left out); nothing without such trials."""
    import pandas as pd

    spec = Study("method").spec
    fine = f"{spec.free_base()}+rollout=fine"
    rows = [(spec.free_base(), s, s < 3, s < 2) for s in range(4)] + [
        (fine, s, True, s != 1) for s in (0, 1, 3, 5)
    ]
    df = pd.DataFrame([{"task": "stapler", "variant": v, "seed": s, "counted": True, "completed": c,
                        "finished_cleanly": f} for v, s, c, f in rows])  # fmt: skip
    text = spec.finer_models(df)
    assert (
        "- **stapler**: `rollout=fine` completes 3 of 3 and finishes 2 cleanly, against 2 and 2 (seeds 0, 1"
        in text
    )
    assert spec.finer_models(df[df["variant"] == spec.METHOD]) == ""


def test_the_method_study_sets_a_lever_against_the_lever_it_builds_on() -> None:
    """stacked: a lever whose overrides contain another's stands against it on the seeds both ran, per
    task and in all; levers that do not build on one another, none."""
    import pandas as pd

    spec = Study("method").spec

    def trials(lever, task, seeds, clean):
        return pd.DataFrame({"lever": lever, "task": task, "seed": list(seeds), "completed": True,
                             "finished_cleanly": clean})  # fmt: skip

    ok = pd.concat([
        trials("carry=held", "apple", range(4), [True, False, False, True]),
        trials("carry=held grip=squeeze", "apple", range(1, 5), [True, True, True, False]),
        trials("carry=held grip=squeeze", "stapler", [0], [True]),  # no carry=held stapler: left out
        trials("cost.lambda_c=3.0", "apple", range(4), [False] * 4),
    ])  # fmt: skip
    text = spec.stacked(ok)
    assert text.count(" against `") == 1  # (cost.lambda_c does not build on carry=held)
    assert (
        "`carry=held grip=squeeze` against `carry=held`: apple (seeds 1-3) 3 of 3 finished cleanly "
        "against 1, completed 3 against 3; in all 3 of 3 against 1 (+2)" in text
    )
    assert "stapler" not in text
    assert spec.stacked(ok[ok["lever"] != "carry=held"]) == ""


def test_the_method_study_says_which_links_hold_the_carried_object(monkeypatch, tmp_path) -> None:
    """grasp_section: over the samples where the object and the reference's are both lifted, each link
    group's share of samples in contact (plant) against expected (reference); an object without a free
    body (the doorknob's articulation) or never carried is left out; no such trial, a line that says so."""
    import numpy as np
    import pandas as pd

    spec = Study("method").spec
    n = 10
    qo = np.zeros((n, 7))
    qo[5:, 2] = 0.1  # lifted from the sixth sample on
    contacts, expected = np.zeros((n, 21), bool), np.zeros((n, 21), bool)
    contacts[:, 5] = True  # ff_tip touches throughout
    expected[:, [0, 5, 20]] = True  # the reference: palm, ff_tip, th_tip
    contacts[7:, 0] = True  # the palm touches on 3 of the 5 carried samples
    (tmp_path / "a").mkdir()
    np.savez(tmp_path / "a" / "timeseries.npz", object_qpos=qo, expected_object_qpos=qo, contacts=contacts,
             expected_contacts=expected)  # fmt: skip
    assert spec.carried({"object_qpos": qo[:, :1], "expected_object_qpos": qo[:, :1]}) is None
    assert spec.carried({"object_qpos": qo[:, :] * 0, "expected_object_qpos": qo * 0}) is None
    frame = pd.DataFrame({"lever": [spec.GRASP_LEVER], "task": ["apple"],
                          "record_path": [str(tmp_path / "a" / "trial.json")]})  # fmt: skip
    monkeypatch.setattr(spec, "lever_frame", lambda study: frame)
    text = spec.grasp_section(None)
    assert "apple (1 trial): 1.6 links in contact on average against the reference's 3.0" in text
    assert "| palm | 0.60 / 1.00 |" in text and "| index, distal and tip | 1.00 / 1.00 |" in text
    assert "| thumb, distal and tip | 0.00 / 1.00 |" in text
    assert "to close the grasp" not in text  # no lever built on it
    # a lever on top of it, on the same seed: its contacts against the base's; another task's trial and a
    # lever not built on it are left out
    more = contacts.copy()
    more[:, 20] = True  # th_tip too, and the palm throughout: 3 links on every carried sample
    more[:, 0] = True
    (tmp_path / "b").mkdir()
    np.savez(tmp_path / "b" / "timeseries.npz", object_qpos=qo, expected_object_qpos=qo, contacts=more,
             expected_contacts=expected)  # fmt: skip
    b = str(tmp_path / "b" / "trial.json")
    frame = pd.DataFrame({"lever": [spec.GRASP_LEVER, f"{spec.GRASP_LEVER} grip=squeeze", "grip=squeeze",
                                    f"{spec.GRASP_LEVER} grip=squeeze",
                                    f"{spec.GRASP_LEVER} sampler.release.noise=1.0"],
                          "task": ["apple", "apple", "apple", "bottle", "apple"], "seed": [3, 3, 3, 3, 3],
                          "record_path": [str(tmp_path / "a" / "trial.json"), b, b, b, b]})  # fmt: skip
    text = spec.grasp_section(None)
    assert "| `carry=held grip=squeeze` | apple | seed 3 | 3.0 / 1.6 | 1.00 / 0.60 |" in text
    assert "| `grip=squeeze` |" not in text and "| bottle |" not in text
    assert "sampler.release.noise" not in text  # a release lever changes nothing while carried
    monkeypatch.setattr(spec, "lever_frame", lambda study: frame.iloc[:0])
    assert spec.grasp_section(None).startswith("No `carry=held` trial")


def test_the_method_study_sets_the_doorknob_on_a_rough_slide_beside_the_authors_slide(monkeypatch) -> None:
    """rough_slide: per seed, how the trial on the slide with friction ended beside the trial of the same
    seed on the authors' slide, and the counts with Barnard's test; without such a trial, a line that says
    so."""
    import pandas as pd

    spec = Study("method").spec

    def trials(seeds, done, clean, friction=None):
        return pd.DataFrame({"task": "doorknob", "variant": spec.METHOD, "seed": seeds, "counted": True,
                             "completed": done, "finished_cleanly": clean, "_final": 0.3,
                             "cpu_seconds": 300.0, "task.slide_friction": friction})  # fmt: skip

    chosen = trials(range(10), [True] * 10, [False] * 10)
    rough = trials([0, 1, 2], [True, True, False], [True, True, False], 0.5).assign(_final=[0.01, 0.02, 0.2])
    monkeypatch.setattr(spec, "frame", lambda study, folder=None: rough)
    text = spec.rough_slide(spec.rough_frame(None), chosen)
    assert "| 0 | 0.5 | clean | 10 | done | 300 |" in text
    assert "| 2 | 0.5 | failed | 200 | done | 300 |" in text
    assert "- finished cleanly: 2 of 3 on the slide with friction, 0 of 3 on the authors' slide" in text
    assert "the paper's method (`full`)" not in text  # no trial of it on the rough slide: no such line
    # the paper's method on the same slide: against its own trials on the authors' slide, and the method's
    paper = rough.assign(variant=spec.BASELINE, finished_cleanly=[True, False, False])
    with_paper = pd.concat([rough, paper], ignore_index=True)
    monkeypatch.setattr(spec, "frame", lambda study, folder=None: with_paper)
    both = spec.rough_slide(spec.rough_frame(None), pd.concat([chosen, chosen.assign(variant=spec.BASELINE)]))
    assert (
        "- the paper's method (`full`) on the slide with friction, finished cleanly: 1 of 3 there, 0 of 3 on"
        in both
    )
    assert f"- on the slide with friction, `{spec.METHOD}` against `full`, finished cleanly: 2 of 3" in both
    monkeypatch.setattr(spec, "frame", lambda study, folder=None: rough)
    summary = spec.rough_summary(spec.rough_frame(None))
    assert f"`{spec.METHOD}` completes the doorknob 2 of 3 and finishes 2 of 3 cleanly" in summary
    # the method the trials ran, named by them: not the default where they ran another
    older = rough.assign(variant="grasp_release_ahead_acquire")
    monkeypatch.setattr(spec, "frame", lambda study, folder=None: older)
    assert "`grasp_release_ahead_acquire` completes the doorknob 2 of 3" in spec.rough_summary(
        spec.rough_frame(None)
    )
    monkeypatch.setattr(spec, "frame", lambda study, folder=None: rough.iloc[:2])
    summary = spec.rough_summary(spec.rough_frame(None))
    assert summary.startswith("\nThe doorknob's shortfall is the authors' frictionless")
    monkeypatch.setattr(spec, "frame", lambda study, folder=None: rough.iloc[:0])
    assert spec.rough_slide(spec.rough_frame(None), chosen).endswith("No such trial is kept yet.\n")
    assert spec.rough_summary(spec.rough_frame(None)) == ""


def test_fig3_says_in_short_which_claim_holds_where() -> None:
    """_verdicts / _in_short: a claim holds on a task where a test in full's favour passes Holm and the
    full method completes some trials; a passing test where every full trial fails is no evidence; the
    doorknob counts only among the hard cells; a reading without hard cells says so."""
    import pandas as pd

    spec = Study("fig3_paper").spec
    counts = {"apple": (6, 0), "bottle": (0, 0), "doorknob": (6, 0)}
    rows = [
        dict(
            fidelity="paper", task=task, variant=variant, seed=seed, status="ok", ttf=1.0, completed=seed < k
        )
        for task, (full, ablated) in counts.items()
        for variant, k in (("full", full), ("no_contact", ablated))
        for seed in range(6)
    ]
    df = pd.DataFrame(rows)
    done = pd.DataFrame(
        [dict(fidelity="paper", variant="no_contact", task=t, p_holm=0.003, delta=1.0) for t in counts]
    )
    ttf = pd.DataFrame(
        [dict(condition="paper", variant="no_contact", task="bottle", p_holm=0.01, prob_superiority=0.9)]
    )
    main = spec._verdicts(df, ttf, done)
    hard = spec._verdicts(df, ttf, done, hard=True)
    assert [(r["variant"], r["real"], r["failing"]) for r in main] == [("no_contact", ["apple"], ["bottle"])]
    assert main[0]["tasks"] == ["apple", "bottle"] and hard[0]["real"] == ["doorknob", "apple"]
    f = Study("fig3_paper").fmt
    table = spec._in_short(main, [], f)
    assert (
        "| the text's reading | the contact term (`no_contact`) | **holds** on the apple | not run yet |"
        in table
    )
    quiet = spec._verdicts(df, ttf.iloc[:0], done.iloc[:0])
    assert "not established (full ahead on the apple, of 2)" in spec._in_short(quiet, hard, f)


def test_the_screen_sets_contact_guidance_beside_the_same_iterations_without_it() -> None:
    """guidance_findings: the guided lever against its name without ``guide…``, per task on the seeds both
    have (a seed only one has is left out), with Barnard's test; nothing without a guided lever."""
    import pandas as pd

    spec = Study("method_screen").spec
    base, guided = "full it4 anneal0.1 stop0.01", "full it4 anneal0.1 stop0.01 guide0.05"
    rows = [
        dict(lever=lever, task="paper_stapler", seed=seed, status="ok", lifted=lifted, completed=lifted,
             ttf=1.0 if lifted else 0.5, cpu_seconds=cpu)
        for lever, cpu, lifts in ((base, 40.0, (0, 0, 0, 0)), (guided, 160.0, (1, 1, 0, 1, 1)))
        for seed, lifted in enumerate(lifts)
    ]  # fmt: skip
    text = spec.guidance_findings(pd.DataFrame(rows))
    assert text.startswith(f"**Contact guidance**, `{guided}` against `{base}`")
    assert (
        "- paper_stapler, with the guidance against without it, seeds 0-3: lifted 3 of 4 against 0 of 4 "
        "(Barnard p = " in text
    )
    assert "median TTF 1.00 against 0.50; CPU-s × 4.00" in text
    assert spec.guidance_findings(pd.DataFrame(rows[:4])) == ""


def test_the_method_study_pairs_each_release_lever_with_the_trial_it_departs_from(
    monkeypatch, tmp_path
) -> None:
    """release_section: only carry=held with release options on top; per trial, where its plant first
    differs from carry=held's of the same seed (from the kept qpos), both errors where the hand lets go and
    at the end, finished cleanly; carry=held's release losses named; nothing run, a line that says so."""
    import math

    import numpy as np
    import pandas as pd

    spec = Study("method").spec
    assert spec.release_lever("carry=held sampler.release.noise=1.0 sampler.release.blend=1.0")
    assert spec.release_lever("carry=held release=backoff")
    assert not spec.release_lever("carry=held") and not spec.release_lever("carry=held grip=squeeze")
    assert not spec.release_lever("sampler.release.noise=1.0")
    t = np.arange(10) * 0.5
    qpos = np.zeros((10, 3))
    for name, moved in (("base", None), ("lever", 6)):
        (tmp_path / name).mkdir()
        q = qpos.copy()
        if moved is not None:
            q[moved:, 1] = 1e-9  # the lever's plant departs at t = 3.0
        np.savez(tmp_path / name / "timeseries.npz", time=t, qpos=q)
    assert spec.departs(str(tmp_path / "lever" / "trial.json"), str(tmp_path / "base" / "trial.json")) == 3.0
    assert spec.departs(str(tmp_path / "base" / "trial.json"), str(tmp_path / "base" / "trial.json")) is None
    assert spec.departs(str(tmp_path / "none" / "trial.json"), str(tmp_path / "base" / "trial.json")) is None
    row = dict(task="apple", seed=8, contact_span_end=2.5, object_position_error_span_final=0.018,
               object_rotation_error_span_final=math.radians(7), completed=True)  # fmt: skip
    lever = "carry=held sampler.release.noise=1.0"
    frame = pd.DataFrame([
        {**row, "lever": "carry=held", "record_path": str(tmp_path / "base" / "trial.json"),
         "final_object_position_error": 0.037, "final_object_rotation_error": math.radians(39),
         "finished_cleanly": False},
        {**row, "lever": lever, "record_path": str(tmp_path / "lever" / "trial.json"),
         "final_object_position_error": 0.014, "final_object_rotation_error": math.radians(8),
         "finished_cleanly": True},
        {**row, "lever": "carry=held grip=squeeze", "record_path": str(tmp_path / "lever" / "trial.json"),
         "final_object_position_error": 0.014, "final_object_rotation_error": math.radians(8),
         "finished_cleanly": True},
    ])  # fmt: skip
    monkeypatch.setattr(spec, "lever_frame", lambda study: frame)
    text = spec.release_section(None)
    assert (
        "| `carry=held sampler.release.noise=1.0` | apple | 8 | +0.50 s | 18 mm, 7° → 37 mm, 39° | "
        "18 mm, 7° → 14 mm, 8° | yes / no |" in text
    )
    assert (
        "1 of 1 finished cleanly against 0 (`carry=held` lost the object as the hand let go on apple 8; the "
        "lever finished 1 of those cleanly)" in text
    )
    assert "grip=squeeze" not in text
    # the other way round, another lever on seed 8: carry=held's trial clean, the lever's lost as it let go
    swapped = frame.iloc[:2].copy()
    swapped["lever"] = ["carry=held", "carry=held release=backoff"]
    swapped["record_path"] = swapped["record_path"].iloc[::-1].to_list()
    for c in ("final_object_position_error", "final_object_rotation_error", "finished_cleanly"):
        swapped[c] = swapped[c].iloc[::-1].to_list()
    monkeypatch.setattr(spec, "lever_frame", lambda study: swapped)
    text = spec.release_section(None)
    assert (
        "`carry=held release=backoff` 0 of 1 finished cleanly against 1 (the lever lost it so where "
        "`carry=held` finished cleanly on apple 8)" in text
    )
    monkeypatch.setattr(spec, "lever_frame", lambda study: frame.iloc[:0])
    assert spec.release_section(None).startswith("No release lever")


def test_the_method_study_says_which_levers_meet_the_target_where(monkeypatch) -> None:
    """levers_target: a lever meets the target on a task only with all of the sweep's seeds run there
    (held-out seeds do not count); the tasks no lever meets it on are named; no lever trials, nothing."""
    import pandas as pd

    spec = Study("method").spec
    tasks, seeds = spec.plan()
    rows = []
    for seed in seeds:  # "a" on the first task: every seed, all but one clean; "b": one seed short
        rows.append(dict(lever="a", task=tasks[0], seed=seed, seeds="sweep", completed=True,
                         finished_cleanly=seed != seeds[0]))  # fmt: skip
        if seed != seeds[-1]:
            rows.append(dict(lever="b", task=tasks[0], seed=seed, seeds="sweep", completed=True,
                             finished_cleanly=True))  # fmt: skip
    rows.append(
        dict(lever="b", task=tasks[0], seed=99, seeds="held out", completed=True, finished_cleanly=True)
    )
    frame = pd.DataFrame(rows)
    monkeypatch.setattr(spec, "lever_frame", lambda study: frame)
    n = len(seeds)
    text = spec.levers_target(None)
    assert (
        f"the target is met on {tasks[0]} by `a` ({n}/{n} completed, {n - 1}/{n} finished cleanly)." in text
    )
    assert "`b`" not in text
    assert f"On all {len(tasks)} tasks: none; on none by any lever: {', '.join(tasks[1:])}." in text
    monkeypatch.setattr(spec, "lever_frame", lambda study: frame.iloc[:0])
    assert spec.levers_target(None) == ""


def test_the_method_study_says_when_each_trial_switched_its_planning_model() -> None:
    """switched: per seed, when the planning model switched after the first expected contact (and back after
    the last, where the record says); the seeds with no switch time; nothing where no record has one."""
    import pandas as pd

    spec = Study("method").spec
    rows = [
        dict(
            seed=0, switch_time=9.01, contact_span_start=7.82, switch_back_time=31.11, contact_span_end=30.94
        ),
        dict(
            seed=1, switch_time=None, contact_span_start=7.82, switch_back_time=None, contact_span_end=30.94
        ),
    ]
    text = spec.switched(pd.DataFrame(rows))
    assert "0: +1.19 s, back +0.17 s after the last" in text and "no switch time on seeds 1" in text
    assert spec.switched(pd.DataFrame(rows).drop(columns="switch_back_time")).count("back") == 0
    assert spec.switched(pd.DataFrame(rows[1:])) == spec.switched(pd.DataFrame([dict(seed=0)])) == ""


def test_the_method_study_bins_the_set_down_by_the_object_s_orientation(monkeypatch) -> None:
    """set_down: per free-object task, the completed trials by the orientation error where the hand lets go,
    each bin's toppled and finished-cleanly counts; the doorknob and trials not completed left out; a
    method built on the default against it on the paired seeds (medians, the Wilcoxon signed-rank p)."""
    import math

    import pandas as pd

    spec = Study("method").spec
    base = spec.free_base()
    lever = f"{base}+place=wrist"

    def trial(task, rot0, rot1, clean, completed=True, seed=0, variant=base):
        return dict(task=task, seed=seed, variant=variant, counted=True, completed=completed,
                    finished_cleanly=clean, object_rotation_error_span_final=math.radians(rot0),
                    object_position_error_span_final=0.01,
                    final_object_rotation_error=math.radians(rot1))  # fmt: skip

    rows = [
        trial("bottle", 5, 5, True, seed=9),
        trial("bottle", 10, 90, False, seed=9),  # toppled
        trial("bottle", 35, 90, False, seed=9),  # toppled
        trial("bottle", 40, 40, False, seed=9),
        trial("bottle", 60, 60, False, seed=9),
        trial("bottle", 5, 90, False, completed=False, seed=9),  # not completed: not counted here
        trial("doorknob", 5, 5, True),
    ]
    monkeypatch.setattr(spec, "plan", lambda: (["doorknob", "bottle"], list(range(10))))
    monkeypatch.setattr(
        spec, "frame", lambda study, folder=None: pd.DataFrame(rows if folder is None else [])
    )
    text = spec.set_down(None)
    assert "| bottle | 5 | 1 / 1 of 2 | none | 1 / 0 of 2 | – / 0 of 1 |" in text
    assert "bottle: 1 of 2 set down 30-45° off toppled, against 1 of 2 set down under 15°" in text
    assert "doorknob" not in text and "Wilcoxon" not in text  # no method on paired seeds
    rows += [trial("bottle", 20 + s, 20 + s, True, seed=s) for s in range(5)]
    rows += [trial("bottle", 10 + s, 10 + s, True, seed=s, variant=lever) for s in range(5)]
    text = spec.set_down(None)
    assert f"| `{lever}` | bottle | 0-4 | 12 / 22 | 5 of 5 | 0.0625 |" in text
    monkeypatch.setattr(spec, "frame", lambda study, folder=None: pd.DataFrame([]))
    assert spec.set_down(None) == ""


def test_the_set_down_s_tilt_comes_from_the_time_series_and_leaves_out_the_spin(tmp_path) -> None:
    """set_down_tilt: each completed trial's tilt where the hand lets go (the last sample of the contact
    span) and at the end, from its timeseries.npz; a bottle spun 40° about the vertical is not tilted, one
    set down tilted 25° that ends on its side lies over; a trial without a time series is left out."""
    import math

    import numpy as np
    import pandas as pd
    from scipy.spatial.transform import Rotation

    spec = Study("method").spec

    def write(name, at, end):
        run = tmp_path / name
        run.mkdir()
        quats = [Rotation.from_euler(*a, degrees=True).as_quat(scalar_first=True) for a in (at, at, end)]
        qpos = np.concatenate([np.zeros((3, 3)), np.array(quats)], axis=1)
        upright = np.tile([0, 0, 0, 1.0, 0, 0, 0], (3, 1))
        np.savez(run / "timeseries.npz", time=np.array([1.0, 2.0, 3.0]), object_qpos=qpos,
                 expected_object_qpos=upright)  # fmt: skip
        return str(run / "trial.json")

    spun = write("spun", ("z", 40), ("z", 40))
    tipped = write("tipped", ("x", 25), ("x", 90))
    assert spec.tilts(spun, 2.0)[0] == pytest.approx(0.0, abs=1e-6)
    assert spec.tilts(tipped, 2.0) == pytest.approx((25.0, 90.0))
    assert all(math.isnan(v) for v in spec.tilts(tmp_path / "none" / "trial.json", 2.0))
    (tmp_path / "records").mkdir()
    swept = Path(write("records/tipped", ("x", 25), ("x", 90)))  # a sweep's: its series does not travel
    assert all(math.isnan(v) for v in spec.tilts(swept, 2.0))
    rows = [
        dict(task="bottle", record_path=spun, contact_span_end=2.0, finished_cleanly=True,
             object_rotation_error_span_final=0.7),
        dict(task="bottle", record_path=tipped, contact_span_end=2.0, finished_cleanly=False,
             object_rotation_error_span_final=0.6),
        dict(task="bottle", record_path=str(tmp_path / "x" / "trial.json"), contact_span_end=2.0,
             finished_cleanly=True, object_rotation_error_span_final=0.1),
    ]  # fmt: skip
    text = spec.set_down_tilt(pd.DataFrame(rows))
    assert "| bottle | 2 | 0 / 1 of 1 | none | none | 1 / 0 of 1 |" in text
    assert "of the 2 set down 30-45° off in all, the median tilt was 12.5°" in text
    assert spec.set_down_tilt(pd.DataFrame([dict(task="bottle")])) == ""


def test_the_latency_s_demand_on_the_machine_is_read_from_the_records_and_the_benchmark(
    tmp_path, monkeypatch
) -> None:
    """threads_needed: the method's completions at each longer latency on the sweep's seeds (and at the
    calibrated one, from the study's records) beside the grasp plan's CPU time over that latency; nothing
    without the plan benchmark, or for seeds off the sweep's."""
    from types import SimpleNamespace

    import pandas as pd

    spec = Study("method").spec
    monkeypatch.setattr(spec, "plan", lambda: (["stapler"], [0, 1]))
    study = SimpleNamespace(dir=tmp_path)
    m = spec.METHOD
    records = [
        dict(task="paper_stapler", variant=m, seed=s, latency=0.3, completed=s == 0) for s in (0, 1, 12)
    ]
    ok = pd.DataFrame([dict(task="stapler", variant=m, seed=s, completed=True) for s in (0, 1)])
    assert spec.threads_needed(study, records, ok, 170.0) == ""  # no benchmark
    (tmp_path / "figures").mkdir()
    rows = [dict(task="paper_stapler", rollout="paper", state="approach", plan_cpu_seconds=1.5),
            dict(task="paper_stapler", rollout="paper", state="contact", plan_cpu_seconds=0.5)]  # fmt: skip
    pd.DataFrame(rows).to_csv(tmp_path / "figures" / spec.PLAN_COSTS, index=False)
    text = spec.threads_needed(study, records, ok, 170.0)
    assert "2 of 2 completed at 170 ms (its grasp plans need 8.8 threads)" in text
    assert "1 of 2 completed at 300 ms (its grasp plans need 5.0 threads)" in text
    assert "1.50 CPU-s" in text
    assert spec.threads_needed(study, records[2:], ok, 170.0) == ""  # a held-out seed only


def test_the_method_study_finds_paced_levers_by_the_pacing_their_record_composed(monkeypatch) -> None:
    """_paced_levers reads a lever trial's pacing from its record, not its overrides: a lever on a paced
    method (effort=acquire_waiting on grasp_held_expected_paced: pacing=lift, a grasp wait) is among the
    grasp's, as pacing=hold's are; pacing=release_turn's among the release's; pacing=lift_retry's among
    neither but its own; an unpaced lever in none."""
    import pandas as pd

    spec = Study("method").spec
    levers = {
        "pacing=hold planner.pace_lag=0.035 variant=grasp_held_expected": "hold",
        "effort=acquire_waiting variant=grasp_held_expected_paced": "lift",
        "pacing=release_turn variant=grasp_held_retract": "release_turn",
        "pacing=lift_retry variant=grasp_held_expected_paced": "lift_retry",
        "carry=held": "none",
    }
    ok = pd.DataFrame([dict(lever=k, pacing=v, task="stapler", seed=0) for k, v in levers.items()])
    monkeypatch.setattr(spec, "lever_frame", lambda study: ok)
    monkeypatch.setattr(spec, "lever_names", lambda ok: ({k: "m" for k in levers}, {k: k for k in levers}))
    monkeypatch.setattr(spec, "with_heldout", lambda study, chosen: pd.DataFrame(
        [], columns=["variant", "task", "seed", "finished_cleanly"]))  # fmt: skip
    grasp, release, retry = (
        spec._paced_levers(None, None, k)[0]["lever"].tolist() for k in ("hold", "release", "lift_retry")
    )
    assert grasp == list(levers)[:2] and release == list(levers)[2:3] and retry == list(levers)[3:4]


def test_the_method_study_reads_when_a_trial_tried_its_grasp_again_and_where_the_object_lay(tmp_path) -> None:
    """grasp_retries: per rewind in the record's retry_times, when it began after the reference's first
    expected contact (contact_span_start) and how far the object lay across the table from where it
    started (mm); none where it never rewound; None for a record without retry_times."""
    import json

    import numpy as np

    spec = Study("method").spec
    t = np.arange(10) * 0.5
    qpos = np.tile([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0], (10, 1))
    qpos[6:, :2] = 0.03, 0.04  # pushed 5 cm from 3 s on
    run = tmp_path / "run"
    run.mkdir()
    np.savez(run / "timeseries.npz", time=t, object_qpos=qpos)
    record = {"retry_times": [1.0, 3.5], "contact_span_start": 0.5}
    (run / "trial.json").write_text(json.dumps(record))
    (first, near), (second, far) = spec.grasp_retries(run / "trial.json")
    assert (first, second) == (0.5, 3.0) and near == 0.0 and far == pytest.approx(50.0)
    (run / "trial.json").write_text(json.dumps({**record, "retry_times": []}))
    assert spec.grasp_retries(run / "trial.json") == []
    (run / "trial.json").write_text(json.dumps({"contact_span_start": 0.5}))
    assert spec.grasp_retries(run / "trial.json") is None


def test_the_method_study_sets_each_error_effort_trial_beside_the_same_config_without_it(
    tmp_path, monkeypatch
) -> None:
    """error_effort: per effort=acquire_error lever trial, its plans given the grasp's samples (the record's
    error_plans of num_plans), its outcome, and the outcome of the lever's overrides less effort= on that
    seed (— where none ran), with both CPU-s; nothing without such a lever."""
    import json

    import pandas as pd

    spec = Study("method").spec
    on = "pacing=lift_retry variant=grasp_held_expected_paced"
    mine = f"effort=acquire_error {on}"
    rows = []
    for lever, seed, clean, done, cpu in ((on, 3, False, False, 300.0), (mine, 3, True, True, 420.0),
                                          (mine, 4, False, True, 410.0)):  # fmt: skip
        run = tmp_path / f"{lever.replace(' ', ',')},seed={seed}"
        run.mkdir()
        (run / "trial.json").write_text(json.dumps({"error_plans": 12, "num_plans": 366}))
        rows.append(dict(lever=lever, task="stapler", seed=seed, finished_cleanly=clean, completed=done,
                         cpu_seconds=cpu, record_path=str(run / "trial.json"), on="m"))  # fmt: skip
    monkeypatch.setattr(spec, "lever_frame", lambda study: pd.DataFrame(rows))
    monkeypatch.setattr(spec, "finer_levers", lambda *a: "")
    monkeypatch.setattr(spec, "with_heldout", lambda study, chosen: pd.DataFrame())
    text = spec.error_effort(None, None)
    assert f"| `{mine}` | stapler | 3 | 12 of 366 | clean | `{on}`: not completed | 420 / 300 |" in text
    assert f"| `{mine}` | stapler | 4 | 12 of 366 | completed | `{on}`: — | 410 |" in text
    assert "2 of 2 completed, 1 of 2 finished cleanly" in text
    monkeypatch.setattr(spec, "lever_frame", lambda study: pd.DataFrame(rows[:1]))
    assert spec.error_effort(None, None) == ""


def test_the_method_study_names_the_one_method_whose_worst_task_is_best(monkeypatch) -> None:
    """every_task: of the methods with all ten sweep seeds on every task, the one whose worst task
    completes most (the Wilson lower bound), then finishes cleanly most; one without a task's seeds is not
    ranked; None where no method has them all."""
    import pandas as pd

    spec = Study("method").spec
    monkeypatch.setattr(spec, "plan", lambda: (["apple", "bottle"], list(range(10))))
    done = {("a", "apple"): 10, ("a", "bottle"): 8, ("b", "apple"): 9, ("b", "bottle"): 9, ("c", "apple"): 10}
    rows = [dict(variant=m, task=t, seed=s, completed=s < k, finished_cleanly=s < k - 1)
            for (m, t), k in done.items() for s in range(10)]  # fmt: skip
    ok = pd.DataFrame(rows)
    assert spec.every_task(ok, ["a", "b", "c"]) == "b"
    assert spec.every_task(ok, ["a", "c"]) == "a"
    assert spec.every_task(ok, ["c"]) is None
    assert spec.every_task(ok[ok["seed"] < 9], ["a", "b"]) is None  # nine seeds of ten


def test_the_method_study_splits_a_paced_trials_waits_into_the_grasps_and_the_releases(tmp_path) -> None:
    """grasp_waits: the reference's waits before the release's window (pace_window from the last expected
    contact, read from the record): how long, when the first began after the first expected contact, the
    object's position error there and where the last ended; paced_waits then counts only the window's. A
    trial without a window (pacing=hold): every wait is the grasp's."""
    import json

    import numpy as np

    spec = Study("method").spec
    t = np.arange(12) * 0.5
    behind = np.array(
        [0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.0, 1.0, 1.0, 1.5, 1.5, 1.5]
    )  # grasp: 1 s, release: 0.5 s
    s = t - behind
    expected = np.zeros((12, 3), bool)
    expected[(s >= 0.5) & (s <= 3.5)] = True  # the reference's contact from 0.5 s to 3.5 s of its time
    error = np.array([0, 0, 0.01, 0.03, 0.02, 0.005, 0, 0, 0, 0, 0, 0])
    qpos = np.tile([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0], (12, 1))
    run = tmp_path / "run"
    run.mkdir()
    np.savez(run / "timeseries.npz", time=t, reference_time=s, expected_contacts=expected,
             object_position_error=error, object_qpos=qpos, expected_object_qpos=qpos)  # fmt: skip
    (run / "trial.json").write_text(json.dumps({"config": {"planner": {"pace_window": [-0.5, 0.0]}}}))
    waited, began, at, ended = spec.grasp_waits(run / "trial.json")
    assert waited == 1.0 and began == pytest.approx(0.5) and at == pytest.approx(10.0)
    assert ended == pytest.approx(20.0)  # (row 4: after the grasp's last wait)
    waited, _, _, _ = spec.paced_waits(run / "trial.json")
    assert waited == pytest.approx(0.5)  # the window's alone
    (run / "trial.json").write_text(json.dumps({"config": {"planner": {"pace_window": None}}}))
    waited, _, _, _ = spec.grasp_waits(run / "trial.json")
    assert waited == 1.5  # no window: every wait is the grasp's


def test_the_method_study_reads_a_paced_trials_wait_and_the_tilt_over_it(tmp_path) -> None:
    """paced_waits: how long the reference fell behind in all, and the object's tilt off the reference's
    where the wait began, where it ended and at the end; NaN for the wait's tilts where it never waited;
    None without a logged reference time."""
    import numpy as np

    spec = Study("method").spec
    t = np.arange(8) * 0.5
    behind = np.array([0.0, 0.0, 0.5, 1.0, 1.5, 1.5, 1.5, 1.5])  # held from 0.5 s to 2.0 s
    tilt = np.radians([0.0, 0.0, 30.0, 20.0, 10.0, 5.0, 5.0, 5.0])
    upright = np.tile([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0], (8, 1))
    tipped = upright.copy()
    tipped[:, 3], tipped[:, 4] = np.cos(tilt / 2), np.sin(tilt / 2)  # about x: tilted by `tilt`
    run = tmp_path / "run"
    run.mkdir()
    np.savez(run / "timeseries.npz", time=t, reference_time=t - behind, object_qpos=tipped,
             expected_object_qpos=upright)  # fmt: skip
    waited, began, ended, end = spec.paced_waits(run / "trial.json")
    assert waited == 1.5 and began == pytest.approx(0.0) and ended == pytest.approx(10.0)
    assert end == pytest.approx(5.0)
    np.savez(run / "timeseries.npz", time=t, reference_time=t, object_qpos=tipped,
             expected_object_qpos=upright)  # fmt: skip
    waited, began, ended, end = spec.paced_waits(run / "trial.json")
    assert waited == 0.0 and np.isnan(began) and np.isnan(ended) and end == pytest.approx(5.0)
    np.savez(run / "timeseries.npz", time=t, object_qpos=tipped, expected_object_qpos=upright)
    assert spec.paced_waits(run / "trial.json") is None


def test_the_method_study_sets_each_finer_lever_seed_by_seed_beside_the_method_it_ran_on() -> None:
    """finer_levers: per task and block of ten seeds, the method's trials seed by seed, then each
    ``rollout=`` lever on it that ran in the block (a seed not run marked so), each with its counts; other
    levers and blocks no lever ran in are left out; nothing without such levers."""
    import pandas as pd

    spec = Study("method").spec
    m = spec.OUTCOME_MARKS

    def trial(variant, seed, completed, clean, lever=None):
        return {"task": "stapler", "variant": variant, "seed": seed, "completed": completed,
                "finished_cleanly": clean, "lever": lever, "on": "base"}  # fmt: skip

    every = pd.DataFrame([trial("base", s, s != 1, s not in (1, 2)) for s in range(20)])
    lift = "rollout=fine_lift variant=base"
    levers = pd.DataFrame(
        [trial("base+rollout=fine_lift", s, True, s != 3, lift) for s in (1, 3)]
        + [trial("base+carry=held", s, True, True, "carry=held variant=base") for s in (12,)]
    )
    text = spec.finer_levers(levers, every)
    base_marks = m["clean"] + m["failed"] + m["completed"] + m["clean"] * 7
    assert f"| stapler | 0-9 | `base` | `{base_marks}` | 9 of 10 | 8 of 10 |" in text
    lever_marks = m["none"] + m["clean"] + m["none"] + m["completed"] + m["none"] * 6
    assert f"| stapler | 0-9 | `rollout=fine_lift` on it | `{lever_marks}` | 2 of 2 | 1 of 2 |" in text
    assert "| stapler | 10-19 |" not in text and "carry=held" not in text  # no planning model of its own
    assert spec.finer_levers(levers[levers["lever"] != lift], every) == ""
