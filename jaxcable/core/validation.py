"""Input checks that name the field and the value.

Checks run only on concrete values (Python or NumPy numbers, or concrete JAX arrays); under
``jit``/``vmap``/``grad`` the values are tracers and are checked at the public entry points instead.
"""

import jax
import numpy as np


def _concrete(value):
    if isinstance(value, jax.core.Tracer):
        return None
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return None


def check_finite(name, value):
    v = _concrete(value)
    if v is not None and not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be finite, got {value!r}")


def check_positive(name, value, allow_zero=False):
    v = _concrete(value)
    if v is None:
        return
    check_finite(name, value)
    bad = v < 0 if allow_zero else v <= 0
    if np.any(bad):
        kind = "non-negative" if allow_zero else "positive"
        raise ValueError(f"{name} must be {kind}, got {value!r}")


def check_range(name, value, low, high, inclusive=False, unit=""):
    v = _concrete(value)
    if v is None:
        return
    check_finite(name, value)
    bad = (v < low) | (v > high) if inclusive else (v <= low) | (v >= high)
    if np.any(bad):
        br = "[]" if inclusive else "()"
        raise ValueError(
            f"{name} must be in {br[0]}{low}, {high}{br[1]}{unit}, got {value!r}"
        )


def check_choice(name, value, choices):
    if value not in choices:
        raise ValueError(f"unknown {name} {value!r}; choose one of {sorted(choices)}")
