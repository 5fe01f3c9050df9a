"""A griffe extension (mkdocs.yml: the python handler's ``extensions``): Sphinx roles in the docstrings
as links of the API reference.

The library's docstrings name objects the Sphinx way, ``:class:`~contactmpc.hands.base.Hand```,
``:func:`schema_for```, ``:math:`\\sigma```. Markdown has no roles, so each becomes code, and a link
(an autorefs cross-reference, ``[`Hand`][contactmpc.hands.base.Hand]``) where its target is an object
this site renders: one of ``contactmpc``'s, resolved like a Python name from where the docstring is
(its object, then the enclosing class and module, imports followed), public (no ``_`` in its path)
and documented (mkdocstrings leaves out what has no docstring). Anything else stays code only, so
the strict build never meets a link it cannot resolve. A leading ``~`` shows only the last name.
"""

from __future__ import annotations

import re
from typing import Any

import griffe

PACKAGE = "contactmpc"
_ROLE = re.compile(r":(?:py:)?(\w+):`(~?)([^`]+)`")
_SECTIONS = ("Args:", "Arguments:", "Parameters:", "Other Parameters:", "Attributes:")
_GROUPED = re.compile(r"^\w+\s*,")


def split_grouped(text: str) -> str:
    """One entry per name where an ``Args:`` entry documents several: ``start, end: when (s).`` ->
    ``start: when (s).`` and ``end: when (s).`` (the names may run over several lines before the colon).
    Google-style parsers take one name per entry; this docstring style groups names that share a
    description."""
    lines = text.split("\n")
    out: list[str] = []
    i, header, item = 0, None, None
    while i < len(lines):
        line = lines[i]
        stripped, indent = line.strip(), len(line) - len(line.lstrip())
        if stripped in _SECTIONS:
            header, item = indent, None
            out.append(line)
            i += 1
            continue
        if header is not None and stripped and indent <= header:
            header = None
        if header is not None and stripped:
            item = indent if item is None else item
            if indent == item and _GROUPED.match(stripped):
                head, j = stripped, i
                while ":" not in head and j + 1 < len(lines) and lines[j + 1].strip():
                    j += 1
                    head += " " + lines[j].strip()
                if ":" in head:
                    names, description = head.split(":", 1)
                    rest = []
                    while (
                        j + 1 < len(lines)
                        and lines[j + 1].strip()
                        and len(lines[j + 1]) - len(lines[j + 1].lstrip()) > item
                    ):
                        j += 1
                        rest.append(lines[j])
                    for name in filter(None, (n.strip() for n in names.split(","))):
                        out.append(f"{' ' * item}{name}:{description}")
                        out += rest
                    i = j + 1
                    continue
        out.append(line)
        i += 1
    return "\n".join(out)


def _member(node: Any, name: str) -> Any:
    try:
        return node.members.get(name)
    except Exception:  # an alias whose target is outside what griffe loaded
        return None


def _lookup(obj: Any, dotted: str, collection: Any) -> Any:
    """The object ``dotted`` names from ``obj``'s scope, or an absolute path; ``None`` if not found."""
    head, *rest = dotted.split(".")
    found, scope = None, obj
    while scope is not None and found is None:
        found = _member(scope, head) if scope.is_class or scope.is_module else None
        scope = scope.parent
    if found is None:
        try:
            return collection[dotted]
        except Exception:
            return None
    for part in rest:
        found = _member(found, part)
        if found is None:
            return None
    return found


def _rendered(target: Any) -> str | None:
    """The path of ``target`` if this site renders it (a page anchor exists), else ``None``."""
    try:
        target = target.final_target if target.is_alias else target
    except Exception:
        return None
    path = target.path
    if not path.startswith(PACKAGE + ".") and path != PACKAGE:
        return None
    if any(part.startswith("_") for part in path.split(".")):
        return None
    node = target
    while node is not None and not node.is_module:
        if not node.docstring:
            return None
        node = node.parent
    return path


class SphinxRoles(griffe.Extension):
    """Rewrite every docstring of the package once it is loaded: roles (above), grouped parameters
    (:func:`split_grouped`)."""

    def on_package(self, *, pkg: griffe.Module, loader: griffe.GriffeLoader, **kwargs: Any) -> None:
        self._walk(pkg, loader.modules_collection)

    def _walk(self, obj: Any, collection: Any) -> None:
        if obj.is_alias:
            return
        if obj.docstring:
            obj.docstring.value = self._rewrite(obj, obj.docstring.value, collection)
        for member in list(obj.members.values()):
            if not member.is_alias:
                self._walk(member, collection)

    @staticmethod
    def _rewrite(obj: Any, text: str, collection: Any) -> str:
        def replace(match: re.Match) -> str:
            role, short, name = match.groups()
            name = name.strip()
            shown = name.rsplit(".", 1)[-1] if short else name
            if role == "math":
                return f"`{name}`"
            # the scope of a docstring is its object's own members, then its parents'
            path = _rendered(found) if (found := _lookup(obj, name.lstrip("."), collection)) else None
            return f"[`{shown}`][{path}]" if path else f"`{shown}`"

        return _ROLE.sub(replace, split_grouped(text))
