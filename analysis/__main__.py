"""``python -m analysis SWEEP_DIR [SWEEP_DIR ...] --out-dir DIR``: table, figure and report in one go.

Writes ``DIR/results.csv`` (every trial), ``DIR/fig3.png`` (the paper's Fig. 3) and ``DIR/results.md``
(per task × variant statistics and full vs ablation tests).
"""

from __future__ import annotations

import argparse


def build_parser() -> argparse.ArgumentParser:
    """Parser of ``python -m analysis``."""
    from analysis._cli import sweep_parser

    parser = sweep_parser(
        "python -m analysis", "Read the trial records of sweeps; write results.csv, fig3.png and results.md."
    )
    parser.add_argument("--out-dir", default="results", help="output directory; default %(default)s")
    parser.add_argument(
        "--parquet", action="store_true", help="write results.parquet instead of results.csv (needs pyarrow)"
    )
    parser.add_argument("--alpha", type=float, default=0.05, help="significance level; default %(default)s")
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``python -m analysis``; returns the exit status."""
    from analysis.aggregate import run_records
    from analysis.report import write_all

    args = build_parser().parse_args(argv)

    def action(df) -> str:
        written = write_all(
            df,
            args.out_dir,
            sweep_dirs=args.sweep_dirs,
            table_name="results.parquet" if args.parquet else "results.csv",
            alpha=args.alpha,
        )
        return f"wrote {', '.join(map(str, written))} ({len(df)} trials)"

    return run_records(args.sweep_dirs, action, (OSError, RuntimeError, ValueError))


if __name__ == "__main__":
    raise SystemExit(main())
