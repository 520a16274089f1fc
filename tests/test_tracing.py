"""traced_once: a method called at several places of one program is traced once, and the program
computes what plain calls compute (values and derivatives)."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from jaxcable.core.config import enable_x64
from jaxcable.core.tracing import traced_once

enable_x64()


class _Spring(eqx.Module):
    k: jax.Array
    name: str = eqx.field(static=True, default="spring")
    calls: list = eqx.field(static=True, default_factory=list)

    def force(self, x, v):
        self.calls.append(1)  # counts traces (Python runs), not executions
        return -self.k * x - 0.1 * v * jnp.abs(v)


def _program(spring, x):
    a = traced_once(type(spring).force, spring, x, 2.0 * x)
    b = traced_once(type(spring).force, spring, x + 1.0, a)
    c = traced_once(type(spring).force, spring, a, b)
    return a + b + c


def test_traced_once_per_structure_with_the_plain_calls_values_and_derivatives():
    spring = _Spring(jnp.asarray(3.0))
    x = jnp.asarray([0.2, -0.5, 1.5])
    value = jax.jit(_program)(spring, x)
    assert len(spring.calls) == 1  # three calls of the same shapes, one trace

    def plain(spring, x):
        f = lambda x_, v_: -spring.k * x_ - 0.1 * v_ * jnp.abs(v_)  # noqa: E731
        a = f(x, 2.0 * x)
        b = f(x + 1.0, a)
        return a + b + f(a, b)

    np.testing.assert_allclose(value, plain(spring, x), rtol=1e-14)
    g = jax.grad(lambda k: jnp.sum(_program(_Spring(k), x)))(jnp.asarray(3.0))
    g_plain = jax.grad(lambda k: jnp.sum(plain(_Spring(k), x)))(jnp.asarray(3.0))
    np.testing.assert_allclose(g, g_plain, rtol=1e-12)
    jac = jax.jacfwd(lambda x_: _program(spring, x_))(x)
    np.testing.assert_allclose(jac, jax.jacfwd(lambda x_: plain(spring, x_))(x), rtol=1e-12)
    # vmapped: the same values as one case at a time
    xs = jnp.stack([x, 2.0 * x])
    np.testing.assert_allclose(jax.vmap(lambda x_: _program(spring, x_))(xs)[1], _program(spring, 2.0 * x), rtol=1e-14)


def test_traced_once_traces_again_for_another_structure_or_static_value():
    spring = _Spring(jnp.asarray(3.0))
    x = jnp.asarray([0.2, -0.5, 1.5])
    call = jax.jit(lambda s, x_: traced_once(type(s).force, s, x_, x_))
    call(spring, x)
    call(spring, 2.0 * x)  # the same structure and shapes: cached
    assert len(spring.calls) == 1
    call(spring, x[:2])  # other shapes
    assert len(spring.calls) == 2
    other = _Spring(jnp.asarray(3.0), name="other", calls=spring.calls)  # another static field
    call(other, x)
    assert len(spring.calls) == 3
    # outside a trace it is a plain call: run (and counted) every time
    traced_once(type(spring).force, spring, x, x)
    traced_once(type(spring).force, spring, x, x)
    assert len(spring.calls) == 5
