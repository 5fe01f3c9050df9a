"""Does a cheap trial of the paper's grasp phase (started shortly before the first expected contact, ended
a few seconds after it) rank the method levers of issue 33 as full trials do, at a fraction of their cost?"""

from __future__ import annotations

import inspect
import json
import re
import shlex
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from analysis.inference import completion_test, newcombe
from analysis.prose import median, of, ratio, seeds, span, unchallenged
from analysis.study import REPO
from analysis.summarize import Fmt, Stat, markdown, summarize
from contactmpc.control.guidance import ObjectGuidance
from contactmpc.labels import NAMED_METHODS, method_labels, method_name

TITLE = "The cheap screen of the method levers (issue 33)"
EXPERIMENTS = [
    "bash studies/method_screen/run_screen.sh",
    'SET=method SEEDS="$(seq -s " " 0 19)" bash studies/method_screen/run_screen.sh',
    'SET=method_lift TASKS=paper_apple SEEDS="$(seq -s " " 0 19)" bash studies/method_screen/run_screen.sh',
    'SET=retarget TASKS=paper_apple SEEDS="$(seq -s " " 0 19)" bash studies/method_screen/run_screen.sh',
    'SET=planner_dt TASKS=paper_apple SEEDS="$(seq -s " " 0 19)" bash studies/method_screen/run_screen.sh',
]
#: The full trials of the same variants: the full method at preset=paper_32samples (fig3_paper) and the
#: stapler's wrist_clearance at 32 samples (stapler/records/stapler_clearance).
#: The clearance variant at the paper point (128 samples): the operating_point study's
#: `operating_point=paper`.
RECORDS = ["fig3_paper", "stapler", "operating_point"]

HERE = Path(__file__).resolve().parent
#: The method (the method study's), screened at two latencies (``SET=method``): its own rows, not a lever's.
METHOD = "grasp_release_ahead_acquire"
#: The method study's seeds (0-9), on which the method's groups were chosen; the screen's seeds from 10 on
#: were not.
CHOSEN_ON = range(10)
#: The calibrated latency (ms) at which the method runs (``preset=paper_32samples_calibrated``'s).
CALIBRATED_MS = round(
    1e3
    * yaml.safe_load((REPO / "conf" / "preset" / "paper_32samples_calibrated.yaml").read_text())["planner"][
        "latency"
    ]
)
SCRIPT = HERE / "run_screen.sh"
TASKS = ("paper_stapler", "paper_bottle")
#: The tasks the method and the levers on top of it are screened on (``SET=method``, ``method_levers``, ...;
#: ``TASKS=paper_apple``): the stapler, the task furthest from the target, then the apple, whose lift the
#: method loses.
METHOD_TASKS = ("paper_stapler", "paper_apple")
BASELINES = ("full", "wrist_clearance")
#: Pairs whose order in the screen is checked against full trials: the clearance term against the paper's
#: method, and the clearance variant at the paper point's 128 samples against 32.
PAIRS = (("full", "wrist_clearance"), ("wrist_clearance", "wrist_clearance samples128"))
#: The lever options (column, default, the short name a lever's label gives them).
LEVER_KEYS = (
    ("planner.iterations", 1, "it"),
    ("planner.anneal", 1.0, "anneal"),
    ("planner.early_stop", 0.0, "stop"),
    ("planner.update", "max", ""),
    ("sampler.noise_ramp", 1.0, "ramp"),
    ("planner.num_samples", 32.0, "samples"),
    ("planner.guidance.timeconst", None, "guide"),
)
#: Where each lever option comes from (issue 33).
SOURCES = {
    "planner.iterations": "SPIDER (arXiv 2511.09484), DIAL-MPC",
    "planner.anneal": "SPIDER (arXiv 2511.09484), DIAL-MPC",
    "planner.early_stop": "SPIDER (arXiv 2511.09484), DIAL-MPC",
    "planner.update": "SPIDER (softmax over the top elites)",
    "sampler.noise_ramp": "judo (`optimizers/overrides.py`)",
    "planner.num_samples": "the paper point's samples (the stapler study)",
    "planner.guidance.timeconst": "DexMachina's virtual object controller, annealed as SPIDER's guidance",
    "variant": "this project (the stapler study)",
    "compensation": "this project: plan from the state predicted for when the plan takes effect",
}


def _value(v: object, default: object) -> object:
    if v is None or (isinstance(v, float) and np.isnan(v)):
        return default
    if isinstance(default, int | float) and not isinstance(default, bool):
        try:
            return float(v)
        except (TypeError, ValueError):
            return v
    return v


def _without_compensation(name: str) -> str:
    """A method's name (``full+wrist=acquire+shaping=clearance+compensation=predict``, or a variant's)
    with its compensation group at the default (``wrist_clearance``); a named method's name
    (``grasp_release_ahead``, ``grasp_release_ahead_acquire+pacing=hold``) as it is, as the screen's labels
    have always named its levers."""
    if name.split("+")[0] in NAMED_METHODS:
        return name
    return method_name({**method_labels({"variant": name}), "compensation": "none"})


def lever(row: dict) -> str:
    """A trial's lever: its variant, then each lever option that differs from its default, then
    ``predict`` where it plans from the predicted state (``compensation=predict``)."""
    variant = str(row.get("variant"))
    predict = row.get("compensation") == "predict" or "+compensation=predict" in variant
    parts = [_without_compensation(variant) if predict else variant]
    for key, default, short in LEVER_KEYS:
        v = _value(row.get(key), default)
        if v != _value(default, default):
            text = f"{v:g}" if isinstance(v, float) else str(v)
            parts.append(f"{short}{text}")
    return " ".join(parts + ["predict"] * predict)


def script() -> dict:
    """What ``run_screen.sh`` runs: its common overrides, its levers (each a list of overrides) and seeds."""
    text = SCRIPT.read_text()
    common = re.search(r"COMMON=\((.*?)\)", text, re.S)[1]
    seeds_text = re.search(r"SEEDS:-([0-9 ]+)\}", text)[1]
    levers: list[list[str]] = []  # every LEVERS set (SET=full, clearance, compensation), full's first
    method: list[list[str]] = []  # SET=method: the method itself, not a lever
    blocks = re.findall(r"LEVERS=\((.*?)\n\)", text, re.S)
    for block in sorted(blocks, key=lambda b: b.strip().splitlines()[0].strip().strip('"') != "variant=full"):
        for line in block.strip().splitlines():
            overrides = shlex.split(line.strip().strip('"'))
            into = method if f"variant={METHOD}" in overrides else levers
            if overrides not in into:
                into.append(overrides)
    return {
        "common": dict(o.split("=", 1) for o in shlex.split(common) if "=" in o),
        "levers": levers,
        "method": method,
        "seeds": [int(s) for s in seeds_text.split()],
    }


def frames(study) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The screen's trials (its own records) and the full trials of its baselines (the text's reading at
    ``preset=paper_32samples``, no operating point, no lever option set), each with a ``lever`` column."""
    df = study.records()
    if not len(df):
        return df, df
    df = df[df["task"].isin(TASKS)].copy()
    df = df[np.array([method_name(r) != METHOD for r in df.to_dict("records")], bool)]
    if "planner.num_samples" not in df and "num_samples" in df:
        df["planner.num_samples"] = df["num_samples"]
    for key, _, _ in LEVER_KEYS:
        if key not in df:
            df[key] = None
    df["lever"] = [lever(r) for r in df.to_dict("records")]
    df["lifted"] = df["milestone_lifted"].astype(object) if "milestone_lifted" in df else None
    own = str(study.dir / "records")
    screen = df[df["record_path"].astype(str).str.startswith(own)]
    full = df[~df["record_path"].astype(str).str.startswith(own)]
    full = unchallenged(full)
    chosen = (
        (full["preset"] == "paper_32samples")
        & full["operating_point"].isna()
        & (full["lever"] == full["variant"])
    )
    # the clearance variant at the paper point (preset=paper, the operating-point map's `paper` point:
    # 128 samples, the same 96 ms latency)
    paper_point = (
        (full["preset"] == "paper")
        & full["operating_point"].isin([None, "paper"])
        & (full["lever"] == "wrist_clearance samples128")
    )
    full = full[(full["fidelity"] == "paper") & full["variant"].isin(BASELINES) & (chosen | paper_point)]
    if "job.start_before_contact" in full:
        full = full[full["job.start_before_contact"].isna()]
    full = full[full["seed"].isin(script()["seeds"])]  # the screen's seeds (the Fig. 3 study has more)
    return screen, full


def counted(df: pd.DataFrame) -> pd.DataFrame:
    return df[df["status"].isin(["ok", "diverged"])]


STATS = [
    Stat("seed", "n", name="trials"),
    Stat("completed", "count", name="completed", where=counted),
    Stat("lifted", "count", name="lifted", where=counted),
    Stat("ttf", "median", name="TTF", digits=2, where=counted),
    Stat("cpu_seconds", "median", name="CPU-s", digits=0, where=counted),
]


def table(df: pd.DataFrame, order: list[str]) -> str:
    tasks = list(dict.fromkeys(TASKS + METHOD_TASKS))
    t = summarize(df, by=["lever", "task"], stats=STATS, order={"lever": order, "task": tasks})
    t["seeds"] = [
        seeds(df[(df["lever"] == a) & (df["task"] == b)]["seed"])
        for a, b in zip(t["lever"], t["task"], strict=True)
    ]
    return markdown(t)


def _k(df: pd.DataFrame, column: str) -> tuple[int, int]:
    known = counted(df)[column].dropna().astype(bool)
    return int(known.sum()), len(known)


def orders(
    screen: pd.DataFrame, full: pd.DataFrame, task: str, pair: tuple[str, str], column: str
) -> tuple[dict, dict | None]:
    """Each side's count ``(k, n)`` of ``column`` per lever of ``pair`` in the screen and in full trials,
    and the sign of ``b - a``'s rate in each (``None`` where a side has no trial of a lever)."""
    fracs = {
        (where, v): _k(df[(df["task"] == task) & (df["lever"] == v)], column)
        for where, df in (("screen", screen), ("full", full))
        for v in pair
    }
    if any(n == 0 for _, n in fracs.values()):
        return fracs, None
    a, b = pair
    return fracs, {
        w: np.sign(fracs[w, b][0] / fracs[w, b][1] - fracs[w, a][0] / fracs[w, a][1])
        for w in ("screen", "full")
    }


def ranking(screen: pd.DataFrame, full: pd.DataFrame) -> str:
    """Whether the screen orders each pair of :data:`PAIRS` as the full trials do, per task and outcome."""
    out = []
    for (a, b), task in ((pair, task) for pair in PAIRS for task in TASKS):
        if not all(len(screen[(screen["task"] == task) & (screen["lever"] == v)]) for v in (a, b)):
            continue
        words = []
        for column, word in (("lifted", "lifted"), ("completed", "completed")):
            fracs, sign = orders(screen, full, task, (a, b), column)
            shown = "; ".join(
                f"{w}: `{a}` {of(*fracs[w, a])}, `{b}` {of(*fracs[w, b])}" for w in ("screen", "full")
            )
            if sign is None:
                missing = [f"{w} trials of `{v}`" for (w, v), (_, n) in fracs.items() if n == 0]
                words.append(f"{word} ({shown}): no ranking, no {Fmt.listing(missing)} kept")
                continue
            verdict = (
                "the same order"
                if sign["screen"] == sign["full"]
                else "a tie where the full trials differ"
                if sign["screen"] == 0
                else "the opposite order"
                if sign["screen"] == -sign["full"] and sign["full"] != 0
                else "an order where the full trials tie"
            )
            words.append(f"{word} ({shown}): **{verdict}**")
        out.append(f"- `{b}` against `{a}`, {task}: " + "; ".join(words) + ".")
    return "\n".join(out) + "\n"


def verdict(screen: pd.DataFrame, full: pd.DataFrame) -> str:
    """How many pairs the screen orders as the full trials do (by lifted), and which levers lift the
    stapler more often than the base they are on: the screen's use, computed from the counts."""
    same, seen = [], 0
    for a, b in PAIRS:
        _, order = orders(screen, full, "paper_stapler", (a, b), "lifted")
        if order is None:
            continue
        seen += 1
        if order["screen"] == order["full"]:
            same.append(f"`{b}` against `{a}`")
    better = []
    for on in BASELINES:
        base = screen[(screen["task"] == "paper_stapler") & (screen["lever"] == on)]
        if not len(base):
            continue
        bk, bn = _k(base, "lifted")
        for name in sorted({n for n in screen["lever"] if n.split()[0] == on and n != on}):
            k, n = _k(screen[(screen["task"] == "paper_stapler") & (screen["lever"] == name)], "lifted")
            if n and k / n > bk / bn:
                better.append(f"`{name}` ({of(k, n)} against {of(bk, bn)})")
    if not seen:
        return ""
    return (
        f"- **The screen orders {len(same)} of the {seen} pairs with full trials on both sides as the full "
        "trials do** (the stapler, by the fraction lifted)"
        + (f": {Fmt.listing(same)}" if same else "")
        + ". "
        + (
            "Levers that lift the stapler more often than their base in the screen: "
            + Fmt.listing(better)
            + "."
            if better
            else "No lever lifts the stapler more often than its base in the screen."
        )
        + "\n"
    )


def _options(overrides: list[str]) -> dict:
    """A lever's overrides as the options its records name (a group's member by its settings)."""
    opts = dict(o.split("=", 1) for o in overrides)
    if "compensation" not in opts and "variant" in opts:  # a named variant's groups, as its records name them
        opts["compensation"] = method_labels({"variant": opts["variant"]}).get("compensation")
    if "guidance" in opts:  # guidance=object: the lever is named by its weld's time constant
        member = yaml.safe_load((REPO / "conf" / "guidance" / f"{opts['guidance']}.yaml").read_text())
        default = inspect.signature(ObjectGuidance).parameters["timeconst"].default
        opts["planner.guidance.timeconst"] = float(member.get("timeconst", default))
    return opts


def levers_table(spec: dict) -> str:
    rows = ["| lever (as the tables name it) | overrides | source |", "|---|---|---|"]
    for overrides in spec["levers"]:
        opts = _options(overrides)
        name = lever(opts)
        keys = [k for k in opts if k not in ("variant", "guidance")] or ["variant"]
        sources = list(dict.fromkeys(SOURCES.get(k, "") for k in keys if SOURCES.get(k)))
        if opts.get("variant") == "full" and keys == ["variant"]:
            sources = ["the paper's method (the baseline)"]
        rows.append(f"| {name} | `{' '.join(overrides)}` | {'; '.join(sources)} |")
    return "\n".join(rows) + "\n"


def cost(screen: pd.DataFrame, full: pd.DataFrame) -> str:
    parts = []
    for task in TASKS:
        s = counted(screen[(screen["task"] == task) & (screen["lever"] == "full")])["cpu_seconds"]
        f = counted(full[(full["task"] == task) & (full["lever"] == "full")])["cpu_seconds"]
        if len(s) and len(f):
            parts.append(
                f"{median(s)} CPU-s on {task} against {median(f)} for a full trial "
                f"({ratio(np.median(s), np.median(f), '{:.2f}')} of it; "
                f"medians over {len(s)} and {len(f)} trials)"
            )
    return "; ".join(parts)


def elite_options(screen: pd.DataFrame) -> str:
    rows = screen[screen["planner.update"] == "elite_softmax"]
    if not len(rows):
        return ""
    planner = (json.loads(Path(rows["record_path"].iloc[0]).read_text()).get("config") or {}).get(
        "planner"
    ) or {}
    opts = [f"`planner.{k}={planner[k]}`" for k in ("elite_fraction", "temperature") if k in planner]
    return f" (with {' and '.join(opts)}, as its records say)" if opts else ""


def findings(screen: pd.DataFrame, full: pd.DataFrame) -> str:
    out = []
    st = screen[(screen["task"] == "paper_stapler") & (screen["lever"] == "full")]
    ft = full[(full["task"] == "paper_stapler") & (full["lever"] == "full")]
    if len(st) and len(ft):
        out.append(
            f"- **The screen reproduces the stapler's failure under the paper's method**: the `full` screen "
            f"trials lift it {of(*_k(st, 'lifted'))} and lose it at {span(st['failure_time'], '{:.1f}')} s "
            f"(reference time), the full trials lift it {of(*_k(ft, 'lifted'))} and lose it at "
            f"{span(ft['failure_time'], '{:.1f}')} s."
        )
    for task, on in ((task, on) for on in BASELINES for task in TASKS):
        base = screen[(screen["task"] == task) & (screen["lever"] == on)]
        levers = {n for n in screen.loc[screen["task"] == task, "lever"] if n.split()[0] == on and n != on}
        if not len(base) or not levers:
            continue
        bl, bn = _k(base, "lifted")
        bc, _ = _k(base, "completed")
        base_cpu = counted(base)["cpu_seconds"].median()
        items = []
        for name in sorted(levers):
            g = screen[(screen["task"] == task) & (screen["lever"] == name)]
            lk, ln = _k(g, "lifted")
            ck, cn = _k(g, "completed")
            items.append(
                f"`{name}` lifted {of(lk, ln)}, completed {of(ck, cn)}, median TTF "
                f"{median(counted(g)['ttf'], '{:.2f}')}, CPU-s × "
                f"{ratio(counted(g)['cpu_seconds'].median(), base_cpu, '{:.2f}')}"
            )
        out.append(
            f"- {task}, against `{on}` in the screen (lifted {of(bl, bn)}, completed {of(bc, bn)}, "
            "median TTF "
            f"{median(counted(base)['ttf'], '{:.2f}')}): " + "; ".join(items) + "."
        )
    return "\n".join(out) + "\n"


def _shared(a: pd.DataFrame, b: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame, list[int]]:
    """``a`` and ``b``'s trials that count, on the seeds both have, and those seeds."""
    a, b = counted(a), counted(b)
    both = sorted(set(a["seed"]) & set(b["seed"]))
    return a[a["seed"].isin(both)], b[b["seed"].isin(both)], both


def _pair(task: str, a: pd.DataFrame, b: pd.DataFrame, name_a: str, name_b: str) -> str | None:
    """One comparison line: ``a`` against ``b`` on the seeds both have (lifted and completed with Barnard's
    test, median TTF, CPU-s ratio); ``None`` where they share no seed."""
    a, b, both = _shared(a, b)
    if not both:
        return None
    parts = []
    for what in ("lifted", "completed"):
        (ak, an), (bk, bn) = _k(a, what), _k(b, what)
        p, _ = completion_test(ak, an, bk, bn)
        parts.append(f"{what} {ak} of {an} against {bk} of {bn} (Barnard p = {p:.3g})")
    return (
        f"- {task}, {name_a} against {name_b}, seeds {seeds(both)}: " + "; ".join(parts) + "; median TTF "
        f"{median(a['ttf'], '{:.2f}')} against {median(b['ttf'], '{:.2f}')}; CPU-s × "
        f"{ratio(a['cpu_seconds'].median(), b['cpu_seconds'].median(), '{:.2f}')}."
    )


def guidance_findings(screen: pd.DataFrame, method: pd.DataFrame | None = None) -> str:
    """Contact guidance (a lever named ``… guide<timeconst> …``) against the same lever without it, per task
    on the seeds both have (lifted and completed counts, Barnard's test of each, median TTF, the CPU-s
    ratio); where the lever builds on the method's groups (``SET=guidance_method``), both also against the
    method in the screen at the calibrated latency (``method``: the screen rows of :func:`method_frames`'s
    ``method``)."""
    out = []
    the_method = f"the method (`{METHOD}`: one iteration of 128 samples while contact is acquired)"
    for name in sorted({n for n in screen["lever"] if " guide" in n}):
        base = re.sub(r" guide\S+", "", name)
        items = []
        for task in TASKS:
            g = screen[(screen["task"] == task) & (screen["lever"] == name)]
            b = screen[(screen["task"] == task) & (screen["lever"] == base)]
            pairs = [(g, b, "with the guidance", "without it")]
            if method is not None and name.startswith("grasp_release_ahead "):
                m = method[(method["task"] == task) & (method["latency_ms"] == CALIBRATED_MS)]
                pairs += [(g, m, "with the guidance", the_method), (b, m, "without it", the_method)]
            items += [line for a, c, x, y in pairs if len(a) and len(c) and (line := _pair(task, a, c, x, y))]
        if items:
            out += [f"**Contact guidance**, `{name}` against `{base}` (`guidance=object`, "
                    "`contactmpc.control.guidance`):", *items]  # fmt: skip
    if not out:
        return ""
    return (
        "\n".join(out)
        + "\n\nWith the guidance on, every iteration of a plan runs (early stopping waits for the last, "
        "unguided one), so a guided plan costs its iterations' rollouts in full.\n"
    )


#: Options that make a lever on top of the method itself (``SET=method_levers``): column, the method's
#: value, the short name a lever's label gives it.
METHOD_LEVER_KEYS = (
    ("planner.acquire_until", 2.0, "until"),
    ("sampler.root_sigma2", 1e-4, "wristvar"),
    ("sampler.root_rotation_sigma2", 0.01, "wristrot"),
    ("cost.lambda_c", 1.0, "contact"),
    ("cost.lambda_o", 1.0, "object"),
    ("cost.surface_weight", 0.0, "surface"),
    ("pacing", "none", "pace"),
    ("planner.pace_rate", 0.0, "rate"),
    ("retarget", "none", "retarget="),
    ("scene.planner_timestep", 0.01, "dt"),
    ("cost.clearance_links", 0, "links"),
)

#: What each lever on top of the method is, by its name's key (:data:`METHOD_LEVER_KEYS`' short names).
METHOD_LEVER_TEXT = {
    "until": "`until3`: the grasp's phase (the wrist sampled, 128 samples a plan) held to 3 s after the "
    "first expected contact instead of 2 s (`planner.acquire_until=3.0 sampler.root_window=[-1.0,3.0]`: the "
    "reference starts lifting the stapler 1.4-1.7 s after its first contact, the apple 1.9 s after it)",
    "wristvar": "`wristvar0.0004`: the wrist's sampling variance on its slides four times the method's "
    "(`sampler.root_sigma2=4.0e-4`: 2 cm instead of 1)",
    "wristrot": "`wristrot0.0025`: the wrist's rotation sampled with a quarter of the method's variance "
    "(`sampler.root_rotation_sigma2=0.0025`: 0.05 rad instead of 0.1)",
    "contact": "`contact3`: the contact term weighted three times the method's (`cost.lambda_c=3.0`; the "
    "clearance term, weighted by it too, with it)",
    "object": "`object3`: the object term weighted three times the method's (`cost.lambda_o=3.0`)",
    "surface": "`surface1`: the surface term on top of the clearance term (`cost.surface_weight=1.0`: each "
    "link whose contact is expected pulled onto the stapler wherever it touches it, read from the clearance "
    "term's distance sensors)",
    "pace": "`pacehold`: the reference paced by the stapler (`pacing=hold`: the reference's clock holds "
    "while the stapler is more than 2 cm from where the reference has it, up to 3 s in all, so the lift "
    "waits for a grasp, and the grasp's phase, 128 samples a plan, lasts while it holds; the trial runs 3 s "
    "longer)",
    "rate": "`pacehold rate0.3`: the same with the reference's clock slowed to 0.3 instead of held while the "
    "stapler lags (`planner.pace_rate=0.3`: the lift slowed, not stopped)",
    "dt": "`dt0.005`: the planning model stepped at 5 ms instead of 10 (`scene.planner_timestep=0.005`: "
    "twice the steps a rollout, so about twice the CPU-s a plan; the plant's 1 ms unchanged)",
    "links": "`links5`: the clearance term holds every link off the object until the reference first "
    "expects 5 links in contact at once (`cost.clearance_links=5`; the method: each link until its own first "
    "expected contact), so the stapler's index, which the reference has alone on it for its first 0.3 s, "
    "does not touch it before the grasp has five links",
    "retarget=": "`retarget=wrist`: the reference's grasp corrected by one wrist translation (the "
    "offset of the wrist's slides that best puts the links the reference expects in contact on the object's "
    "surface, eased in over 1 s before the first expected contact; the retargeted grasp passes the "
    "fingertips into the object and keeps the palm off it)",
}


def method_lever(row: dict) -> str:
    """A trial of the method's lever: each :data:`METHOD_LEVER_KEYS` option that differs from the method's
    (``until3 wristvar0.0004``); ``""`` for the method itself."""
    parts = []
    for key, default, short in METHOD_LEVER_KEYS:
        v = _value(row.get(key), default)
        if v != default:
            parts.append(f"{short}{v:g}" if isinstance(v, float) else f"{short}{v}")
    return " ".join(parts)


def method_frames(study) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The method's trials on :data:`METHOD_TASKS` at plans every 170 ms (the calibrated loop): its screen
    trials (``SET=method``) and the method study's full trials (its records and its ``latency/`` runs), with
    ``where`` (``screen`` / ``full``), ``latency_ms`` and ``half`` (seeds 0-9, the method study's, or
    10-19); and, apart, the trials of levers on top of it (``SET=method_levers``), with their
    ``method_lever`` (:func:`method_lever`). The records are read once for both."""
    df = study.records("method", "method/latency")
    if not len(df):
        return df, df
    df = df.assign(method_lever=[method_lever(r) for r in df.to_dict("records")])
    # the method, or the method with its reference paced (a lever on it, pacing=hold)
    names = [method_name(r) or "" for r in df.to_dict("records")]
    ours = np.array(
        [
            n == METHOD or n.startswith((f"{METHOD}+pacing=", f"{METHOD}+retarget=", f"{METHOD}+rollout="))
            for n in names
        ],
        bool,
    )
    df = df[df["task"].isin(METHOD_TASKS).to_numpy() & ours]
    df = df[(df["replan_interval"] - 0.17).abs() < 1e-6].copy()  # not the runs planning every 60 ms
    if "planner.approach_reset" in df:  # the method itself, not a lever on top of it
        df = df[df["planner.approach_reset"].isna()]
    own = str(study.dir / "records")
    df["where"] = np.where(df["record_path"].astype(str).str.startswith(own), "screen", "full")
    df = df[(df["where"] == "screen") | df["job.start_before_contact"].isna()]
    df["latency_ms"] = (1e3 * df["latency"]).round().astype(int)
    df["half"] = np.where(df["seed"].isin(CHOSEN_ON), HALVES[0], HALVES[1])
    df["lifted"] = df["milestone_lifted"].astype(object)
    lever = df["method_lever"].ne("")
    return df[~lever], df[lever]


#: The two halves of the screen's seeds.
HALVES = ("0-9", "10-19")


def _compared(what: str, a: tuple[int, int], b: tuple[int, int]) -> str:
    """A bullet: two lifted counts, the difference in rate with Newcombe's interval and Barnard's p."""
    p, floor = completion_test(*a, *b)
    d, lo, hi = newcombe(*a, *b)
    return (
        f"- {what}: lifted {of(*a)} against {of(*b)}, a difference of {100 * d:+.0f} points (95 % interval "
        f"{100 * lo:+.0f} to {100 * hi:+.0f}; Barnard's exact two-sided p = {Fmt.p(p)}, the smallest these "
        f"counts allow {Fmt.p(floor)})."
    )


def _screened(method: pd.DataFrame) -> pd.DataFrame | None:
    """The method's screen trials (of :func:`method_frames`'s ``method``), ``None`` without any."""
    return method[method["where"] == "screen"] if len(method) else None


#: How far (m) the reference's object rises over its height at the first expected contact where it counts
#: as lifting (:func:`pacing_waits`).
LIFT_START = 0.005


def pacing_waits(paced: pd.DataFrame) -> str | None:
    """What the paced trials' reference did, from their time series (``reference_time``): how many waited,
    the most it fell behind control time (median), how many waited the whole budget, when the first wait
    began against where the reference starts lifting the object (its expected height :data:`LIFT_START`
    over the height at the first expected contact), and how far the object rose while the reference stood
    still; ``None`` without a paced trial's time series."""
    rows = []
    for r in counted(paced).itertuples():
        path = Path(r.record_path).parent / "timeseries.npz"
        if not path.is_file():
            continue
        series = np.load(path)
        if "reference_time" not in series.files:
            continue
        t, ref = series["time"], series["reference_time"]
        behind = t - ref
        still = np.flatnonzero(np.diff(ref) <= 1e-12)  # rows after which the reference stood still
        z, expected = series["object_qpos"][:, 2], series["expected_object_qpos"][:, 2]
        span = t >= r.contact_span_start
        lifts = t[span][expected[span] > expected[span][0] + LIFT_START]
        start = float(t[still[0]] - lifts[0]) if len(still) and len(lifts) else np.nan
        budget = json.loads(Path(r.record_path).read_text())["config"]["planner"]["pace_budget"]
        rise = float((z[still + 1] - z[still]).sum())
        rows.append((behind.max(), behind.max() >= budget - 1e-6, start, rise))
    if not rows:
        return None
    most, whole, start, rise = (np.array(c) for c in zip(*rows, strict=True))
    waited = most > 0
    return (
        f"- `pacehold`, from its {len(rows)} trials' time series: the reference waited in "
        f"{int(waited.sum())} of {len(rows)}, falling {median(most[waited], '{:.1f}')} s behind (median), "
        f"the whole budget in {int(whole.sum())}; the first wait began {median(start[waited], '{:+.2f}')} s "
        "from where the reference starts lifting the stapler (median); while the reference stood still the "
        f"stapler rose {median(1e3 * rise[waited], '{:.1f}')} mm (median; {1e3 * rise.min():.1f} to "
        f"{1e3 * rise.max():.1f}). The hand's targets are the policy read at the reference's time, so they "
        "stand still while it waits."
    )


def method_levers_section(levers: pd.DataFrame, method: pd.DataFrame) -> str:
    """Each lever on top of the method (``levers``, of :func:`method_frames`) against the method's own
    screen trials at the calibrated latency (``method``, of :func:`method_frames`), on the seeds both have:
    a table, and per lever the counts with Barnard's test, median TTF and the CPU-s ratio."""
    levers = levers[levers["where"] == "screen"] if len(levers) else levers
    if not len(levers):
        return ""
    base = method[(method["where"] == "screen") & (method["latency_ms"] == CALIBRATED_MS)]
    by = dict(tuple(levers.groupby("method_lever", sort=True)))
    both = pd.concat([base.assign(lever=METHOD), *(g.assign(lever=f"{METHOD} {n}") for n, g in by.items())])
    shown = {
        short for _, _, short in METHOD_LEVER_KEYS if any(w.startswith(short) for n in by for w in n.split())
    }
    lines, better = [], []
    for n, g in by.items():
        for task in METHOD_TASKS:
            mine, theirs = g[g["task"] == task], base[base["task"] == task]
            if line := _pair(task, mine, theirs, f"`{n}`", "the method"):
                lines.append(line)
            a, b, _ = _shared(mine, theirs)
            (ak, an), (bk, bn) = _k(a, "lifted"), _k(b, "lifted")
            if an and bn and ak / an > bk / bn and completion_test(ak, an, bk, bn)[0] < 0.05:
                better.append(f"`{n}` ({task.removeprefix('paper_')})")
    if "pacehold" in by and (waits := pacing_waits(by["pacehold"])):
        lines.append(waits)
    lines.append(
        "Levers that lift the object more often than the method on the same seeds (Barnard p < 0.05): "
        + (", ".join(better) if better else "none")
        + "."
    )
    return (
        "## Levers on top of the method\n\n"
        f"`SET=method_levers`, `method_cost`, `method_cost2`, `method_pacing`: the method (`{METHOD}`, its "
        f"preset, {CALIBRATED_MS} ms) with an option changed (two together: a name of two words), on the "
        "stapler's screen, against the method's own screen trials (`SET=method`) on the same seeds; "
        "`SET=method_lift TASKS=paper_apple`: the method and `until3` on the apple's screen (the window ends "
        "before the apple is handed off, so no apple screen trial completes: `lifted` is its measure); "
        "`SET=retarget TASKS=paper_apple`: `retarget=wrist` on the apple's screen, against the method's "
        "trials of `SET=method_lift`; `SET=planner_dt TASKS=paper_apple`: `dt0.005` on the apple's screen, "
        "against the same; `SET=clearance_links` (`TASKS=paper_stapler`, then `paper_apple`): `links5` on "
        "both screens. "
        + "; ".join(text for short, text in METHOD_LEVER_TEXT.items() if short in shown)
        + ".\n\n"
        + table(both, [METHOD, *(f"{METHOD} {n}" for n in by)])
        + "\n"
        + "\n".join(lines)
        + "\n"
    )


def method_section(df: pd.DataFrame) -> str:
    """The method in the screen at the calibrated latency and with plans applied after 60 ms, against its
    full trials (on the seeds it was chosen on), and the screen's two halves of seeds against each other."""
    df = df[df["task"] == "paper_stapler"] if len(df) else df  # (the apple's screen: one latency, no halves)
    if not len(df) or not (df["where"] == "screen").any():
        return ""
    lats = sorted(set(df.loc[df["where"] == "screen", "latency_ms"]), reverse=True)
    t = summarize(
        df,
        by=["where", "latency_ms", "half"],
        stats=STATS,
        order={
            "where": ["screen", "full"],
            "latency_ms": sorted(set(df["latency_ms"]), reverse=True),
            "half": list(HALVES),
        },  # fmt: skip
    )
    t["seeds"] = [
        seeds(df[(df["where"] == w) & (df["latency_ms"] == lat) & (df["half"] == h)]["seed"])
        for w, lat, h in zip(t["where"], t["latency_ms"], t["half"], strict=True)
    ]
    t = t.drop(columns="half").rename(columns={"where": "trial", "latency_ms": "latency (ms)"})

    def count(where: str, lat: int, half: str | None, column: str = "lifted") -> tuple[int, int]:
        g = df[(df["where"] == where) & (df["latency_ms"] == lat)]
        return _k(g if half is None else g[g["half"] == half], column)

    out = []
    for lat in lats:
        screen, full = count("screen", lat, None), count("full", lat, None)
        if screen[1] and full[1]:
            out.append(_compared(f"{lat} ms, the screen (every seed) against the full trials", screen, full))
    if len(lats) == 2:
        sides = [count("screen", lat, None) for lat in lats]
        out.append(_compared(f"the screen, {lats[0]} against {lats[1]} ms (every seed)", *sides))
    for lat in lats:
        sides = [count("screen", lat, half) for half in HALVES]
        if all(n for _, n in sides):
            out.append(_compared(f"the screen at {lat} ms, seeds {HALVES[0]} against {HALVES[1]}", *sides))
    return (
        "## The method in the screen: its grasp, at two latencies\n\n"
        f"`SET=method`: the method (`{METHOD}` at its own preset, `paper_32samples_calibrated`) on the "
        "stapler's screen with each plan applied 170 ms after its state (the calibrated latency) and after "
        "60 ms (`planner.latency=0.06`; plans still every 170 ms), beside its full trials at the same timing "
        "(the method study's records and its `latency/` runs), which its groups were chosen on (seeds "
        f"{seeds(CHOSEN_ON)}). A screen trial's generator starts with the screen, 3 s before the contact, so "
        "its random draws at the grasp are not those of the full trial of the same seed: no screen seed was "
        f"chosen on, and the halves {HALVES[0]} and {HALVES[1]} are alike by design (a difference between "
        "them is chance). `lifted`: the record's `milestone_lifted` (in the screen the window ends 4 s after "
        "the first contact, so `completed` there is the stapler lifted and turned, not the set-down).\n\n"
        + markdown(t)
        + "\n"
        + "\n".join(out)
        + "\n"
    )


def report(study) -> str:
    spec = script()
    common = spec["common"]
    before, after = common["job.start_before_contact"], common["job.end_after_contact"]
    screen, full = frames(study)
    method, levers = method_frames(study)
    paper = yaml.safe_load((REPO / "conf" / "preset" / "paper.yaml").read_text())["planner"]["num_samples"]
    it = screen[screen["planner.iterations"].fillna(1).astype(float) > 1]
    n_it, n_s = (int(it["planner.iterations"].max()), int(it["num_samples"].max())) if len(it) else (0, 0)
    rollouts = (
        f"`planner.iterations={n_it}` at {n_s} samples runs at most {n_it * n_s} rollouts a plan, the "
        f"paper point's {paper} (`preset=paper`); "
        if len(it)
        else ""
    )
    latency = median(screen["latency"], "{:.0f}", scale=1000) if "latency" in screen else "-"
    lever_order = [lever(_options(ov)) for ov in spec["levers"]]
    shown = " ".join(f"{k}={v}" for k, v in common.items() if not k.startswith(("hydra", "task")))
    seen = sorted(set(screen["seed"].dropna().astype(int))) if len(screen) else []
    return (
        f"{study.question}\n\n"
        "## What the screen is\n\n"
        f"A screen trial starts the paper's task from the reference's state {before} s before its first "
        f"expected contact and ends it {after} s after (`job.start_before_contact={before} "
        f"job.end_after_contact={after}`): the hand at the reference's targets then, the object at the "
        "reference's configuration then, both at rest, the controller's clock starting there "
        "(`contactmpc.trial.Trial`'s `start_time`; the record says `start_time`). TTF, milestones and errors "
        "are measured the same way on what it logs: the contact span is the window's, and a milestone taken "
        "relative to the reference (the stapler's `turned`, the bottle's `poured`) is relative to the "
        "reference inside the window. On the stapler the window holds the grasp and the lift, where the full "
        "trials of the paper's method lose it; on the bottle the grasp, the lift and the start of the "
        "transport, not the pour (where the full trials fail): `completed` there does not include the pour; "
        "to screen the pour the window needs a later end (`job.end_after_contact=12`).\n\n"
        "Starting 1 s before the contact instead (`job.start_before_contact=1.0`) was too late: the stapler, "
        "seed 0, was lifted and turned in the screen where every full trial of the method fails (a trial "
        "whose record was not kept): the full trial's hand arrives with what the seconds of sampling before "
        "the contact did to the nominal, the screen's with the reference's own.\n\n"
        f"Common overrides (`run_screen.sh`): `{shown}`, "
        f"on `task={common.get('task', '')}`, seeds {seeds(spec['seeds'])} planned (seeds vary slowest, so a "
        f"sweep stopped early holds every lever at the seeds it reached; kept so far: {seeds(seen)}).\n\n"
        f"**Cost**: a screen trial of `variant=full` costs {cost(screen, full)}.\n\n"
        f"{study.provenance(pd.concat([screen, full]))}\n\n"
        "## The levers screened\n\n"
        "Each on top of `variant=full` (`SET=full`, the default) or of `variant=wrist_clearance` "
        "(`SET=clearance`, on the stapler only), whose first word it names; `SET=compensation` runs both "
        "bases planning from the predicted state (`predict`, on both tasks).\n\n"
        + levers_table(spec)
        + f"\n`planner.update=elite_softmax`{elite_options(screen)}. {rollouts}the fixed "
        f"{latency} ms latency of `preset=paper_32samples` (median of the screen's records) is the paper "
        "point's latency, so it charges them. With `planner.latency_model` the latency is priced from "
        "`iterations x (samples + 1 for elite_softmax)`.\n\n"
        "## The screen (per lever and task)\n\n"
        "`lifted`: the record's `milestone_lifted`; TTF and CPU-s are medians over the trials that count "
        "(status ok or diverged).\n\n"
        + table(screen, lever_order)
        + "\n## The full trials of the same variants\n\n"
        "The text's reading (`fidelity=paper`) at `preset=paper_32samples`, no operating point, no lever "
        "option: `variant=full` from the Fig. 3 study, the stapler's `variant=wrist_clearance` from the "
        "stapler study (`stapler_clearance`; at 128 samples, `preset=paper`, its paper point).\n\n"
        + table(full, list(dict.fromkeys(full["lever"])) if len(full) else list(BASELINES))
        + "\n## Does the screen rank the levers as full trials do?\n\n"
        "Each pair by the fraction lifted and the fraction completed, in the screen and in full trials:\n\n"
        + ranking(screen, full)
        + "\n## What the records show\n\n"
        + verdict(screen, full)
        + findings(screen, full)
        + (f"\n{guided}" if (guided := guidance_findings(screen, _screened(method))) else "")
        + (f"\n{section}" if (section := method_section(method)) else "")
        + (f"\n{section}" if (section := method_levers_section(levers, method)) else "")
    )
