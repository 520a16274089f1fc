"""Gradient-safe math helpers: norms safe at zero, smooth steps and ramps.

Every kink in the physics (slack, contact onset, payout starting) goes through one of these
so that its gradient is finite everywhere; each smoothing width is an argument with units.
"""

import jax.numpy as jnp


def safe_norm(x, axis=-1, eps=1e-30):
    """Euclidean norm whose gradient is finite (zero) at x = 0."""
    sq = jnp.sum(x * x, axis=axis)
    is_zero = sq <= eps
    safe_sq = jnp.where(is_zero, 1.0, sq)
    return jnp.where(is_zero, 0.0, jnp.sqrt(safe_sq))


def safe_normalize(x, fallback, axis=-1, eps=1e-30):
    """x / |x|, or ``fallback`` where |x| = 0 (gradient-safe)."""
    sq = jnp.sum(x * x, axis=axis, keepdims=True)
    is_zero = sq <= eps
    safe_sq = jnp.where(is_zero, 1.0, sq)
    return jnp.where(is_zero, fallback, x / jnp.sqrt(safe_sq))


def smooth_relu(x, width):
    """Softplus ramp ``width * log(1 + exp(x / width))``: ~max(x, 0) with a rounded kink of `width`."""
    return width * jnp.logaddexp(0.0, x / width)


def smooth_step(x, width):
    """Logistic step from 0 (x << -width) to 1 (x >> width)."""
    return 0.5 * (1.0 + jnp.tanh(x / (2.0 * width)))


def cubic_step(t, t0, h0, t1, h1):
    """The C1 STEP function of the arresting-cable paper's appendix: h0 for t <= t0, h1 for t >= t1."""
    eta = jnp.clip((t - t0) / (t1 - t0), 0.0, 1.0)
    return h0 + (h1 - h0) * eta**2 * (3.0 - 2.0 * eta)
