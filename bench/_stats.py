"""Shared by the benches: percentiles of a sorted sample."""


def quantile(ordered: list[float], q: float) -> float:
    """The q-quantile (0..1) of an already sorted list; NaN when it is empty."""
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))] if ordered else float("nan")
