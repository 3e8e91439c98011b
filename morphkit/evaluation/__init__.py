"""Evaluation: compare trained retargeters on held-out clips, as ACE's Table 1 (Li et al. 2023, §7.3).

* :mod:`~.methods`: the methods of run folders (ACE stages and NKN's cross-morphology runs).
* :mod:`~.evaluate`: retarget the evaluation clips with each, score DIV, FID, L_fea and UFR
  (:mod:`morphkit.metrics`) against one reference (the creature's data set and one Ψ pairing).
* :mod:`~.report`: Table 1 as markdown and CSV (mean ± std over seeds), bar charts, side-by-side
  videos and ``index.html``.
* :mod:`~.reproduce`: the whole pipeline for one creature (data, prior, ACE and its ablations,
  ACE+contact, NKN; evaluation; report), resumable stage by stage.
* :mod:`~.stages`: the stage runner under it (done markers, lanes in forked processes, Ctrl-C → checkpoint).

This layer sits above the trainers (:mod:`morphkit.retarget`) and the renderer (:mod:`morphkit.render`).
"""

from morphkit.evaluation.evaluate import Evaluation as Evaluation
from morphkit.evaluation.evaluate import MethodResult as MethodResult
from morphkit.evaluation.evaluate import Reference as Reference
from morphkit.evaluation.evaluate import evaluate_methods as evaluate_methods
from morphkit.evaluation.evaluate import reference_for as reference_for
from morphkit.evaluation.evaluate import retarget as retarget
from morphkit.evaluation.methods import METHOD_ORDER as METHOD_ORDER
from morphkit.evaluation.methods import Method as Method
from morphkit.evaluation.methods import find_methods as find_methods
from morphkit.evaluation.report import SummaryRow as SummaryRow
from morphkit.evaluation.report import format_summary as format_summary
from morphkit.evaluation.report import summarize as summarize
from morphkit.evaluation.report import write_report as write_report
from morphkit.evaluation.reproduce import ReproduceConfig as ReproduceConfig
from morphkit.evaluation.reproduce import evaluate_runs as evaluate_runs
from morphkit.evaluation.reproduce import reproduce_table1 as reproduce_table1
from morphkit.evaluation.targets import TargetCheck as TargetCheck
from morphkit.evaluation.targets import check_targets as check_targets
from morphkit.evaluation.targets import format_targets as format_targets

__all__ = [
    "METHOD_ORDER",
    "Evaluation",
    "Method",
    "MethodResult",
    "Reference",
    "ReproduceConfig",
    "SummaryRow",
    "TargetCheck",
    "check_targets",
    "evaluate_methods",
    "evaluate_runs",
    "find_methods",
    "format_summary",
    "format_targets",
    "reference_for",
    "reproduce_table1",
    "retarget",
    "summarize",
    "write_report",
]
