"""Applied forces on a rocket + segment-rope chain, one small component per physical effect.

Each component has ``node_forces(t, kin, scene) -> (n+1, 2)`` [N], node 0 being the rocket. A scene
holds a tuple of them and sums what they return: a cheap scene simply leaves components out.
"""

from __future__ import annotations

import abc

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from jaxcable.core.math import safe_norm, smooth_step
from jaxcable.core.validation import as_array, check_choice, check_positive

_DRAG_FORMS = ("standard", "per_axis")


class AbstractForce(eqx.Module):
    """A force contribution on every node of the chain."""

    @abc.abstractmethod
    def node_forces(self, t, kin, scene):
        """Force on each node [N], shape (n+1, 2)."""


class Gravity(AbstractForce):
    """Uniform gravity ``(0, -m g)`` on every node (paper eqs 11-12, sign corrected: y is up).

    Attributes:
        g_mps2: gravitational acceleration [m/s^2].
    """

    g_mps2: Float[Array, ""] = eqx.field(converter=as_array, default=9.81)

    def __check_init__(self):
        check_positive("gravity.g_mps2", self.g_mps2, allow_zero=True)

    def node_forces(self, t, kin, scene):
        return jnp.stack([jnp.zeros_like(kin.masses), -kin.masses * self.g_mps2], -1)


class Thrust(AbstractForce):
    """The rocket motor's thrust on node 0 (paper eq 15), along the velocity."""

    def node_forces(self, t, kin, scene):
        f = scene.rocket.thrust(t, kin.velocities[0], scene.launch.direction)
        return jnp.zeros_like(kin.velocities).at[0].set(f)


class AeroDrag(AbstractForce):
    """Quadratic drag on the rocket and on every rope segment (paper eqs 13-14).

    ``form="standard"`` (default): ``-1/2 rho_a C_D A |v| v``, along the relative velocity.
    ``form="per_axis"``: the paper's printed form, ``-1/2 rho_a C_D A (v_x|v_x|, v_y|v_y|)`` (sign
    corrected), which is not rotation invariant and over-predicts drag on oblique motion.
    The rocket uses its reference area ``pi d^2/4``; segment j uses ``d * l_j`` at its far-end node.

    Attributes:
        air_density_kgpm3: air density [kg/m^3].
        form: "standard" or "per_axis" (static).
    """

    air_density_kgpm3: Float[Array, ""] = eqx.field(converter=as_array, default=1.225)
    form: str = eqx.field(static=True, default="standard")

    def __check_init__(self):
        check_positive("aero.air_density_kgpm3", self.air_density_kgpm3, allow_zero=True)
        check_choice("drag form", self.form, _DRAG_FORMS)

    def node_forces(self, t, kin, scene):
        rope, rocket = scene.rope, scene.rocket
        area = jnp.concatenate(
            [
                jnp.reshape(rocket.drag_coefficient * rocket.reference_area_m2, (1,)),
                rope.drag_coefficient * rope.diameter_m * kin.lengths,
            ]
        )
        v = kin.velocities
        if self.form == "standard":
            quad = safe_norm(v)[:, None] * v
        else:
            quad = v * jnp.abs(v)
        return -0.5 * self.air_density_kgpm3 * area[:, None] * quad


class Ground(AbstractForce):
    """Ground at y = 0 for the rope nodes: rope that reaches the ground lies on it.

    A node below the ground gets a mass-proportional penalty normal force, a spring-damper with
    natural rate ``rate_radps`` and damping ratio ``damping_ratio`` (so the sinking depth under its
    own weight, ``g / rate^2`` = 2.5 cm at the default, is the same for every segment length), and a
    regularised Coulomb friction ``-mu N tanh(v_x / slip_speed_mps)`` that brings rope lying on the
    ground to rest and resists dragging it (``mu = friction_coefficient``). Contact switches on over
    ``width_m`` with a logistic step. The rocket (node 0) is excluded: its impact ends the flight.

    A viscous tangential law (force proportional to speed) was tried first: at the 100 m/s at which
    rope is dragged off the ground it glues the rope down with ~50 g, and it made reverse-mode
    gradients disagree with finite differences; the Coulomb form does not (see tests).
    """

    # Defaults chosen by measurement (30 deg flight, 2 m segments, dopri5 rtol 1e-5): a 50 rad/s,
    # 5 mm contact took 1605 steps, this 20 rad/s, 5 cm one 963, and the range moved by 0.002%.
    rate_radps: float = eqx.field(static=True, default=20.0)
    damping_ratio: float = eqx.field(static=True, default=1.0)
    friction_coefficient: float = eqx.field(static=True, default=0.5)
    slip_speed_mps: float = eqx.field(static=True, default=0.1)
    width_m: float = eqx.field(static=True, default=0.05)

    def node_forces(self, t, kin, scene):
        y = kin.positions[:, 1]
        vx, vy = kin.velocities[:, 0], kin.velocities[:, 1]
        depth = -y
        on = smooth_step(depth, self.width_m)
        m = kin.masses
        w = self.rate_radps
        normal = m * on * (w**2 * jnp.maximum(depth, 0.0) - 2 * self.damping_ratio * w * vy)
        normal = jnp.maximum(normal, 0.0)  # the ground pushes, never pulls
        tangential = -self.friction_coefficient * normal * jnp.tanh(vx / self.slip_speed_mps)
        f = jnp.stack([tangential, normal], -1)
        return f.at[0].set(0.0)


class NoPullOut(AbstractForce):
    """No pull-out force: new rope joins the flying tail already moving (the paper's Kane form).

    This creates the joining rope's momentum from nothing; kept as the paper-faithful option.
    """

    def node_forces(self, t, kin, scene):
        return jnp.zeros_like(kin.velocities)


class ConstantPullOut(AbstractForce):
    """A constant resistance of the box, ``force_N``, on the tail node, along the rope, while paying out.

    Attributes:
        force_N: pull-out resistance [N].
        speed_width_mps: payout speed over which the force switches on (tanh) [m/s] (static).
    """

    force_N: Float[Array, ""] = eqx.field(converter=as_array, default=50.0)
    speed_width_mps: float = eqx.field(static=True, default=0.1)

    def __check_init__(self):
        check_positive("pullout.force_N", self.force_N, allow_zero=True)

    def node_forces(self, t, kin, scene):
        f = -self.force_N * jnp.tanh(kin.payout_rate / self.speed_width_mps) * kin.tail_direction
        return jnp.zeros_like(kin.velocities).at[kin.tail_index].add(jnp.where(kin.has_tail, f, 0.0))


class MomentumFluxPullOut(AbstractForce):
    """Momentum flux of rope pulled from rest: ``-rho (dS/dt) v_tail`` on the tail node.

    The rope joining the tail is at rest in the box and leaves with the tail's material velocity, so
    this is the exact momentum balance of the accreting tail mass (``rho v^2`` in a straight pull).
    An optional constant box resistance ``box_force_N`` adds on top.
    """

    box_force_N: Float[Array, ""] = eqx.field(converter=as_array, default=0.0)
    speed_width_mps: float = eqx.field(static=True, default=0.1)

    def __check_init__(self):
        check_positive("pullout.box_force_N", self.box_force_N, allow_zero=True)

    def node_forces(self, t, kin, scene):
        rho = scene.rope.linear_density_kg_per_m
        v_tail = kin.velocities[kin.tail_index]
        f = -rho * kin.payout_rate * v_tail
        f = f - self.box_force_N * jnp.tanh(kin.payout_rate / self.speed_width_mps) * kin.tail_direction
        return jnp.zeros_like(kin.velocities).at[kin.tail_index].add(jnp.where(kin.has_tail, f, 0.0))


PULLOUT_MODELS = {
    "none": NoPullOut,
    "constant": ConstantPullOut,
    "momentum_flux": MomentumFluxPullOut,
}


def make_pullout(kind: str, force_N=0.0):
    """Pull-out model by name: "none", "constant" (``force_N``) or "momentum_flux" (+ ``force_N``)."""
    check_choice("pull-out model", kind, PULLOUT_MODELS)
    if kind == "none":
        return NoPullOut()
    if kind == "constant":
        return ConstantPullOut(force_N=force_N)
    return MomentumFluxPullOut(box_force_N=force_N)
