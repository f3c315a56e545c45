"""The helpers the benchmark scripts draw their conclusions with."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from pareto import pareto


def test_pareto_front_with_a_time_tolerance():
    """(time, error) pairs: a pair is beaten by one as accurate and faster
    by more than the tolerance, or by one more accurate and no slower than
    the tolerance allows; the same error within the tolerance beats
    nothing, so run-to-run noise alone does not decide the front."""
    pts = [(100.0, 0.02), (110.0, 0.02),    # same error, 10 % apart
           (50.0, 0.10),                    # faster, worse: on the front
           (130.0, 0.02),                   # same error, 30 % slower than the first
           (200.0, 0.05)]                   # slower and worse than the first
    assert pareto(pts) == [0, 2]             # exact: 110 ms loses to 100 ms
    assert pareto(pts, 0.15) == [0, 1, 2]    # within 15 %: neither beats the other
    # more accurate and within the tolerance beats a faster one; beyond it, not
    assert pareto([(100.0, 0.02), (112.0, 0.01)], 0.15) == [1]
    assert pareto([(100.0, 0.02), (120.0, 0.01)], 0.15) == [0, 1]
