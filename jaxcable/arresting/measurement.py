r"""What the tracking controller sees: the noisy laser measurement of the rocket's head and
bottom, the 3-tap filter, and the target rule that turns them into slider targets.

Arresting-cable paper (Zhang et al. 2021), section II.A, eqs 1-3. The controller that uses them is
:mod:`jaxcable.arresting.control` (see its glossary for the symbols).

Measurement and filter (eqs 1-2)
--------------------------------
The measured head and bottom positions carry isotropic Gaussian noise (eq 1). Reading: "RMS
sigma_r" is the RMS of *each* Cartesian component (the 3D vector's RMS is sqrt(3) sigma_r).
Samples are i.i.d. at the sampling instants k Delta t (a discrete white noise). The paper does not
give Delta t; the default 0.02 s (50 Hz, a common rate for laser trackers) keeps the filter's mean
delay 2 Delta t = 0.04 s below the motor dead time (tau = 0.1 s), so the loop delay is set by the
motor as the paper assumes, and its second-order error 2.3 Delta t^2 |a| (below) is 9 mm for a
free-falling point (|a| = 9.81 m/s^2), a tenth of sigma_r = 0.1 m.

Eq 2 is the FIR filter ``r(t) = sum_j w_j r^m(t - j Delta t)``, w = (0.3, 0.4, 0.3), j = 1, 2, 3.
Inside a continuous ODE the true positions are available only at the current time, so for a
smoothly moving point we use the Taylor expansion of the filter: with ``sum w_j = 1``,
``sum j w_j = 2`` and ``sum j^2 w_j = 4.6``,

    sum_j w_j r(t - j Dt) = r - 2 Dt v + (4.6 / 2) Dt^2 a + O(Dt^3)
                          = [r(t) - 2 Dt v(t)] + 2.3 Dt^2 a + O(Dt^3 |a'|),

so :func:`delayed_measurement` ``r - 2 Dt v`` is exact at constant velocity and errs by
``2.3 Dt^2 a`` (exactly, for a quadratic trajectory; tested against the discrete filter). The true
delayed position r(t - 2 Dt) = r - 2 Dt v + 2 Dt^2 a would err by only 0.3 Dt^2 a, but it needs a
history of the scene's state. The noise part of eq 2 is exact on the sample grid: the filtered
noise sequence ``n_f[k] = 0.3 n[k-1] + 0.4 n[k-2] + 0.3 n[k-3]`` (RMS ``sqrt(0.34) sigma_r``) is
linearly interpolated between the samples (:class:`NoiseTrack`): continuous and piecewise linear in
t, so an adaptive solver meets kinks, not jumps, at the sample times.

Target rule (eq 3)
------------------
Our world frame has z up and the capture (top) plane at z = 0. The paper's words: while the whole
rocket is *above* the plane, the target is the bottom's projection; once it crosses the plane, the
intersection of the rocket axis with the plane. "Above" is z_b >= 0 here, which is the printed
inequality (section II.B's drop coordinate points down, where the same words would read z_b <= 0;
we follow the words). The intersection formula ``x_b - (x_b - x_h) z_b / (z_b - z_h)`` does not
depend on the sign convention of z. We write both branches as one point on the axis,
``r_b + s (r_h - r_b)`` with ``s = max(-z_b, 0) / (z_h - z_b)`` clamped to [0, 1]: s = 0 above the
plane (projection), the printed intersection below it, continuous at z_b = 0 (s -> 0). The clamp
(our addition; eq 3 is silent there) picks the head's projection when the head too is below the
plane, and keeps a horizontal or inverted axis finite. The division uses the double-``where``
trick, so values and gradients are finite everywhere (the rule is continuous with a kink at
z_b = 0, as printed).
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp

from jaxcable.core.validation import as_array, check_finite, check_positive

__all__ = [
    "FILTER_DELAYS",
    "FILTER_WEIGHTS",
    "NoiseTrack",
    "delayed_measurement",
    "filter_noise_samples",
    "filtered_measurement",
    "measurement_noise",
    "measurement_noise_track",
    "slider_target",
    "target_point",
]

FILTER_WEIGHTS = (0.3, 0.4, 0.3)
"""Weights of the moving-average filter of eq 2 [-] (they sum to 1)."""
FILTER_DELAYS = (1, 2, 3)
"""Delays of the filter taps, in samples (mean delay sum w_j j = 2 samples)."""


# ---------------------------------------------------------------------------------------------
# measurement noise and the 3-tap filter (eqs 1-2)
# ---------------------------------------------------------------------------------------------


def measurement_noise(key, n_samples: int, noise_rms_m):
    """Raw measurement noise of head and bottom (eq 1): i.i.d. isotropic Gaussian samples.

    Args:
        key: a ``jax.random`` key (the same key gives the same noise).
        n_samples: number of sampling instants (static).
        noise_rms_m: sigma_r, RMS of each Cartesian component [m] (scalar).

    Returns:
        (n_samples, 2, 3) [m]: index 0 is the head, 1 the bottom.
    """
    return jnp.asarray(noise_rms_m) * jax.random.normal(key, (int(n_samples), 2, 3))


def filter_noise_samples(raw):
    """Eq 2 applied to a sampled sequence (..., with time on axis 0): ``y[k] = 0.3 raw[k+2] +
    0.4 raw[k+1] + 0.3 raw[k]``, i.e. output sample k uses the raw samples 1, 2, 3 steps before it
    when raw sample j is taken at time (j - 3) Delta t. Returns ``len(raw) - 3`` samples."""
    w1, w2, w3 = FILTER_WEIGHTS
    return w1 * raw[2:-1] + w2 * raw[1:-2] + w3 * raw[:-3]


class NoiseTrack(eqx.Module):
    """Filtered measurement noise on the sample grid t_k = k Delta t, linearly interpolated.

    Continuous and piecewise linear in t (differentiable between samples), so it can drive an
    adaptive ODE solver. Before t = 0 it holds the first value, after the last sample the last one.
    """

    sample_period_s: jax.Array = eqx.field(converter=as_array)
    """Delta t: sampling period [s], scalar."""
    values_m: jax.Array = eqx.field(converter=as_array)
    """Filtered noise at t_k = k Delta t: (n, 2, 3) [m] (head, bottom; x, y, z), n >= 2."""

    def __check_init__(self):
        check_positive("sample_period_s", self.sample_period_s)
        check_finite("values_m", self.values_m)
        if self.values_m.ndim != 3 or self.values_m.shape[1:] != (2, 3) or self.values_m.shape[0] < 2:
            raise ValueError(f"values_m must have shape (n >= 2, 2, 3), got {self.values_m.shape}")

    @property
    def sample_times(self):
        """t_k = k Delta t [s], (n,)."""
        return self.sample_period_s * jnp.arange(self.values_m.shape[0])

    def __call__(self, t):
        """Filtered noise of head and bottom at time t [s]: (2, 3) [m]."""
        n = self.values_m.shape[0]
        k = t / self.sample_period_s
        i = jnp.clip(jnp.floor(k), 0, n - 2)
        frac = jnp.clip(k - i, 0.0, 1.0)
        i = i.astype(int)
        return (1.0 - frac) * self.values_m[i] + frac * self.values_m[i + 1]


def measurement_noise_track(key, controller, t_end_s: float, sample_period_s=None) -> NoiseTrack:
    """Filtered noise covering [0, t_end_s] with the controller's Delta t and sigma_r.

    ``controller`` is a :class:`~jaxcable.arresting.control.TrackingController` (any object with
    ``sample_period_s`` and ``noise_rms_m``).

    Sizes need concrete ``t_end_s`` and ``controller.sample_period_s``; ``noise_rms_m`` may be
    traced (vmap over it). Draws ``n + 3`` raw samples for ``n`` filtered ones (eq 2 looks back 3).
    ``sample_period_s`` (a Python float) overrides the controller's, for callers that trace it."""
    check_positive("t_end_s", t_end_s)
    dt = controller.sample_period_s if sample_period_s is None else sample_period_s
    if isinstance(dt, jax.core.Tracer):
        raise ValueError("sample_period_s must be concrete to size the noise track")
    n = int(math.ceil(float(t_end_s) / float(dt))) + 2
    if n > 10**7:
        raise ValueError(
            f"t_end_s must give at most 1e7 noise samples at sample_period_s = {float(dt):g} s, got t_end_s = {t_end_s!r}"
        )
    raw = measurement_noise(key, n + 3, controller.noise_rms_m)
    return NoiseTrack(sample_period_s=dt, values_m=filter_noise_samples(raw))


def delayed_measurement(position_m, velocity_m_s, sample_period_s):
    """Noise-free part of the filtered measurement (eq 2) of a smoothly moving point:
    ``r - 2 Delta t v`` [m] (exact at constant velocity; error 2.3 Delta t^2 a). Any shape (..., 3)."""
    return position_m - 2.0 * sample_period_s * velocity_m_s


def filtered_measurement(positions_m, velocities_m_s, t, noise, sample_period_s):
    """What the controller sees at time t (eqs 1-2): ``r - 2 Delta t v + n_f(t)``.

    Args:
        positions_m, velocities_m_s: true head and bottom, (2, 3) [m], [m/s] (head first).
        t: time since the start of tracking [s].
        noise: a :class:`NoiseTrack`, or None for a noise-free measurement.
        sample_period_s: Delta t [s].

    Returns:
        (2, 3) [m]: filtered head, bottom.
    """
    measured = delayed_measurement(positions_m, velocities_m_s, sample_period_s)
    return measured if noise is None else measured + noise(t)


# ---------------------------------------------------------------------------------------------
# target rule (eq 3)
# ---------------------------------------------------------------------------------------------


def target_point(r_head, r_bottom):
    """Eq 3 in the z-up frame: the target (x_t, y_t) [m] on the top plane z = 0, shape (2,).

    Bottom above the plane (z_b >= 0): the bottom's projection; below: the intersection of the
    axis bottom -> head with z = 0 (the head's projection if the head is below too). NaN-free with
    finite gradients everywhere (see the module docstring).
    """
    z_b, z_h = r_bottom[2], r_head[2]
    depth = jnp.maximum(-z_b, 0.0)  # how far the bottom is below the plane
    crossing = depth > 0.0
    # s = depth / (z_h - z_b), clamped to [0, 1]: dividing by max(z_h - z_b, depth) clamps it and is
    # > 0 in the branch that uses it; the other branch divides by 1 (double where: no 0/0 in grads)
    denom = jnp.where(crossing, jnp.maximum(z_h - z_b, depth), 1.0)
    s = jnp.where(crossing, depth / denom, 0.0)
    return r_bottom[:2] + s * (r_head[:2] - r_bottom[:2])


def slider_target(r_head, r_bottom):
    """d^target = ``[x_t, x_t, y_t, y_t]`` [m], (4,): sliders 1-2 move along x, 3-4 along y."""
    xy = target_point(r_head, r_bottom)
    return jnp.stack([xy[0], xy[0], xy[1], xy[1]])
