"""What a scene is: components + parameters + state, and the vector field they define.

A scene is an ``eqx.Module`` (a PyTree): its array fields are parameters (sweepable with ``vmap``,
differentiable), its static fields are structure (array sizes, which components it has). A concrete
scene composes only the components it needs, so a cheap scene is cheap by construction.

:func:`jaxcable.core.simulate` needs from a scene:

* ``initial_state()``: the state PyTree at ``t = 0``;
* ``vector_field(t, state)``: its time derivative;
* ``terminal_event(t, state)``: a scalar whose sign change ends the run (or ``None`` attribute);
* ``jump_times()``: times where the vector field jumps (motor burn-out, ...), told to the stepper;
* ``probe(t, state)``: a small PyTree saved on the output grid (time histories);
* ``snapshot(t, state)``: a larger PyTree saved at a few instants (shapes);
* ``summarize(...)``: the scalar outputs users ask for.
"""

from __future__ import annotations

import abc

import equinox as eqx
import jax.numpy as jnp


class AbstractScene(eqx.Module):
    """Base class of every scene."""

    @abc.abstractmethod
    def initial_state(self):
        """State PyTree at t = 0."""

    @abc.abstractmethod
    def vector_field(self, t, state):
        """d(state)/dt."""

    def terminal_event(self, t, state):
        """Scalar; the run ends when it crosses zero. ``None`` to run to ``t1``."""
        return None

    @property
    def has_terminal_event(self) -> bool:
        return False

    def jump_times(self):
        """Times at which the vector field is discontinuous (array), or ``None``."""
        return None

    def default_save_ts(self, t1):
        """Times of the probe histories when the caller gives none [s]."""
        return jnp.linspace(0.0, t1, 101)

    def default_snapshot_ts(self, t1):
        """Times of the snapshots when the caller gives none [s]."""
        return jnp.reshape(jnp.asarray(t1, dtype=float), (1,))

    def probe(self, t, state):
        """Small PyTree saved on the output grid."""
        return state

    def snapshot(self, t, state):
        """PyTree saved at the snapshot instants."""
        return state

    def summarize(self, result):
        """Dict of scalar outputs computed from a :class:`jaxcable.Result`."""
        return {}
