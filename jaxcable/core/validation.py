"""Input checks that name the field and the value.

Every message has the form ``"<field> must be ..., got <value>"``. Checks run only on concrete
values (Python or NumPy numbers, or concrete JAX arrays); under ``jit``/``vmap``/``grad`` the values
are tracers and are checked at the public entry points instead, so the checks never break a
transformation. A value of the wrong type (a string, ``None``, a complex or boolean number, a
container of those) raises :class:`InputTypeError`, which is both a ``TypeError`` and a
``ValueError`` (callers that report bad input by catching ``ValueError``, like the command line,
catch it too).

Modules whose array fields are converted with :func:`as_array` / :func:`as_float_array` keep a
non-numeric value as it is, so that their ``__check_init__`` names the field (``jnp.asarray`` alone
would fail first, without the field's name).
"""

import jax
import jax.numpy as jnp
import numpy as np


class InputTypeError(TypeError, ValueError):
    """A value of the wrong type for its field (e.g. a string where a number is needed)."""


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


def as_array(value):
    """Field converter: ``jnp.asarray(value)``, or ``value`` unchanged when it is not numeric, so
    that the Module's ``__check_init__`` (not the converter) rejects it with the field's name."""
    try:
        return jnp.asarray(value)
    except (TypeError, ValueError):
        return value


def as_float_array(value):
    """Field converter: :func:`float_array`, or ``value`` unchanged when it is not a real number
    (see :func:`as_array`)."""
    try:
        array = jnp.asarray(value)
    except (TypeError, ValueError):
        return value
    if array.dtype == bool or jnp.issubdtype(array.dtype, jnp.complexfloating):
        return value
    return float_array(array)


def _show(value):
    """A short ``repr`` of a value for an error message (arrays as their numbers)."""
    if isinstance(value, (np.ndarray, np.generic, jax.Array)) and not isinstance(value, jax.core.Tracer):
        arr = np.asarray(value)
        if arr.shape == ():
            text = str(arr)  # the dtype's shortest form: 1e+12 for a float32 1e12, 2.0 for a float 2
        else:
            text = np.array2string(arr, threshold=8, precision=7)
    else:
        text = repr(value)
    return text if len(text) <= 120 else text[:117] + "..."


def real(name, value):
    """``value`` as a concrete float NumPy array; ``None`` when traced. Raises
    :class:`InputTypeError` naming ``name`` for a value that is not a real number or an array of
    real numbers (strings, ``None``, booleans, complex numbers, objects)."""
    if isinstance(value, jax.core.Tracer):
        return None
    bad = isinstance(value, (str, bytes, bool, np.bool_)) or value is None
    if not bad:
        try:
            arr = np.asarray(value)
        except Exception:  # noqa: BLE001 - ragged lists and the like
            bad = True
        else:
            bad = arr.dtype.kind not in "iuf" and not (
                arr.dtype.kind == "V" and jnp.issubdtype(arr.dtype, jnp.floating)  # bfloat16
            )
    if bad:
        raise InputTypeError(f"{name} must be a real number, got {_show(value)}")
    return np.asarray(value, dtype=float)


def check_real(name, value):
    """``value`` is a real number or an array of them (any finite or non-finite value)."""
    real(name, value)


def check_finite(name, value):
    v = real(name, value)
    if v is not None and not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be finite, got {_show(value)}")


def check_positive(name, value, allow_zero=False):
    v = real(name, value)
    if v is None:
        return
    check_finite(name, value)
    bad = v < 0 if allow_zero else v <= 0
    if np.any(bad):
        kind = "non-negative" if allow_zero else "positive"
        raise ValueError(f"{name} must be {kind}, got {_show(value)}")


def check_range(name, value, low, high, inclusive=False, unit="", *, low_inclusive=None, high_inclusive=None, why=""):
    """``low < value < high`` (``inclusive``: ``<=`` at both ends; ``low_inclusive`` /
    ``high_inclusive`` set one end). ``unit`` follows the interval in the message; ``why`` (a
    reason, e.g. the physical limit) follows it in parentheses."""
    v = real(name, value)
    if v is None:
        return
    check_finite(name, value)
    lo_in = inclusive if low_inclusive is None else low_inclusive
    hi_in = inclusive if high_inclusive is None else high_inclusive
    bad = ((v < low) if lo_in else (v <= low)) | ((v > high) if hi_in else (v >= high))
    if np.any(bad):
        reason = f" ({why})" if why else ""
        raise ValueError(
            f"{name} must be in {'[' if lo_in else '('}{low:g}, {high:g}{']' if hi_in else ')'}{unit}{reason}, "
            f"got {_show(value)}"
        )


def check_abs_max(name, value, limit, unit="", why=""):
    """``|value| <= limit`` (finite); ``why`` states the limit's reason in the message."""
    v = real(name, value)
    if v is None:
        return
    check_finite(name, value)
    if np.any(np.abs(v) > limit):
        reason = f" ({why})" if why else ""
        raise ValueError(f"|{name}| must be <= {limit:g}{unit}{reason}, got {_show(value)}")


def check_int(name, value, low=None, high=None):
    """``value`` is an integer (Python or NumPy, not a bool), ``low <= value <= high`` where given."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise InputTypeError(f"{name} must be an integer, got {_show(value)}")
    if (low is not None and value < low) or (high is not None and value > high):
        lo = "-inf" if low is None else f"{low}"
        hi = "inf" if high is None else f"{high}"
        raise ValueError(f"{name} must be an integer in [{lo}, {hi}], got {_show(value)}")


def check_bool(name, value):
    """``value`` is ``True`` or ``False``."""
    if not isinstance(value, (bool, np.bool_)):
        raise InputTypeError(f"{name} must be True or False, got {_show(value)}")


def check_instance(name, value, types, allow_none=False):
    """``value`` is an instance of ``types`` (or ``None`` with ``allow_none``)."""
    if allow_none and value is None:
        return
    if not isinstance(value, types):
        types = types if isinstance(types, tuple) else (types,)
        names = " or ".join(t.__name__ for t in types) + (" or None" if allow_none else "")
        raise InputTypeError(f"{name} must be a {names}, got {_show(value)}")


def check_vector(name, value, shape):
    """``value`` is a finite real array of ``shape`` (a tuple; checked only when concrete)."""
    v = real(name, value)
    if v is None:
        return
    if v.shape != tuple(shape):
        raise ValueError(f"{name} must have shape {tuple(shape)}, got {_show(value)} (shape {v.shape})")
    check_finite(name, value)


def check_seed(name, value):
    """A random seed: an integer in ``[0, 2**32)``, or a JAX PRNG key array (not checked)."""
    if isinstance(value, jax.core.Tracer):
        return
    if isinstance(value, (np.ndarray, jax.Array)):
        if value.ndim != 0 or jax.dtypes.issubdtype(value.dtype, jax.dtypes.prng_key):
            return  # a key array (checked by jax.random)
        if jnp.issubdtype(value.dtype, jnp.integer):
            value = int(value)
    check_int(name, value, 0, 2**32 - 1)


def check_choice(name, value, choices):
    try:
        ok = value in choices
    except TypeError:  # an unhashable value against a dict or set of names
        ok = False
    if not ok:
        raise ValueError(f"unknown {name} {_show(value)}; choose one of {sorted(choices)}")


def check_fields(obj, rules, prefix=""):
    """Apply ``rules`` (``{field: check}``, each ``check(name, value)``) to the fields of ``obj`` (a
    Module, or a dict of values, of which only the keys present are checked); names in messages
    are ``prefix + field``."""
    for field, rule in rules.items():
        if isinstance(obj, dict):
            if field not in obj:
                continue
            value = obj[field]
        else:
            value = getattr(obj, field)
        rule(prefix + field, value)


def finite(name, value):
    """A rule for :func:`check_fields`: finite."""
    check_finite(name, value)


def positive(allow_zero=False, high=None, unit="", why=""):
    """A rule for :func:`check_fields`: positive (or non-negative), and at most ``high`` if given."""

    def rule(name, value):
        check_positive(name, value, allow_zero=allow_zero)
        if high is not None:
            check_range(name, value, 0.0, high, low_inclusive=allow_zero, high_inclusive=True, unit=unit, why=why)

    return rule


def within(low, high, inclusive=True, unit="", why=""):
    """A rule for :func:`check_fields`: in ``[low, high]`` (``inclusive=False``: open)."""
    return lambda name, value: check_range(name, value, low, high, inclusive=inclusive, unit=unit, why=why)


def abs_at_most(limit, unit="", why=""):
    """A rule for :func:`check_fields`: ``|value| <= limit``."""
    return lambda name, value: check_abs_max(name, value, limit, unit=unit, why=why)


_concrete = concrete  # the name the modules used before the helpers were shared
