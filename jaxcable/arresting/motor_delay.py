r"""The servo motor's dead time e^{-tau s} as a rational approximant in state-space form.

Arresting-cable paper (Zhang et al. 2021), section II.A, eqs 7-8: the delay tau of the motor
model. :class:`jaxcable.arresting.control.TrackingController` builds one of these from its
``motor_delay_s``, ``delay_model`` and ``delay_order``.

diffrax has no delay equations. ``e^{-tau s}`` is replaced by a rational approximant
``R(tau s)`` realised as ``tau x' = A0 x + B0 u``, ``y = C0 x + D0 u`` with constant matrices in the
scaled variable ``sigma = tau s`` (so tau is an array field: vmappable and differentiable):

* :class:`PadeDelay`: the [n/n] Pade approximant (all-pass, |R| = 1). Its companion form has
  states of wildly different scale (the constant coefficient is 30240 at n = 5), which misleads
  an adaptive solver's mixed error norm; we use the *balanced* realisation (Gramians equal; for an
  all-pass every Hankel singular value is 1), computed once per order with SciPy.
* :class:`LagChainDelay`: n first-order lags of tau / n each, ``1 / (1 + tau s / n)^n``.

At tau = 0 both are the identity, y = u: a double ``where`` keeps the 1 / tau branch out of values
and gradients there. The gradient with respect to tau *at* tau = 0 is therefore 0 (the identity
branch), not the one-sided derivative for tau -> 0+; it is exact for every tau > 0. Small positive tau makes the filter stiff (fastest pole |p_max| / tau, |p_max|
= 2, 3.5, 5.1, 6.8, 8.5 for Pade orders 1-5); use an implicit solver for tau << 0.01 s.

Measured on the Fig 4 case (tau = 0.1 s, t_c = 10 s, a_p = 2, 17 m, no noise; against the exact
delayed reference :func:`jaxcable.arresting.control.delayed_loop_reference`; ``experiments/figure4_controller.py``): Pade
orders 1-5 err 4.8e-4, 2.2e-5, 5.9e-6, 2.3e-6, 1.1e-6 m in d and 5.3e-3, 1.0e-3, 4.2e-4, 2.2e-4,
1.3e-4 m/s in v_p (peak 6.3 m/s); a chain of 16 lags errs 1.1e-3 m and 2.0e-3 m/s, worse than Pade
order 1. Default: Pade order 2 (see :attr:`jaxcable.arresting.control.TrackingController.delay_order`).
"""

from __future__ import annotations

import abc
import functools
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import scipy.linalg

from jaxcable.core.validation import as_array, check_positive

__all__ = [
    "AbstractDelay",
    "LagChainDelay",
    "PadeDelay",
]


@functools.lru_cache(maxsize=None)
def _pade_matrices(order: int):
    """Balanced realisation (A0, B0, C0, D0) of the [n/n] Pade approximant of e^{-sigma}."""
    n = order
    # D(sigma) = sum_k c_k sigma^k, N(sigma) = D(-sigma); R = N / D
    c = np.array(
        [
            math.factorial(2 * n - k) * math.factorial(n)
            / (math.factorial(2 * n) * math.factorial(k) * math.factorial(n - k))
            for k in range(n + 1)
        ]
    )
    a = c / c[n]  # monic denominator
    A = np.zeros((n, n))
    A[:-1, 1:] = np.eye(n - 1)
    A[-1, :] = -a[:n]
    B = np.zeros((n, 1))
    B[-1, 0] = 1.0
    D = float((-1) ** n)
    numer = a * (-1.0) ** np.arange(n + 1)  # monic-scaled numerator, leading coefficient (-1)^n
    C = (numer[:n] - D * a[:n])[None, :]
    # balance: W_c = W_o = Sigma (all ones for an all-pass); T = L U Sigma^{-1/2}, W_c = L L^T
    Wc = scipy.linalg.solve_continuous_lyapunov(A, -B @ B.T)
    Wo = scipy.linalg.solve_continuous_lyapunov(A.T, -C.T @ C)
    L = np.linalg.cholesky(Wc)
    U, s2, _ = np.linalg.svd(L.T @ Wo @ L)
    T = L @ U @ np.diag(s2**-0.25)
    Ti = np.linalg.inv(T)
    return Ti @ A @ T, (Ti @ B)[:, 0], (C @ T)[0], D


@functools.lru_cache(maxsize=None)
def _lag_chain_matrices(n_lags: int):
    """(A0, B0, C0, D0) of 1 / (1 + sigma / n)^n: x_1' = n (u - x_1), x_k' = n (x_{k-1} - x_k)."""
    n = n_lags
    A = n * (-np.eye(n) + np.eye(n, k=-1))
    B = np.zeros(n)
    B[0] = n
    C = np.zeros(n)
    C[-1] = 1.0
    return A, B, C, 0.0


class AbstractDelay(eqx.Module):
    """A rational approximant R(tau s) of the dead time e^{-tau s}, realised in the scaled variable
    sigma = tau s: ``tau x' = A0 x + B0 u``, ``y = C0 x + D0 u``. Concrete subclasses give the
    matrices; ``delay_s`` is an array field of each."""

    @property
    @abc.abstractmethod
    def n_states(self) -> int:
        """Number of filter states per channel."""

    @abc.abstractmethod
    def unit_matrices(self):
        """NumPy (A0 (n, n), B0 (n,), C0 (n,), D0 float) of R(sigma)."""

    def derivative(self, x, u):
        """Filter states x (..., n) and input u (...) -> (dx/dt (..., n), delayed output y (...)).

        At delay_s = 0 the filter is the identity (y = u, x frozen); the 1 / tau branch is kept out
        of values and gradients there by a double ``where``."""
        A0, B0, C0, D0 = (jnp.asarray(m) for m in self.unit_matrices())
        tau = self.delay_s
        has_delay = tau > 0.0
        tau_safe = jnp.where(has_delay, tau, 1.0)
        dx = (x @ A0.T + u[..., None] * B0) / tau_safe
        dx = jnp.where(has_delay, dx, 0.0)
        y = jnp.where(has_delay, x @ C0 + D0 * u, u)
        return dx, y

    def frequency_response(self, omega_rad_s):
        """R(i omega tau) as a NumPy complex array (for tests and plots; concrete delay_s only)."""
        A0, B0, C0, D0 = self.unit_matrices()
        tau = float(self.delay_s)
        out = []
        for w in np.atleast_1d(np.asarray(omega_rad_s, float)):
            sig = 1j * w * tau
            out.append(C0 @ np.linalg.solve(sig * np.eye(len(B0)) - A0, B0) + D0)
        return np.array(out)


class PadeDelay(AbstractDelay):
    """[n/n] Pade approximant of e^{-tau s} (all-pass), balanced state-space realisation."""

    delay_s: jax.Array = eqx.field(converter=as_array, default=0.1)
    """tau: dead time [s], scalar, >= 0."""
    order: int = eqx.field(static=True, default=2)
    """Pade order n (1..8): n states per channel."""

    def __check_init__(self):
        check_positive("delay_s", self.delay_s, allow_zero=True)
        if not isinstance(self.order, (int, np.integer)) or not 1 <= int(self.order) <= 8:
            raise ValueError(f"order must be an integer in [1, 8], got {self.order!r}")

    @property
    def n_states(self) -> int:
        return int(self.order)

    def unit_matrices(self):
        return _pade_matrices(int(self.order))


class LagChainDelay(AbstractDelay):
    """A chain of n first-order lags of tau / n each: ``1 / (1 + tau s / n)^n``."""

    delay_s: jax.Array = eqx.field(converter=as_array, default=0.1)
    """tau: dead time [s], scalar, >= 0."""
    n_lags: int = eqx.field(static=True, default=4)
    """Number of lags n (>= 1): n states per channel."""

    def __check_init__(self):
        check_positive("delay_s", self.delay_s, allow_zero=True)
        if not isinstance(self.n_lags, (int, np.integer)) or int(self.n_lags) < 1:
            raise ValueError(f"n_lags must be a positive integer, got {self.n_lags!r}")

    @property
    def n_states(self) -> int:
        return int(self.n_lags)

    def unit_matrices(self):
        return _lag_chain_matrices(int(self.n_lags))
