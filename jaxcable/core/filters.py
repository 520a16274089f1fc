r"""Channel-frequency-class (CFC) low-pass filters of SAE J211/1 (ISO 6487's classes), in JAX.

Crash and drop tests report accelerations and loads after a standard low-pass filter, named by its
*channel frequency class* ``CFC`` [Hz]. J211's table of applications: CFC 60 for vehicle structural
accelerations in total-vehicle comparison and as collision-simulation (sled) input, and for
barrier-force and belt load cells; CFC 180 for structural accelerations to be integrated to velocity
or displacement, and the occupant's spine; CFC 600 for component analysis; CFC 1000 for the dummy's
head. SAE J211/1 (rev. MAR95 onward), Appendix C, gives the filter as a second-order Butterworth
low-pass applied once forward and once backward in time (zero phase, a 4-pole response), whose 3 dB
frequency ``F_H`` is ``5/3 CFC`` (100, 300, 1000, 1650 Hz). The coefficients here are J211's; ISO
6487's printed formulas differ slightly.

Derivation (re-derived here; J211's Appendix C prints the result)
-----------------------------------------------------------------
The analog prototype is the second-order Butterworth ``H(s) = w_a^2 / (s^2 + sqrt(2) w_a s + w_a^2)``
with ``|H(j w)|^2 = 1 / (1 + (w / w_a)^4)``. The digital filter is its bilinear transform
``s = (1 - z^-1) / (1 + z^-1)`` (the factor ``2 / T`` absorbed into ``w_a``), prewarped so that the
design frequency ``w_d`` maps exactly: ``w_a = tan(w_d T / 2)``. Substituting and dividing by
``D = 1 + sqrt(2) w_a + w_a^2`` gives the difference equation

    y[n] = a0 x[n] + a1 x[n-1] + a2 x[n-2] + b1 y[n-1] + b2 y[n-2],
    a0 = w_a^2 / D,  a1 = 2 a0,  a2 = a0,
    b1 = -2 (w_a^2 - 1) / D,  b2 = (-1 + sqrt(2) w_a - w_a^2) / D,

J211's formulas with ``w_d = 2 pi CFC 2.0775`` and ``w_a = sin(w_d T/2) / cos(w_d T/2)``. On the unit
circle ``s = j tan(w T / 2)``, so one pass has ``|H|^2 = 1 / (1 + (tan(w T/2) / w_a)^4)`` exactly,
and the forward-backward pair has the real, zero-phase gain

    G(f) = 1 / (1 + (tan(pi f T) / w_a)^4)                      (:func:`cfc_gain`)

``G(0) = (a0 + a1 + a2) / (1 - b1 - b2) = 1`` (a constant passes unchanged), ``G = 1/2`` at the design
frequency ``2.0775 CFC`` and ``G = 1/sqrt(2)`` (-3 dB) where ``(tan(pi f T)/w_a)^4 = sqrt(2) - 1``,
i.e. ``f = 2.0775 (sqrt(2) - 1)^(1/4) CFC = 1.666 CFC`` in the analog limit: J211's ``F_H``. The
bilinear map needs ``w_d T / 2 < pi / 2``: the design frequency ``2.0775 CFC`` below the Nyquist
frequency ``1 / (2 T)`` (:func:`cfc_max_spacing_s`); J211 further asks for a sample rate of at
least about 10 ``F_H`` (commercial J211 implementations accept 6 ``F_H``), which
:func:`cfc_recommended_spacing_s` returns.

Ends of the record (the filter needs a history before the first sample and after the last; J211
recommends padding of at least 10 ms): the forward pass starts in its steady state at the first
sample (the record extended backward by its first value), the backward pass in its steady state at
the last forward output. A constant passes unchanged; the step response settles to the step.

Non-finite samples (a run that ended early saves ``inf`` after its end) are replaced by the last
finite sample before them (:func:`hold_last_finite`) before filtering, so that no ``inf``/``NaN``
reaches the output or its gradient. Everything is traced (``jax.lax.scan``), so the filter is
differentiable in the signal and the spacing and vmaps over a batch of records.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp

from jaxcable.core.validation import check_positive, concrete_scalar

__all__ = [
    "CFC_DESIGN_FACTOR",
    "CFC_3DB_FACTOR",
    "N_INITIAL",
    "cfc_filter",
    "cfc_gain",
    "cfc_max_spacing_s",
    "cfc_recommended_spacing_s",
    "hold_last_finite",
    "j211_coefficients",
]

CFC_DESIGN_FACTOR = 2.0775
"""J211/1 Appendix C: the one-pass Butterworth's design frequency is ``2.0775 CFC`` [Hz]."""

CFC_3DB_FACTOR = CFC_DESIGN_FACTOR * (math.sqrt(2.0) - 1.0) ** 0.25
"""``F_H / CFC`` = 1.6664: the forward-backward filter's -3 dB frequency per unit class (analog
limit; J211 tabulates ``F_H`` = 100, 300, 1000, 1650 Hz for CFC 60, 180, 600, 1000)."""

SAMPLES_PER_F_H = 10.0
"""J211's guidance on the sample rate: at least about 10 samples per period of ``F_H``."""


def _check_cfc(cfc_hz):
    check_positive("cfc_hz", cfc_hz)


def _check_spacing(cfc_hz, dt_s):
    check_positive("dt_s", dt_s)
    dt, cfc = concrete_scalar(dt_s), concrete_scalar(cfc_hz)
    if dt is not None and cfc is not None and not dt < cfc_max_spacing_s(cfc):
        raise ValueError(
            f"dt_s must be below {cfc_max_spacing_s(cfc):.6g} s for a CFC {cfc:g} filter (its design frequency "
            f"{CFC_DESIGN_FACTOR * cfc:g} Hz must stay below the Nyquist frequency 1 / (2 dt_s)), got {dt_s!r}"
        )


def cfc_max_spacing_s(cfc_hz) -> float:
    """Largest sample spacing [s] the CFC ``cfc_hz`` filter can run on at all (exclusive bound): its
    design frequency ``2.0775 CFC`` at the Nyquist frequency, ``1 / (2 x 2.0775 CFC)`` (4.01 ms for
    CFC 60)."""
    _check_cfc(cfc_hz)
    return 1.0 / (2.0 * CFC_DESIGN_FACTOR * float(cfc_hz))


def cfc_recommended_spacing_s(cfc_hz) -> float:
    """Largest sample spacing [s] J211 recommends for CFC ``cfc_hz``: 10 samples per period of the
    3 dB frequency ``F_H = 1.666 CFC`` (1.0 ms for CFC 60, 0.33 ms for CFC 180)."""
    _check_cfc(cfc_hz)
    return 1.0 / (SAMPLES_PER_F_H * CFC_3DB_FACTOR * float(cfc_hz))


def j211_coefficients(cfc_hz, dt_s):
    """``(a0, a1, a2, b1, b2)`` of one pass of the J211 filter of class ``cfc_hz`` [Hz] at sample
    spacing ``dt_s`` [s] (the module docstring derives them); traced arguments are allowed."""
    _check_cfc(cfc_hz)
    _check_spacing(cfc_hz, dt_s)
    wd = 2.0 * jnp.pi * cfc_hz * CFC_DESIGN_FACTOR
    wa = jnp.tan(0.5 * wd * dt_s)
    d = 1.0 + jnp.sqrt(2.0) * wa + wa**2
    a0 = wa**2 / d
    b1 = -2.0 * (wa**2 - 1.0) / d
    b2 = (-1.0 + jnp.sqrt(2.0) * wa - wa**2) / d
    return a0, 2.0 * a0, a0, b1, b2


def cfc_gain(freq_hz, cfc_hz, dt_s):
    """Closed-form gain [-] of the forward-backward J211 filter at frequency ``freq_hz`` [Hz] (below
    the Nyquist frequency): ``1 / (1 + (tan(pi f dt) / tan(pi 2.0775 CFC dt))^4)``, real (zero phase)."""
    _check_cfc(cfc_hz)
    _check_spacing(cfc_hz, dt_s)
    wa = jnp.tan(jnp.pi * CFC_DESIGN_FACTOR * cfc_hz * dt_s)
    return 1.0 / (1.0 + (jnp.tan(jnp.pi * freq_hz * dt_s) / wa) ** 4)


def hold_last_finite(x, valid=None):
    """``x`` (n, ...) with every sample that is non-finite (or, where given, not ``valid`` (n,))
    replaced by the last good sample before it along axis 0, and by 0 before the first good one.

    The replacement is a gather and ``where``: the gradient reaches the held samples and no
    ``inf``/``NaN`` of a replaced sample enters it."""
    x = jnp.asarray(x)
    good = jnp.isfinite(x)
    if valid is not None:
        good = good & jnp.reshape(jnp.asarray(valid, bool), (-1,) + (1,) * (x.ndim - 1))
    safe = jnp.where(good, x, 0.0)
    idx = jnp.arange(x.shape[0]).reshape((-1,) + (1,) * (x.ndim - 1))
    last = jax.lax.cummax(jnp.where(good, idx, -1), axis=0)
    held = jnp.take_along_axis(safe, jnp.maximum(last, 0), axis=0)
    return jnp.where(last >= 0, held, 0.0)


def _one_pass(x, coefficients):
    """One causal pass over axis 0, started in the steady state of ``x[0]``."""
    a0, a1, a2, b1, b2 = coefficients

    def step(carry, xn):
        x1, x2, y1, y2 = carry
        yn = a0 * xn + a1 * x1 + a2 * x2 + b1 * y1 + b2 * y2
        return (xn, x1, yn, y1), yn

    start = (x[0], x[0], x[0], x[0])
    _, y = jax.lax.scan(step, start, x)
    return y


N_INITIAL = 64
"""Samples of the signal before the record that :func:`cfc_filter` prepends when given ``initial``
(64 ms at 1 ms spacing; J211 asks for at least 10 ms of padding; the filter's poles decay at
``2 pi 2.0775 CFC / sqrt(2)`` = 554 1/s for CFC 60, so 64 samples of 0.4-1 ms leave < 1e-6)."""


def cfc_filter(x, dt_s, cfc_hz=60.0, valid=None, initial=None):
    """The SAE J211/1 (ISO 6487) CFC ``cfc_hz`` [Hz] filter of a record ``x`` (n, ...) sampled every
    ``dt_s`` [s] along axis 0: the second-order Butterworth of :func:`j211_coefficients` run forward,
    then backward (zero phase). Non-finite samples, and those not ``valid`` (n,), are first replaced
    by the last good one (:func:`hold_last_finite`); the passes start in their steady states (module
    docstring). ``initial`` (shape ``x.shape[1:]``, default None: the first sample): the signal
    before the record, prepended as :data:`N_INITIAL` samples, when the record starts with a jump
    (both passes then see it). Differentiable in ``x`` and ``dt_s``; vmappable; ``cfc_hz`` > 0 and,
    when concrete, ``dt_s`` below :func:`cfc_max_spacing_s` (ValueError naming the field otherwise)."""
    x = jnp.asarray(x)
    if x.ndim == 0 or x.shape[0] == 0:
        raise ValueError(f"x must be a record with at least one sample along axis 0, got shape {x.shape}")
    coefficients = j211_coefficients(cfc_hz, dt_s)
    held = hold_last_finite(x, valid)
    n_before = 0
    if initial is not None:
        initial = jnp.broadcast_to(jnp.asarray(initial, held.dtype), held.shape[1:])
        n_before = N_INITIAL
        held = jnp.concatenate([jnp.broadcast_to(initial, (n_before,) + held.shape[1:]), held])
    forward = _one_pass(held, coefficients)
    return _one_pass(forward[::-1], coefficients)[::-1][n_before:]
