"""Analysis of ContactMPC sweeps: collect the trial records, draw the paper's Fig. 3, write a report.

Only records (``trial.json``) are read. Nothing is computed at import; the submodules are imported on
first use of a name, so ``import analysis`` stays cheap in a notebook::

    from analysis import load_records, ttf_boxplot, markdown_report

    df = load_records("outputs/sweeps/2025-01-01/12-00-00")
    ttf_boxplot(df, "fig3.png")
    print(markdown_report(df))

Command lines: ``python -m analysis SWEEP_DIR... --out-dir DIR`` (table, figure and report),
``python -m analysis.aggregate``, ``python -m analysis.figures``, ``python -m analysis.report``; the
studies' reports (``studies/<name>/README.md``): ``python -m analysis.study``.
"""

from __future__ import annotations

import importlib

_EXPORTS = {
    "load_records": "aggregate",
    "read_record": "aggregate",
    "variant_name": "aggregate",
    "ok_trials": "aggregate",
    "write_table": "aggregate",
    "RecordWarning": "aggregate",
    "ttf_boxplot": "figures",
    "summary_table": "report",
    "significance_tests": "report",
    "markdown_report": "report",
    "write_report": "report",
    "write_all": "report",
    "Stat": "summarize",
    "summarize": "summarize",
    "Study": "study",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        return getattr(importlib.import_module(f"analysis.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module 'analysis' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
