"""The README's blocks made from the kept sweep records (``results/``), re-made in place.

Each block sits between ``<!-- NAME:begin ... -->`` and ``<!-- NAME:end -->`` in ``README.md`` and is what
one analysis command makes of the records in ``results/`` (the command is written in the block's begin
marker): the Fig. 3 grid on the paper's data (:mod:`analysis.paper_fig3`), the operating-point map
(:mod:`analysis.operating_point`) and the end of the paper tasks (:mod:`analysis.release`). A block whose
records are not all there yet says how many it has. ``tests/test_results.py`` checks that the README
holds exactly what this module makes of the kept records.

Command line (from the repository root; ``--check`` changes nothing and exits 1 if a block is stale)::

    python -m analysis.readme_blocks [--check]
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path

import pandas as pd

from analysis import operating_point, paper_fig3, release
from analysis.aggregate import select
from contactmpc.records import one_line

REPO = Path(__file__).resolve().parent.parent
RESULTS = REPO / "results"
FIG3_IMAGE = "analysis/images/fig3_paper_32samples.png"
RELEASE_IMAGE = "analysis/images/release_paper.png"

#: The operating-point map's records: the map's own sweep, the chosen point's full-method trials of
#: fig3_paper (the apple and bottle at 32 samples, paper_32samples = s32 on the paper point) and the
#: stapler with the wrist sampled while contact is acquired at that point, without and with the clearance
#: term (variant=wrist_clearance, results/stapler_clearance; at the paper point in operating_point).
POINT_DIRS = ("operating_point", "fig3_paper", "stapler_wrist_32samples", "stapler_clearance")
POINT_FILTER = {"task": "apple,bottle,stapler", "variant": "full,wrist_acquire,wrist_clearance"}
#: The end of the paper tasks: fig3_paper's full method (the "before") beside the methods release_reset
#: (release=reset: the walked-in grip dropped at the last contact), release (release=open: that, the
#: release term, opening, waiting), release_scheduled (release=scheduled: no sampling after the last
#: contact), in results/release, and release_backoff (release=backoff: scheduled, open to the flat hand,
#: the wrist backed off), in results/release_backoff (method names: contactmpc.labels.method_name).
RELEASE_DIRS = ("fig3_paper", "release_reset", "release", "release_backoff")
RELEASE_FILTER = {
    "task": "apple,bottle",
    "variant": "full,release_reset,release,release_scheduled,release_backoff",
    "fidelity": "paper",
}


def _dirs(names: tuple[str, ...], root: Path) -> list[Path]:
    return [root / n for n in names if (root / n).is_dir()]


def fig3_block(root: Path = RESULTS, image_out: Path | None = None) -> str:
    """The Fig. 3 block: how many of the 144 trials are kept, the figure, the table and the tests.
    With ``image_out`` the figure is drawn there (the README shows :data:`FIG3_IMAGE`)."""
    df = paper_fig3.load(root / "fig3_paper")
    if image_out is not None:
        paper_fig3.fig3(df, image_out)
    counts = df.groupby(["fidelity", "task", "variant"]).size()
    parts = []
    for fid in ("paper", "authors_code"):
        if fid not in counts.index.get_level_values(0):
            parts.append(f"`{fid}`: none yet")
            continue
        c = counts.loc[fid]
        cells = "every cell" if len(c) == 12 else f"{len(c)} of 12 cells"
        seeds = f"{c.min()}" if c.min() == c.max() else f"{c.min()}-{c.max()}"
        parts.append(f"`{fid}`: {c.sum()} trials, {cells}, {seeds} seed{'s' if c.max() > 1 else ''} each")
    cpu = df["cpu_seconds"].sum() / 3600
    return (
        f"**{len(df)} of 144 trials** ({'; '.join(parts)}; {cpu:.2f} CPU-hours measured):\n\n"
        f"![Fig. 3 on the paper's data at preset=paper_32samples]({FIG3_IMAGE})\n\n" + paper_fig3.markdown(df)
    )


def point_block(root: Path = RESULTS) -> str:
    """The operating-point map on the kept records (:data:`POINT_DIRS`, rows :data:`POINT_FILTER`)."""
    df = select(operating_point.load(*_dirs(POINT_DIRS, root)), **POINT_FILTER)
    table = operating_point.summary(df)
    cpu = pd.to_numeric(df["compute"], errors="coerce").sum() / 3600
    return f"**{len(df)} trials, {cpu:.2f} CPU-hours**:\n\n" + operating_point.markdown(
        table, operating_point.cheapest(table)
    )


def release_block(root: Path = RESULTS, image_out: Path | None = None) -> str:
    """The end of the paper apple and bottle: the full method against variants release_reset and release
    (a variant none of whose records is kept yet is left out); with ``image_out`` the figure is drawn
    there (the README shows :data:`RELEASE_IMAGE`)."""
    df = paper_fig3.load(*_dirs(RELEASE_DIRS, root))
    have = set(df["variant"])
    variants = ",".join(v for v in RELEASE_FILTER["variant"].split(",") if v in have)
    df = select(df, **{**RELEASE_FILTER, "variant": variants})
    if image_out is not None:
        release.release_figure(df, image_out)
    return (
        f"![the end of the paper apple and bottle, per trial]({RELEASE_IMAGE})\n\n"
        + release.markdown(release.release_table(df))
        + "\nPer seed (object error after the span, mm; clean = finished cleanly, done = completed but not"
        " settled, failed = not completed):\n\n" + release.paired_markdown(df)
    )


def release_lite_block(root: Path = RESULTS) -> str:
    """The end of the synthetic doorknob at the lite preset (the synthetic task whose reference lets go):
    the full method against variant=release_scheduled, per variant and per seed."""
    df = paper_fig3.load(root / "release_lite")
    return (
        release.markdown(release.release_table(df))
        + "\nPer seed (articulation error after the span, x 1e-3 rad or m):\n\n"
        + release.paired_markdown(df)
    )


def release_flat_block(root: Path = RESULTS) -> str:
    """Design 8 (``release=flat``: design 6 opening to the flat hand) beside the full method and
    design 7 on the same seeds: the paper apple and bottle (``results/fig3_paper``,
    ``results/release_backoff``) and the synthetic doorknob (``results/release_lite``). Design 8's
    records (``results/release_flat``, ``results/release_flat_lite``) were made as
    ``variant=release_backoff sampler.release_backoff=0`` (now ``release=backoff
    sampler.release.backoff=0``), which behaves as ``release=flat`` (with no back-off its window is
    unused): they are shown as ``release_flat``."""
    flat = paper_fig3.load(root / "release_flat", root / "release_flat_lite").assign(variant="release_flat")
    paper = select(
        paper_fig3.load(*_dirs(("fig3_paper", "release_backoff"), root)),
        task="apple,bottle",
        variant="full,release_backoff",
        fidelity="paper",
    )
    door = select(paper_fig3.load(root / "release_lite"), variant="full,release_backoff")
    df = pd.concat([paper, door, flat], ignore_index=True)
    return (
        release.markdown(release.release_table(df))
        + "\nPer seed (object error after the span: mm, or x 1e-3 rad on the doorknob; clean = finished"
        " cleanly, done = completed but not settled, failed = not completed):\n\n"
        + release.paired_markdown(df)
    )


#: name -> (what makes it, the command the begin marker states, the figure it draws or ``None``)
BLOCKS: dict[str, tuple[Callable[..., str], str, str | None]] = {
    "fig3_paper": (fig3_block, "python -m analysis.paper_fig3 results/fig3_paper", FIG3_IMAGE),
    "operating_point": (
        point_block,
        f"python -m analysis.operating_point {' '.join('results/' + d for d in POINT_DIRS)} "
        + " ".join(f"--{k} {v}" for k, v in POINT_FILTER.items()),
        None,
    ),
    "release_reset": (
        release_block,
        f"python -m analysis.release {' '.join('results/' + d for d in RELEASE_DIRS)} "
        + " ".join(f"--{k} {v}" for k, v in RELEASE_FILTER.items()),
        RELEASE_IMAGE,
    ),
    "release_lite": (release_lite_block, "python -m analysis.release results/release_lite", None),
    "release_flat": (
        release_flat_block,
        "python -m analysis.release results/release_flat results/release_flat_lite (shown as variant"
        " release_flat) beside results/fig3_paper, results/release_backoff and results/release_lite",
        None,
    ),
}


def rewrite(readme: str, name: str, body: str) -> str:
    """``readme`` with block ``name``'s content replaced by ``body`` (the markers kept, the begin marker
    stating the command). Raises ``ValueError`` if the README has no such block."""
    begin, end = f"<!-- {name}:begin", f"<!-- {name}:end -->"
    if begin not in readme or end not in readme:
        raise ValueError(f"README.md has no block {name} ({begin} ... {end})")
    a = readme.index(begin)
    b = readme.index(end) + len(end)
    marker = f"{begin} (made by `python -m analysis.readme_blocks` from: {BLOCKS[name][1]}) -->"
    return readme[:a] + marker + "\n" + body + end + readme[b:]


def made(readme: str, root: Path = RESULTS, draw: bool = False, skipped: list[str] | None = None) -> str:
    """``readme`` with every block re-made from the records under ``root`` (blocks whose records are
    absent, or that cannot be made from them, are left as they are, each with its reason appended to
    ``skipped``). ``draw`` also re-draws the figures."""
    for name, (make, _, image) in BLOCKS.items():
        rewrite(readme, name, "")  # the README must have the block, records or not
        try:
            body = make(root, REPO / image) if (draw and image) else make(root)
        except (ValueError, FileNotFoundError) as err:
            if skipped is not None:  # e.g. its records are not here: the block stays as it is
                skipped.append(f"{name}: {one_line(err)}")
            continue
        readme = rewrite(readme, name, body)
    return readme


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m analysis.readme_blocks", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--check", action="store_true", help="change nothing; exit 1 if a block is stale")
    args = parser.parse_args(argv)
    path = REPO / "README.md"
    old = path.read_text()
    skipped: list[str] = []
    new = made(old, draw=not args.check, skipped=skipped)
    for line in skipped:
        print(f"not re-made (left as it is): {line}", file=sys.stderr)
    if args.check:
        stale = old != new
        print("README blocks are " + ("stale: run python -m analysis.readme_blocks" if stale else "current"))
        return int(stale)
    path.write_text(new)
    print(f"re-made {', '.join(BLOCKS)} in {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
