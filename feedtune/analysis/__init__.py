"""Frequency-domain analyses (loops, margins, Nyquist, ball-screw cases) and time-domain metrics."""

from .ballscrew import BallScrewAnalysis, analyze_ballscrew, closed_loop_poles
from .loop import LoopMetrics, analyze_loop
from .metrics import contour_error, ropesnap_metrics, tracking_metrics

__all__ = [
    "BallScrewAnalysis",
    "LoopMetrics",
    "analyze_ballscrew",
    "analyze_loop",
    "closed_loop_poles",
    "contour_error",
    "ropesnap_metrics",
    "tracking_metrics",
]
