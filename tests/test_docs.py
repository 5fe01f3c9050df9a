"""The documentation site builds with warnings as errors, and its generated parts cover the repository.

`mkdocs build --strict` fails on a broken link, a broken anchor, a reference mkdocstrings cannot resolve
or a docstring griffe cannot parse, so a change anywhere that breaks the site fails here (and in
.ci/run). Skipped where the `docs` extra is not installed.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("mkdocs")
pytest.importorskip("material")
pytest.importorskip("mkdocstrings_handlers.python")

REPO_ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
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
