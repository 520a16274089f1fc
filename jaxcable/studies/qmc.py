"""Quasi-Monte Carlo points over named parameter ranges: SciPy's scrambled Halton sequence.

Each parameter gets one dimension of the sequence, in the order of the ranges given, and each unit
coordinate ``u`` in [0, 1) is mapped linearly onto its range, ``lo + u (hi - lo)`` (in the range's
own unit). The points are deterministic for a seed, and the first ``n`` points of a larger draw
equal the ``n``-point draw (the prefix property: a sweep can be extended without changing its
earlier cases).

Halton (not Sobol): any ``n`` is balanced (Sobol wants powers of two). Scrambling (random digit
permutations fixed by the seed) removes the strong correlations of the unscrambled sequence
between high dimensions.
"""

from __future__ import annotations

import numpy as np

from jaxcable.core.validation import check_positive

__all__ = ["halton_unit", "scaled_halton"]


def _check_count(n):
    if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)):
        raise ValueError(f"n must be a non-negative integer, got {n!r}")
    check_positive("n", n, allow_zero=True)
    return int(n)


def halton_unit(n: int, d: int, seed: int = 0) -> np.ndarray:
    """The first ``n`` points of the scrambled ``d``-dimensional Halton sequence of ``seed``: (n, d)
    in [0, 1) (:class:`scipy.stats.qmc.Halton`)."""
    from scipy.stats import qmc

    n = _check_count(n)
    if n == 0:
        return np.zeros((0, d))
    return qmc.Halton(d=d, scramble=True, seed=int(seed)).random(n)


def scaled_halton(ranges: dict, n: int, seed: int = 0) -> dict:
    """``n`` points over the box ``ranges`` (``{name: (lo, hi)}``, one Halton dimension per name in
    its order): ``{name: np.ndarray (n,)}``, each ``lo + u (hi - lo)``. A range with ``lo == hi``
    gives the constant ``lo`` and still takes its dimension (the others do not shift)."""
    u = halton_unit(n, len(ranges), seed)
    return {name: lo + u[:, j] * (hi - lo) for j, (name, (lo, hi)) in enumerate(ranges.items())}
