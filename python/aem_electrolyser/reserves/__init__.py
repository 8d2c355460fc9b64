"""Prequalification evaluation library for frequency reserves (a tool beside the FMU: it reads
only traces of the hub's consumption).

A model-based assessment of the test programme (Nordic FCR technical requirements v1.1 of
28 March 2025 and test programme, Fingrid FFR, SO GL Annex V), not a prequalification approval.

Modules: signals (test programmes f(t)), requirement (result type, Trace), evaluate (Nordic FCR
time domain and the dispatcher evaluate.evaluate), frequency_domain (sine tests, Nyquist),
activation (CE FCR, FFR, aFRR, mFRR), bisection (largest passing capacity), report
(Markdown/CSV/JSON, plots).
"""

from . import activation, bisection, evaluate, frequency_domain, report, signals
from .bisection import CapacityResult, largest_capacity
from .frequency_domain import SinePoint, evaluate_sine_set, sine_point
from .requirement import FAIL, PASS, UNSURE, Requirement, Trace
from .signals import TestSignal

__all__ = [
    "activation",
    "bisection",
    "evaluate",
    "frequency_domain",
    "report",
    "signals",
    "CapacityResult",
    "largest_capacity",
    "SinePoint",
    "evaluate_sine_set",
    "sine_point",
    "FAIL",
    "PASS",
    "UNSURE",
    "Requirement",
    "Trace",
    "TestSignal",
]
