"""Method labels and config keys across versions: one map that resuming and the analysis both read.

A method is a ``variant`` (the paper's ``full``, ``no_contact``, ``joint_space``; ``replay``, ``robust``; or a
named combination such as ``wrist_clearance``) with twelve independent groups on top: ``wrist`` (``fixed |
sampled | acquire | carry``), ``shaping`` (``none | surface | clearance | clearance_grasp``), ``release``
(``none | reset | open | scheduled | flat | backoff | eased | ...``), ``compensation`` (``none | predict``),
``effort`` (``uniform | acquire | acquire_half | acquire_short | acquire_long | acquire_grasped |
acquire_waiting | acquire_error``), ``place`` (``none | wrist``), ``pacing`` (``none | hold | lift | release |
...``), ``carry`` (``none | wrist | pose | held``), ``grip`` (``none | squeeze | carried | touched``),
``retarget`` (``none | wrist``), ``rollout`` (``paper | fine``) and ``reuse`` (``none | elites |
elites_expected | elites_grasped | ...``).
Records made before the groups existed name the combination by one variant label (``variant:
release_flat``); records made before the release schedule was one object store its options as flat sampler
keys (``sampler.release_pause``); records made before a group existed read as its default.

- :func:`method_labels` reads a record's labels, old or new, as ``{variant, wrist, shaping, release,
  compensation, effort, place, pacing, carry, grip, retarget, rollout, reuse}``;
- :func:`method_name` names the method of those labels, the same name for an old record and a new
  one of the same combination (the old variant's name where it had one: ``wrist_acquire``), by which
  the analysis groups trials;
- :func:`upgrade_config` rewrites an old record's config to today's keys, so a resume and the
  analysis compare it with a config composed now.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping
from typing import Any

from contactmpc.control.release import ReleaseSchedule

GROUPS: dict[str, str] = {
    "wrist": "fixed",
    "shaping": "none",
    "release": "none",
    "compensation": "none",
    "effort": "uniform",
    "place": "none",
    "pacing": "none",
    "carry": "none",
    "grip": "none",
    "retarget": "none",
    "rollout": "paper",
    "reuse": "none",
}
"""The method's groups on top of the variant, each with its default member (the paper's method)."""

NAMED_VARIANTS: dict[str, str] = {
    "wrist": "full",
    "wrist_clearance": "full",
    "grasp_release": "full",
    "grasp_release_ahead": "full",
    "grasp_release_ahead_acquire": "full",
    "grasp_held_eased": "full",
    "grasp_held_eased_refined": "full",
    "grasp_held_retract": "full",
    "grasp_held_expected": "full",
    "grasp_held_expected_long": "full",
    "grasp_held_expected_paced": "full",
    "grasp_held_expected_adaptive": "full",
}
"""Variants that only select groups (``conf/variant/<name>.yaml``'s defaults), by the variant they
build on: the method is that variant with the groups the record names."""

OLD_VARIANTS: dict[str, dict[str, str]] = {
    "wrist": {"variant": "wrist", "wrist": "sampled"},
    "wrist_acquire": {"variant": "full", "wrist": "acquire"},
    "surface": {"variant": "full", "shaping": "surface"},
    "clearance": {"variant": "full", "shaping": "clearance"},
    "wrist_surface": {"variant": "full", "wrist": "acquire", "shaping": "surface"},
    "wrist_clearance": {"variant": "wrist_clearance", "wrist": "acquire", "shaping": "clearance"},
    "release_reset": {"variant": "full", "release": "reset"},
    "release": {"variant": "full", "release": "open"},
    "release_scheduled": {"variant": "full", "release": "scheduled"},
    "release_flat": {"variant": "full", "release": "flat"},
    "release_backoff": {"variant": "full", "release": "backoff"},
}
"""Variant labels of records made before the groups (``conf/variant`` had one file per combination):
the labels the same trial gets now. A label not here is today's variant with the groups' defaults."""

NAMED_METHODS: dict[str, dict[str, str]] = {
    "grasp_release": {
        "variant": "grasp_release",
        "wrist": "acquire",
        "shaping": "clearance",
        "release": "flat",
    },
    "grasp_release_ahead": {
        "variant": "grasp_release_ahead",
        "wrist": "acquire",
        "shaping": "clearance",
        "release": "flat",
        "compensation": "predict",
    },
    "grasp_release_ahead_acquire": {
        "variant": "grasp_release_ahead_acquire",
        "wrist": "acquire",
        "shaping": "clearance",
        "release": "flat",
        "compensation": "predict",
        "effort": "acquire",
    },
    "grasp_held_eased": {
        "variant": "grasp_held_eased",
        "wrist": "acquire",
        "shaping": "clearance",
        "release": "eased",
        "compensation": "predict",
        "effort": "acquire",
        "carry": "held",
    },
}
"""Variants of today that name a combination of groups (``conf/variant/<name>.yaml``'s defaults), read
as :data:`OLD_VARIANTS` are: the method's name for those groups (``variant=grasp_release
compensation=predict`` is ``grasp_release_ahead``)."""
# grasp_held_eased with its planning model refined once it mispredicts the object
NAMED_METHODS["grasp_held_eased_refined"] = {
    **NAMED_METHODS["grasp_held_eased"],
    "variant": "grasp_held_eased_refined",
    "rollout": "fine_on_error",
}

# grasp_held_eased letting go of an object on joints by retracting
NAMED_METHODS["grasp_held_retract"] = {
    **NAMED_METHODS["grasp_held_eased"],
    "variant": "grasp_held_retract",
    "release": "retract_articulated",
}

# grasp_held_retract keeping the last plan's runners-up once the reference expects a grasp
NAMED_METHODS["grasp_held_expected"] = {
    **NAMED_METHODS["grasp_held_retract"],
    "variant": "grasp_held_expected",
    "reuse": "elites_expected",
}

# grasp_held_expected with the grasp's 128 samples a plan until 4 s after the first expected contact
NAMED_METHODS["grasp_held_expected_long"] = {
    **NAMED_METHODS["grasp_held_expected"],
    "variant": "grasp_held_expected_long",
    "effort": "acquire_long",
}

# grasp_held_expected whose reference waits for an object it is leaving behind
NAMED_METHODS["grasp_held_expected_paced"] = {
    **NAMED_METHODS["grasp_held_expected"],
    "variant": "grasp_held_expected_paced",
    "pacing": "lift",
}

# grasp_held_expected_paced trying a lost grasp again, with the grasp's samples where the object is off
NAMED_METHODS["grasp_held_expected_adaptive"] = {
    **NAMED_METHODS["grasp_held_expected_paced"],
    "variant": "grasp_held_expected_adaptive",
    "pacing": "lift_retry",
    "effort": "acquire_error",
}

_LABELS: dict[str, dict[str, str]] = {**OLD_VARIANTS, **NAMED_METHODS}

# (variant built on, *groups) -> the old variant's (or the named method's) name
_NAMES: dict[tuple[str, ...], str] = {
    (NAMED_VARIANTS.get(new["variant"], new["variant"]), *(new.get(g, d) for g, d in GROUPS.items())): old
    for old, new in _LABELS.items()
}


def method_labels(labels: Mapping[str, Any]) -> dict[str, str | None]:
    """A record's method labels as today's ``{variant, *GROUPS}`` (the groups of :data:`GROUPS`).

    A record's group labels are read as they are (a group it lacks, or names as ``None``, at its
    default); a variant label in :data:`OLD_VARIANTS` (an old record's, or a name :func:`method_name`
    gave) adds that entry's groups where the labels leave them at their defaults, so reading
    :func:`method_name`'s result again gives the same method.

    A variant label with groups on top, as :func:`method_name` writes them
    (``grasp_release+effort=acquire``), is that variant with those groups.

    Args:
        labels: the record's fields (or any mapping with ``variant`` and the groups' names).
    """
    variant = labels.get("variant")
    if isinstance(variant, str) and "+" in variant:
        base, *more = variant.split("+")
        added = dict(g.split("=", 1) for g in more)
        return method_labels({**labels, "variant": base, **{g: m for g, m in added.items() if g in GROUPS}})
    if variant in _LABELS:
        # an old variant's name, or a method's name that method_name gave: its groups, where the labels
        # leave them unset (so reading a method's own name again gives the same method); an old variant's
        # records also wrote the defaults of groups that did not exist yet, read as the variant's, while a
        # named method's records (today's variants select their groups) write each group's choice, so a
        # group set back to its default there is read as set
        old, explicit = _LABELS[variant], variant in NAMED_METHODS
        given = {g: labels.get(g) for g in GROUPS}
        return {
            "variant": old["variant"],
            **{
                g: given[g] if given[g] is not None and (explicit or given[g] != d) else old.get(g, d)
                for g, d in GROUPS.items()
            },
        }
    return {"variant": variant, **{g: labels.get(g) or d for g, d in GROUPS.items()}}


def method_name(labels: Mapping[str, Any]) -> str | None:
    """The name of the method a record ran (see :func:`method_labels`): the variant's when every
    group is at its default, the old variant's of the combination where there was one
    (``wrist_clearance``, ``release_flat``), else the project's named method it adds groups to followed by
    each of them (``grasp_release+effort=acquire``), else the variant followed by each group off its
    default, ``+group=member`` (``joint_space+wrist=acquire``). ``None`` without a variant label."""
    found = method_labels(labels)
    variant = found["variant"]
    if not isinstance(variant, str) or not variant:
        return None
    groups = tuple(found[g] for g in GROUPS)
    base = NAMED_VARIANTS.get(variant, variant)
    if groups == tuple(GROUPS.values()):
        return base
    if (name := _NAMES.get((base, *groups))) is not None:
        return name
    # a named method with more groups on top: the one naming the most of the record's groups, then the
    # groups it leaves at their defaults (grasp_release+effort=acquire)
    within = [
        (sum(g in named for g in GROUPS), name)
        for name, named in NAMED_METHODS.items()
        if NAMED_VARIANTS.get(named["variant"], named["variant"]) == base
        and all(found[g] == named[g] for g in GROUPS if g in named)
    ]
    if within:
        name = max(within)[1]
        rest = [(g, found[g]) for g, d in GROUPS.items() if g not in NAMED_METHODS[name] and found[g] != d]
        return name + "".join(f"+{g}={m}" for g, m in rest)
    if (named := NAMED_METHODS.get(variant)) is not None:
        # a named method with some of its own groups changed, even back to the default
        # (grasp_held_eased+effort=uniform)
        rest = [(g, found[g]) for g, d in GROUPS.items() if found[g] != named.get(g, d)]
        return variant + "".join(f"+{g}={m}" for g, m in rest)
    return base + "".join(f"+{g}={m}" for g, m in zip(GROUPS, groups, strict=True) if m != GROUPS[g])


RELEASE_TARGET = f"{ReleaseSchedule.__module__}.{ReleaseSchedule.__qualname__}"
"""What ``sampler.release`` builds."""

OLD_RELEASE_KEYS: dict[str, str] = {
    "release_pause": "pause",
    "release_open": "open",
    "release_open_to": "open_to",
    "release_backoff": "backoff",
    "release_backoff_window": "backoff_window",
    "release_reset": "reset",
    "release_noise": "noise",
    "release_window": "window",
}
"""The sampler's release options before they were one object (``sampler.release_pause``), by their
name in :class:`~contactmpc.control.release.ReleaseSchedule` (``sampler.release.pause``)."""

RELEASE_DEFAULTS: dict[str, Any] = {
    p.name: list(p.default) if isinstance(p.default, tuple) else p.default
    for p in inspect.signature(ReleaseSchedule).parameters.values()
}
"""The release schedule's options at their defaults (the paper's method), as a config holds them."""


def upgrade_config(config: Any) -> Any:
    """A record's resolved config with today's keys: wherever a node holds old release options
    (:data:`OLD_RELEASE_KEYS`: the sampler and the trial job's copy of it), they become one
    ``release`` node, ``None`` where every option was at its default (the paper's method, as
    ``sampler.release: null`` is now), else a :data:`RELEASE_TARGET` node with every option. A config
    without old keys is returned as it is; the argument is not changed.

    Raises:
        ValueError: a node holds both old release options and a ``release`` node.
    """
    if not isinstance(config, Mapping):
        return config
    out = {k: upgrade_config(v) for k, v in config.items()}
    old = {k: out.pop(k) for k in OLD_RELEASE_KEYS if k in out}
    if not old:
        return out
    if out.get("release") is not None:
        raise ValueError("a config holds both sampler.release and the old sampler.release_* options")
    options = {**RELEASE_DEFAULTS, **{OLD_RELEASE_KEYS[k]: v for k, v in old.items()}}
    options = {k: list(v) if isinstance(v, tuple) else v for k, v in options.items()}
    out["release"] = None if options == RELEASE_DEFAULTS else {"_target_": RELEASE_TARGET, **options}
    return out
