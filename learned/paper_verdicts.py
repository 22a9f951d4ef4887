"""The verdict rule for the seed paper's findings: ours over repeats, against the paper's own figure as the bound.

Every finding the paper states is a comparison with a direction: a difference from the baseline *at most* its
figure (reservoir +1.5 mm), a saving of data *at least* its figure (65 % less), a ratio at most or at least its
figure (naive's diagonal 1.5x the baseline; its S1 14x the baseline), a count of eliminated poses at least its
figure. :func:`against` judges one such comparison over the repeats of a run:

- fewer than :data:`MIN_REPEATS` finite repeats: no verdict (:data:`FEW`), since one repeat has no spread and
  repeats of the same preset differ by about 15 % (``docs/reproduce-paper.md``);
- the bound is the paper's figure loosened by half a unit of its last stated digit (the paper rounds: its
  "65 %" is anything from 64.5 %), and nothing more;
- the *excess* is how far the mean over repeats lies beyond the bound, in the direction that breaks the claim;
  the *spread* is the repeats' sample standard deviation (``ddof = 1``). Excess above the spread:
  :data:`NOT`; at or below minus the spread: :data:`AS`; in between: :data:`WITHIN`, no verdict.

A finding that depends on a threshold the errors never reach (selection's eliminations and its data saving,
when the baseline's error is above the novelty threshold, where the paper's sits at half of it) is
:data:`LEVEL`: the caller decides that, this module names it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["AS", "NOT", "WITHIN", "LEVEL", "FEW", "NO_CLAIM", "MIN_REPEATS", "against", "spread", "describe"]

AS = "as the paper"
NOT = "NOT as the paper"
WITHIN = "within the spread"
LEVEL = "not judgeable at this error level"
FEW = "not judged: fewer than 3 repeats"
NO_CLAIM = "-"

#: Repeats a verdict needs: the fewest with a spread that is more than one difference.
MIN_REPEATS = 3


def _finite(values) -> np.ndarray:
    v = np.asarray(values, dtype=float).ravel()
    return v[np.isfinite(v)]


def spread(values) -> float:
    """The repeats' sample standard deviation (``ddof = 1``); NaN with fewer than two finite values."""
    v = _finite(values)
    return float(np.std(v, ddof=1)) if len(v) > 1 else float("nan")


def against(values, bound: float, at_most: bool, decimals: int = 0) -> str:
    """The verdict on one of the paper's comparisons.

    Parameters
    ----------
    values : array_like, shape (R,)
        Ours, one value per repeat (NaN values left out).
    bound : float
        The paper's figure.
    at_most : bool
        The claim holds when ours is at most the bound (a difference in error, a ratio of errors); False: at
        least (a saving of data, a ratio of forgetting, a count of eliminated poses).
    decimals : int
        Decimals the paper states the figure with; the bound is loosened by half of the last one.

    Returns
    -------
    str
        :data:`AS`, :data:`NOT`, :data:`WITHIN` or :data:`FEW`.

    Examples
    --------
    >>> against([2.4, 2.5, 2.3], 1.5, at_most=True, decimals=1)
    'NOT as the paper'
    >>> against([0.5, 3.0, 1.0], 1.5, at_most=True, decimals=1)
    'within the spread'
    """
    v = _finite(values)
    if len(v) < MIN_REPEATS:
        return FEW
    loose = 0.5 * 10.0**-decimals
    mean = float(v.mean())
    excess = mean - (bound + loose) if at_most else (bound - loose) - mean
    s = spread(v)
    if excess > s:
        return NOT
    if excess <= -s:
        return AS
    return WITHIN


def describe(values, fmt: str = "{:+.2f}", unit: str = "") -> str:
    """``mean ± spread unit (R repeats)``, or the one value with ``(1 repeat)``."""
    v = _finite(values)
    unit = f" {unit}" if unit else ""
    if not len(v):
        return "no finite value"
    if len(v) == 1:
        return f"{fmt.format(v[0])}{unit} (1 repeat)"
    return f"{fmt.format(v.mean())} ± {fmt.replace('+', '').format(spread(v))}{unit} ({len(v)} repeats)"
