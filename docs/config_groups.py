"""The config groups of ``conf/``, as Markdown, made from the YAML files and the config schemas.

Used by ``hooks.py`` at build time (the ``<!-- config-groups -->`` marker of
``guide/config-groups.md``), so the page cannot drift from the configs. ``python docs/config_groups.py``
prints it.

Per group: its default (from ``conf/config.yaml``'s defaults list) and its members. A member that builds
an object (a ``_target_``) gets the target, the first line of its docstring and one row per field of its
schema (``contactmpc.config.schema_for``: the constructor's parameters with their defaults), with the
member's own value where its YAML sets one and the first sentence of the parameter's description in the
``Args:`` of the docstrings up the class's MRO. A member without a target (``# @package _global_``: a
variant, preset, experiment, ...) gets what it sets: the groups it overrides and its values. Every member
shows its YAML in a collapsed block.
"""

from __future__ import annotations

import dataclasses
import inspect
import os
import re
import sys
import typing
from pathlib import Path
from typing import Any

from griffe_roles import split_grouped  # beside this file

ROOT = Path(__file__).resolve().parent.parent
CONF = ROOT / "conf"

_ROLE = re.compile(r":(?:py:)?[a-z]+:`~?([^`]+)`")


def _setup() -> None:
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    os.environ.setdefault("MUJOCO_GL", "egl")


# --------------------------------------------------------------------------------------- docstrings


def _plain(text: str) -> str:
    """Docstring text as one Markdown line: Sphinx roles as code, ``x`` as `x`, table-safe."""
    text = _ROLE.sub(
        lambda m: f"``{m.group(1).rsplit('.', 1)[-1] if '~' in m.group(0) else m.group(1)}``", text
    )
    text = text.replace("``", "`")
    text = " ".join(text.split())
    return text.replace("|", "\\|")


def _first_sentence(text: str) -> str:
    """Up to the first ``.`` or ``;`` outside parentheses that ends a word (``e.g.``, ``i.e.`` go on)."""
    text = " ".join(text.split())
    depth = 0
    for i, char in enumerate(text):
        depth += {"(": 1, ")": -1, "[": 1, "]": -1}.get(char, 0)
        if char in ".;" and depth <= 0 and (i + 1 == len(text) or text[i + 1] == " "):
            if not text[max(0, i - 3) : i + 1].endswith(("e.g.", "i.e.")):
                return text[:i]
    return text.rstrip(".;:")


def summary(obj: Any) -> str:
    """The first line (paragraph) of an object's docstring, or ``""``."""
    doc = inspect.getdoc(obj) or ""
    return _plain(doc.split("\n\n", 1)[0])


def arg_docs(obj: Any) -> dict[str, str]:
    """Parameter name -> the first sentence of its description, from the Google-style ``Args:``
    sections of the docstrings of ``obj`` (a function) or of a class, its ``__init__`` and its bases."""
    sources = []
    if inspect.isclass(obj):
        for cls in obj.__mro__:
            if cls is object:
                continue
            sources += [cls.__dict__.get("__doc__"), getattr(cls.__dict__.get("__init__"), "__doc__", None)]
    else:
        sources.append(getattr(obj, "__doc__", None))
    found: dict[str, str] = {}
    for doc in sources:
        if not doc:
            continue
        lines = split_grouped(inspect.cleandoc(doc)).splitlines()
        for i, line in enumerate(lines):
            if line.strip() not in ("Args:", "Arguments:", "Parameters:"):
                continue
            indent = None
            name, parts = None, []
            for item in lines[i + 1 :]:
                if not item.strip():
                    continue
                lead = len(item) - len(item.lstrip())
                if indent is None:
                    indent = lead
                if lead < indent:
                    break
                match = re.match(r"(\w+)\s*(?:\([^)]*\))?:\s*(.*)", item.strip()) if lead == indent else None
                if match:
                    if name and not " ".join(parts).lower().startswith("see "):  # a base documents it
                        found.setdefault(name, " ".join(parts))
                    name, parts = match.group(1), [match.group(2)]
                elif name:
                    parts.append(item.strip())
            if name and not " ".join(parts).lower().startswith("see "):
                found.setdefault(name, " ".join(parts))
    return {k: _plain(_first_sentence(v)) for k, v in found.items() if v}


# -------------------------------------------------------------------------------------------- YAML


def _value(value: Any) -> str:
    """A config value as it would be written on the command line."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {_value(v)}" for k, v in value.items()) + "}"
    return str(value)


def _code(value: Any) -> str:
    text = _value(value).replace("|", "\\|")
    text = text if len(text) <= 80 else text[:77] + "..."
    return f"`{text}`"


def _flatten(node: Any, prefix: str = "") -> list[tuple[str, Any]]:
    if isinstance(node, dict) and node and "_target_" not in node:
        out = []
        for key, value in node.items():
            out += _flatten(value, f"{prefix}.{key}" if prefix else str(key))
        return out
    return [(prefix, node)]


def leading_comment(path: Path) -> str:
    """The comment block at the top of a YAML file (its ``# @package`` line left out)."""
    lines = []
    for line in path.read_text(encoding="utf-8").splitlines():
        if not line.startswith("#"):
            break
        if not line.startswith("# @package"):
            lines.append(line[1:].strip())
    return " ".join(lines).strip()


def _type(hint: Any) -> str:
    text = hint.__name__ if isinstance(hint, type) and not typing.get_args(hint) else str(hint)
    return text.replace("typing.", "").replace("NoneType", "None").replace("|", "\\|")


# ------------------------------------------------------------------------------------------ groups


def root_defaults() -> tuple[list[str], dict[str, Any]]:
    """The groups in the order of ``conf/config.yaml``'s defaults list, and each one's default."""
    from omegaconf import OmegaConf

    order, default = [], {}
    for entry in OmegaConf.to_container(OmegaConf.load(CONF / "config.yaml"))["defaults"]:
        if isinstance(entry, dict):
            for key, value in entry.items():
                order.append(key)
                default[key] = value
    return order, default


def groups() -> list[str]:
    """Every config group: a folder of ``conf/`` holding member files (``hydra/launcher`` too)."""
    found = sorted(
        {p.parent.relative_to(CONF).as_posix() for p in CONF.glob("**/*.yaml") if p.parent != CONF}
    )
    order, _ = root_defaults()
    return sorted(
        found, key=lambda g: (order.index(g) if g in order else len(order), g.startswith("hydra"), g)
    )


def _member_target(group: str, member: str, path: Path, data: dict) -> list[str]:
    from contactmpc.config import locate, schema_for

    target = data["_target_"]
    obj = locate(target)
    canonical = f"{obj.__module__}.{obj.__qualname__}"
    schema = schema_for(target)
    out = [f"Builds [`{target}`][{canonical}]" + (f": {summary(obj)}" if summary(obj) else "."), ""]
    comment = leading_comment(path)
    if comment:
        out += [_plain(comment), ""]
    out += _table(schema, obj, data)
    extra = [k for k in data if k not in {f.name for f in dataclasses.fields(schema)} | {"defaults"}]
    if extra:
        out += ["Also sets: " + ", ".join(f"`{k}`" for k in extra) + ".", ""]
    return out


def _table(schema: type, obj: Any, data: dict | None) -> list[str]:
    """One row per parameter of a schema: type, default, the member's value, its description."""
    docs = arg_docs(obj)
    rows = []
    for f in dataclasses.fields(schema):
        if f.name in ("_target_", "_partial_"):
            continue
        if f.default is not dataclasses.MISSING:
            default = _code(f.default) if f.default != "???" else "required"
        elif f.default_factory is not dataclasses.MISSING:
            default = _code(f.default_factory())
        else:
            default = "required"
        own = "" if data is None else (_code(data[f.name]) if f.name in data else "") + " | "
        rows.append(f"| `{f.name}` | {_type(f.type)} | {default} | {own}{docs.get(f.name, '')} |")
    if not rows:
        return []
    if data is None:
        return ["| parameter | type | default | description |", "|---|---|---|---|", *rows, ""]
    return ["| parameter | type | default | this member | description |", "|---|---|---|---|---|", *rows, ""]


def _member_global(group: str, path: Path, data: dict) -> list[str]:
    out = []
    comment = leading_comment(path)
    if comment:
        out += [_plain(comment), ""]
    sets = []
    for entry in data.get("defaults", []) or []:
        if isinstance(entry, str) and entry != "_self_":  # another member of this group, or a config path
            sets.append(f"all of `{group}={entry}`" if "/" not in entry else f"all of `{entry}`")
        if isinstance(entry, dict):
            for key, value in entry.items():
                if key == "_self_":
                    continue
                key = key.removeprefix("override ").lstrip("/")
                sets.append(f"`{key}={_value(value)}`")
    package = _package(group, path)
    for key, value in _flatten({k: v for k, v in data.items() if k != "defaults"}):
        if not key:  # nothing of its own (``{}``)
            continue
        sets.append(f"`{package + '.' if package else ''}{key}`: {_code(value)}")
    out += [
        "Sets: " + "; ".join(sets) + "." if sets else "Sets nothing: the root config's defaults as they are.",
        "",
    ]
    return out


def _package(group: str, path: Path) -> str:
    """Where a member's keys go in the config (Hydra's ``# @package``; by default its group)."""
    match = re.search(r"^#\s*@package\s+(\S+)", path.read_text(encoding="utf-8"), re.MULTILINE)
    package = match.group(1) if match else "_group_"
    if package == "_global_":
        return ""
    return package.replace("_group_", group.replace("/", "."))


def markdown() -> str:
    """The config-groups section of the docs: one ``##`` per group, one ``###`` per member."""
    _setup()
    from omegaconf import OmegaConf

    _, default = root_defaults()
    out = []
    for group in groups():
        members = sorted((CONF / group).glob("*.yaml"))
        name = group if group.startswith("hydra") else group
        out += [f"## `{name}`", ""]
        if group in default:
            chosen = default[group]
            out += [f"Default: `{group}={chosen}`." if chosen is not None else "None by default.", ""]
        out += [
            "Members: " + ", ".join(f"[`{p.stem}`](#{group.replace('/', '')}-{p.stem})" for p in members),
            "",
        ]
        for path in members:
            data = OmegaConf.to_container(OmegaConf.load(path), resolve=False) or {}
            out += [f"### `{group}={path.stem}` {{ #{group.replace('/', '')}-{path.stem} }}", ""]
            if isinstance(data, dict) and "_target_" in data:
                out += _member_target(group, path.stem, path, data)
            else:
                out += _member_global(group, path, data if isinstance(data, dict) else {})
            source = path.read_text(encoding="utf-8").rstrip()
            rel = path.relative_to(ROOT).as_posix()
            out += [
                f'??? note "{rel}"',
                "    ```yaml",
                *("    " + line for line in source.splitlines()),
                "    ```",
                "",
            ]
    out += top_level()
    return "\n".join(out)


def _key_comments(path: Path) -> dict[str, str]:
    """Top-level key -> the comment lines right above it in a YAML file."""
    found, block = {}, []
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.startswith("#"):
            block.append(line[1:].strip())
        elif re.match(r"^[A-Za-z_]\w*:", line):
            found[line.split(":", 1)[0]] = " ".join(block)
            block = []
        else:
            block = []
    return found


def top_level() -> list[str]:
    """The root config's own values (``conf/config.yaml``) and the scene's parameters."""
    from omegaconf import OmegaConf

    from contactmpc.config import SceneConf, locate

    root = OmegaConf.to_container(OmegaConf.load(CONF / "config.yaml"), resolve=False)
    comments = _key_comments(CONF / "config.yaml")
    out = [
        "## Top-level values and `scene`",
        "",
        "| key | value in `conf/config.yaml` | what it is |",
        "|---|---|---|",
    ]
    for key, value in root.items():
        if key not in ("defaults", "hydra"):
            out.append(f"| `{key}` | {_code(value)} | {_plain(comments.get(key, ''))} |")
    scene = locate(SceneConf._target_)
    out += ["", f"`scene.*`: the parameters of [`{SceneConf._target_}`][{SceneConf._target_}] "]
    out[-1] += f"({summary(scene).rstrip('.')})." if summary(scene) else "."
    out += ["", *_table(SceneConf, scene, None)]
    return out


if __name__ == "__main__":
    print(markdown())
