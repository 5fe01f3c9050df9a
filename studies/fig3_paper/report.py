"""Does the full method beat each ablation on the paper's own tasks, at the operating point that works?"""

from __future__ import annotations

TITLE = "Fig. 3 on the paper's data at the operating point that works"
EXPERIMENTS = ["fig3_paper", "fig3_paper_hard"]


def report(study) -> str:
    df = study.records()
    return study.provenance(df) + "\n"
