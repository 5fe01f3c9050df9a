"""MkDocs hooks (``hooks:`` in mkdocs.yml): the parts of the site made at build time.

- **API reference**: one page per public module of ``contactmpc/`` (``::: contactmpc.x.y``, rendered by
  mkdocstrings from the docstrings, read statically by griffe), so a new module appears by itself.
- **Studies**: every ``studies/<name>/README.md`` at the repository root (and ``studies/README.md`` if
  there is one, else a generated index of them), at the same paths in the site, in a "Studies" section.
- **Files the pages link to**: a relative link or image whose target is not in the docs tree but exists
  at the same path in the repository (``../analysis/images/x.png`` from ``guide/*.md``, a study's
  ``figures/*.png``) is served from the repository, so no binary file is copied into ``docs/`` in git;
  a Markdown file under ``studies/`` that a study links to becomes a page outside the nav. A link to what
  the repository has but a site cannot show (a folder, other Markdown) keeps its text and loses its link
  (the repository's README links to the home page); a link to what does not exist fails the build.
- **Config groups**: ``<!-- config-groups -->`` in ``guide/config-groups.md`` is replaced by the
  tables that :mod:`config_groups` (beside this file) makes from ``conf/`` and the config schemas.

Nothing is written into the repository; the generated pages live only in the build.
"""

from __future__ import annotations

import importlib
import posixpath
import re
import sys
from pathlib import Path

from mkdocs.structure.files import File, Files, InclusionLevel

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
PACKAGE = "contactmpc"
STUDIES = "studies"
API = "api"
MARKER = "<!-- config-groups -->"

# [text](target), ![alt](target "title"), <img src="target">, [ref]: target
_LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)|<img[^>]*\ssrc=\"([^\"]+)\"")
_REF = re.compile(r"^\s{0,3}\[[^\]]+\]:\s*<?(\S+?)>?(?:\s|$)", re.MULTILINE)
_INLINE_LINK = re.compile(r"(?<!!)\[([^\]]*)\]\(\s*<?([^)\s>]+)>?\s*\)")
_FENCE = re.compile(r"^(```|~~~).*?^\1", re.MULTILINE | re.DOTALL)


# ------------------------------------------------------------------------------------------ modules


def modules() -> list[tuple[str, str]]:
    """``(dotted name, page path)`` of every public module and package of ``contactmpc/``, sorted.

    A module is public when no part of its dotted name starts with ``_`` (``__init__`` stands for its
    package). A package's page is ``api/<path>/index.md``, a module's ``api/<path>.md``.
    """
    found = []
    for path in sorted((ROOT / PACKAGE).rglob("*.py")):
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        package = parts[-1] == "__init__"
        if package:
            parts = parts[:-1]
        if any(p.startswith("_") for p in parts):
            continue
        page = posixpath.join(API, *parts, "index.md") if package else posixpath.join(API, *parts) + ".md"
        found.append((".".join(parts), page))
    return found


def _api_nav(mods: list[tuple[str, str]]) -> list:
    """The nested nav of the API pages: one section per package, its own page first."""
    tree: dict = {}
    for name, page in mods:
        node = tree
        for part in name.split(".")[:-1]:
            node = node.setdefault(part, {})
        leaf = name.split(".")[-1]
        if page.endswith("index.md"):
            node.setdefault(leaf, {})[""] = page
        else:
            node[leaf] = page

    def entries(node: dict) -> list:
        out = [node[""]] if "" in node else []
        for key in sorted(k for k in node if k):
            value = node[key]
            out.append({key: entries(value) if isinstance(value, dict) else value})
        return out

    return entries(tree[PACKAGE])  # the package page first, then one entry per module or subpackage


# ------------------------------------------------------------------------------------------ studies


def studies() -> list[str]:
    """The report of every study, ``studies/<name>/README.md``, sorted by name."""
    return sorted(p.relative_to(ROOT).as_posix() for p in (ROOT / STUDIES).glob("*/README.md"))


def _title(path: Path) -> str:
    match = re.search(r"^#\s+(.+?)\s*#*\s*$", path.read_text(encoding="utf-8"), re.MULTILINE)
    return match.group(1) if match else path.parent.name


def _studies_index(reports: list[str]) -> str:
    lines = [
        "# Studies",
        "",
        "Each study is a folder `studies/<name>/` of the repository: its experiment, its kept",
    ]
    lines += ["records and a report made from them by one command. The reports:", ""]
    for report in reports:
        rel = posixpath.relpath(report, STUDIES)
        lines.append(f"- [{_title(ROOT / report)}]({rel})")
    if not reports:
        lines.append("(none yet)")
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------------------------- linked files


def _targets(markdown: str) -> list[str]:
    """Relative link and image targets of a page (outside fenced code), without anchors or queries."""
    text = _FENCE.sub("", markdown)
    found = [a or b for a, b in _LINK.findall(text)] + _REF.findall(text)
    out = []
    for target in found:
        target = target.split("#", 1)[0].split("?", 1)[0]
        if target and not re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*:", target) and not target.startswith("/"):
            out.append(target)
    return out


def _add_linked(files: Files, config) -> None:
    """Serve from the repository what the pages link to at a path the docs tree lacks: a file that is not
    Markdown as it is, a Markdown file under ``studies/`` as a page outside the nav (its links followed in
    turn). Other targets are left to :func:`_unlink` and, if missing, to mkdocs' link check."""
    todo = list(files.documentation_pages())
    while todo:
        page = todo.pop()
        base = posixpath.dirname(page.src_uri)
        for target in _targets(page.content_string):
            uri = posixpath.normpath(posixpath.join(base, target))
            source = ROOT / uri
            if uri.startswith("..") or files.get_file_from_path(uri) is not None or not source.is_file():
                continue
            if source.suffix != ".md":
                files.append(File.generated(config, uri, abs_src_path=str(source)))
            elif uri.startswith(STUDIES + "/"):
                hidden = InclusionLevel.NOT_IN_NAV
                new = File.generated(config, uri, abs_src_path=str(source), inclusion=hidden)
                files.append(new)
                todo.append(new)


def _unlink(markdown: str, page: File, files: Files) -> str:
    """Links to what the repository has but the site cannot show (a folder, a Markdown file outside the
    site) keep their text and lose their link; a link to the repository's README goes to the home page."""
    base = posixpath.dirname(page.src_uri)

    def replace(match: re.Match) -> str:
        text, target = match.group(1), match.group(2)
        path = target.split("#", 1)[0].split("?", 1)[0]
        if not path or re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*:", path) or path.startswith("/"):
            return match.group(0)
        uri = posixpath.normpath(posixpath.join(base, path))
        if uri.startswith("..") or files.get_file_from_path(uri) is not None:
            return match.group(0)
        if uri == "README.md":
            return f"[{text}]({posixpath.relpath('index.md', base or '.')})"
        if (ROOT / uri).is_dir() or (ROOT / uri).is_file():
            return text
        return match.group(0)

    parts = re.split(r"(^(?:```|~~~).*?^(?:```|~~~)[^\n]*$)", markdown, flags=re.MULTILINE | re.DOTALL)
    for i in range(0, len(parts), 2):  # the odd parts are fenced code
        parts[i] = _INLINE_LINK.sub(replace, parts[i])
    return "".join(parts)


# -------------------------------------------------------------------------------------------- hooks


def on_config(config):
    """Append the generated sections to the nav: the API reference, then the studies."""
    nav = list(config.nav or [])
    nav.append({"API reference": _api_nav(modules())})
    nav.append({"Studies": [f"{STUDIES}/README.md", *studies()]})
    config.nav = nav
    return config


def on_files(files: Files, config) -> Files:
    """Add the API pages, the studies and the repository files the pages link to."""
    for name, page in modules():
        files.append(File.generated(config, page, content=f"::: {name}\n"))
    reports = studies()
    index = ROOT / STUDIES / "README.md"
    if index.is_file():
        files.append(File.generated(config, f"{STUDIES}/README.md", abs_src_path=str(index)))
    else:
        files.append(File.generated(config, f"{STUDIES}/README.md", content=_studies_index(reports)))
    for report in reports:
        files.append(File.generated(config, report, abs_src_path=str(ROOT / report)))
    _add_linked(files, config)
    return files


def on_page_markdown(markdown: str, page, config, files) -> str:
    """Fill the config-groups page from ``conf/`` and the schemas; drop links the site cannot serve."""
    markdown = _unlink(markdown, page.file, files)
    if MARKER in markdown:
        if str(DOCS) not in sys.path:
            sys.path.insert(0, str(DOCS))
        import config_groups

        importlib.reload(config_groups)  # mkdocs serve: a changed conf/ shows on the next rebuild
        markdown = markdown.replace(MARKER, config_groups.markdown())
    return markdown
