"""Input checks that name the field and the value.

Checks run only on concrete values (Python or NumPy numbers, or concrete JAX arrays); under
``jit``/``vmap``/``grad`` the values are tracers and are checked at the public entry points instead.
"""

import jax
import jax.numpy as jnp
import numpy as np


def concrete(value):
    """``value`` as a float NumPy array, or ``None`` when it is traced (under ``jit``/``vmap``/``grad``)
    or not numeric: checks run only on values they can see."""
    if isinstance(value, jax.core.Tracer):
        return None
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return None


def concrete_scalar(value):
    """``value`` as a Python float when it is a concrete scalar, else ``None``."""
    arr = concrete(value)
    return float(arr) if arr is not None and arr.shape == () else None


def float_array(value):
    """A field as a floating JAX array, so ``vmap``/``grad`` reach it and ``jit`` traces it (no
    recompile for a new value, nor for a Python float against an array). A floating input keeps its
    dtype (float32 stays float32, for the measured float32 option); integers become the default float."""
    value = jnp.asarray(value)
    return value.astype(value.dtype if jnp.issubdtype(value.dtype, jnp.floating) else float)


def check_finite(name, value):
    v = concrete(value)
    if v is not None and not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be finite, got {value!r}")


def check_positive(name, value, allow_zero=False):
    v = concrete(value)
    if v is None:
        return
    check_finite(name, value)
    bad = v < 0 if allow_zero else v <= 0
    if np.any(bad):
        kind = "non-negative" if allow_zero else "positive"
        raise ValueError(f"{name} must be {kind}, got {value!r}")


def check_range(name, value, low, high, inclusive=False, unit=""):
    v = concrete(value)
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


_concrete = concrete  # the name the modules used before the helpers were shared
