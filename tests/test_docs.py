"""The documentation site builds with warnings as errors, and its generated parts cover the repository.

`mkdocs build --strict` fails on a broken link, a broken anchor, a reference mkdocstrings cannot resolve
or a docstring griffe cannot parse, so a change anywhere that breaks the site fails here (and in
.ci/run); skipped where the `docs` extra is not installed. The hand-written guide is also checked
against the repository without building: every `group=member`, repository file and `python -m analysis…`
module it names exists, so a renamed config member or module fails here instead of going stale.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    for module in ("mkdocs", "material", "mkdocstrings_handlers.python"):
        pytest.importorskip(module)
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1", "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
        cwd=REPO_ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, (
        f"mkdocs build --strict failed:\n{done.stdout[-3000:]}\n{done.stderr[-6000:]}"
    )
    return out


@pytest.mark.slow
def test_the_site_builds_strict_with_every_module_member_and_study(site: Path) -> None:
    assert (site / "index.html").is_file()
    # one API page per public module of contactmpc/
    for file in (REPO_ROOT / "contactmpc").rglob("*.py"):
        parts = file.relative_to(REPO_ROOT).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        if any(p.startswith("_") for p in parts):
            continue
        page = site / "api" / Path(*parts) / "index.html"
        assert page.is_file(), f"no API page for {'.'.join(parts)}"
        assert ".".join(parts) in page.read_text(encoding="utf-8")
    # every member of every config group on the generated page
    groups = (site / "guide" / "config-groups" / "index.html").read_text(encoding="utf-8")
    for path in (REPO_ROOT / "conf").glob("*/**/*.yaml"):
        group = path.parent.relative_to(REPO_ROOT / "conf").as_posix()
        assert f"{group}={path.stem}" in groups, f"{group}={path.stem} missing from the config-groups page"
    # every study's report, with the figures it shows
    for report in (REPO_ROOT / "studies").glob("*/README.md"):
        assert (site / "studies" / report.parent.name / "index.html").is_file(), f"no page for {report}"


# ------------------------------------------------------------------- the guide names what exists

GUIDE = sorted((REPO_ROOT / "docs").rglob("*.md"))
_CHOICE = re.compile(r"(?<![\w.+/])(\w+)=([\w,]+)(?![\w<])")
_PATH = re.compile(r"(?<![\w./])((?:contactmpc|analysis|tests|conf|studies)/[\w/.-]*\w\.(?:py|yaml|ipynb))")
_MODULE = re.compile(r"python -m (analysis(?:\.\w+)*)")


def _groups() -> set[str]:
    return {p.name for p in (REPO_ROOT / "conf").iterdir() if p.is_dir() and p.name != "hydra"}


def test_the_guide_names_only_config_members_that_exist() -> None:
    """Every ``group=member`` the guide writes (commands and prose) is a file of conf/<group>/."""
    groups, missing = _groups(), []
    for page in GUIDE:
        for group, members in _CHOICE.findall(page.read_text(encoding="utf-8")):
            if group not in groups:
                continue
            for member in filter(None, members.split(",")):
                if member != "null" and not (REPO_ROOT / "conf" / group / f"{member}.yaml").is_file():
                    missing.append(f"{page.relative_to(REPO_ROOT)}: {group}={member}")
    assert not missing, "the guide names config members that do not exist:\n" + "\n".join(
        sorted(set(missing))
    )


def test_the_guide_names_only_files_and_modules_that_exist() -> None:
    """Every repository file (``contactmpc/…py``, ``conf/…yaml``, ``tests/…py``) and every
    ``python -m analysis.…`` module the guide names exists."""
    missing = []
    for page in GUIDE:
        text = page.read_text(encoding="utf-8")
        for path in _PATH.findall(text):
            if "*" not in path and "<" not in path and not (REPO_ROOT / path).exists():
                missing.append(f"{page.relative_to(REPO_ROOT)}: {path}")
        for module in _MODULE.findall(text):
            path = REPO_ROOT / module.replace(".", "/")
            if not (path.with_suffix(".py").is_file() or (path / "__init__.py").is_file()):
                missing.append(f"{page.relative_to(REPO_ROOT)}: python -m {module}")
    assert not missing, "the guide names files or modules that do not exist:\n" + "\n".join(
        sorted(set(missing))
    )
