"""Ripple metrics from captured signals: angle-domain resampling, synchronous averaging, order
spectrum, pk-pk, GUM uncertainty (k = 2) and ILAC-G8 verdicts. Knows nothing about instruments.

Typical use::

    res = analyze_capture(capture, max_order=64, named_order=6,
                          instruments=InstrumentUncertainty(transducer_accuracy_class_pct=0.1,
                                                            transducer_full_scale_nm=5.0))
    verdict = decide(measured=res, predicted_pk_pk_pu=0.02, predicted_order=6, rule=DecisionRule())
"""

from hil.analysis.dispatch import ANALYSES, run_analysis
from hil.analysis.decision import DECISIONS, DecisionRule, Verdict, classify, decide
from hil.analysis.metrics import (DEFAULT_MAX_ORDER, PK_PK_METHODS, RippleResult, analyze_capture,
                                 analyze_torque)
from hil.analysis.uncertainty import BudgetRow, InstrumentUncertainty, UncertaintyBudget

__all__ = ["ANALYSES", "run_analysis", "DECISIONS", "DEFAULT_MAX_ORDER", "PK_PK_METHODS", "BudgetRow", "DecisionRule",
           "InstrumentUncertainty", "RippleResult", "UncertaintyBudget", "Verdict",
           "analyze_capture", "analyze_torque", "classify", "decide"]
