"""Statics shared by the peer cable scripts (``moordyn_line.py``, ``exudyn_cable.py``): the static
equilibrium of jaxcable's ALE cable with both ends pinned (Newton on the generalised forces of
:func:`jaxcable.components.ale.assemble` over the internal nodes' positions, from a stretched guess), and
Irvine's elastic catenary, the closed form both compare against."""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq


def static_newton(cable, s, gravity, guess, scale, max_iter: int = 50):
    """Positions (n, 3) [m] of the discrete static equilibrium.

    Args:
        cable: :class:`jaxcable.components.ale.AleCable`; s: (n,) material coordinates [m];
        gravity: (3,) [m/s^2]; guess: (n, 3) start [m], its end nodes are the pins;
        scale: force scale of the residual [N] (e.g. the cable's weight); max_iter: Newton steps.
    """
    import jax
    import jax.numpy as jnp

    from jaxcable.components.ale import AleState, assemble

    n = s.shape[0]
    r0 = jnp.asarray(guess)
    zeros = jnp.zeros((n, 3))

    def residual(x):
        r = r0.at[1:-1].set(x.reshape(n - 2, 3))
        _, Q = assemble(cable, AleState(r=r, s=s, v=zeros, sdot=jnp.zeros(n)), gravity)
        return Q.reshape(n, 4)[1:-1, :3].reshape(-1) / scale

    step = jax.jit(lambda x: (residual(x), jax.jacfwd(residual)(x)))
    x = r0[1:-1].reshape(-1)
    for _ in range(max_iter):
        F, J = step(x)
        dx = jnp.linalg.solve(J, -F)
        x = x + dx
        if float(jnp.max(jnp.abs(dx))) < 1e-12:
            break
    F, _ = step(x)
    assert float(jnp.max(jnp.abs(F))) < 1e-10, "jaxcable static Newton did not converge"
    return np.asarray(r0.at[1:-1].set(x.reshape(n - 2, 3)))


def irvine(EA, w, L0, span):
    """Irvine's elastic catenary, level supports (Hooke): mid-material-point sag [m], H [N]."""

    def span_error(H):
        return H * L0 / EA + 2 * H / w * np.arcsinh(w * L0 / (2 * H)) - span

    H = brentq(span_error, 1e-6 * w * L0, 1e6 * w * L0)
    sag = w * L0**2 / (8 * EA) + H / w * (np.sqrt(1 + (w * L0 / (2 * H)) ** 2) - 1)
    return sag, H
