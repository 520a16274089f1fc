"""Buffer device: a counterweight on a slideway with a friction brake, behind a moving pulley group.

Arresting-cable paper, sections II.B (eqs 12-13) and III.A ("the counterweight was considered as a
point mass, and the brake was replaced by a stick-slip friction force"), Table 1 (m_w = 0.92 t,
F_f = 3.13e5 N, alpha = 3).

Kinematics (our reading of eq 12). The two outer strands of a subsystem's cable end on a moving
pulley block; when the block moves by ``u`` [m] each strand shortens by ``u``, so the arresting span
gains ``2 u`` of cable. The transfer cable raises the counterweight by ``w = alpha u`` [m]. With rigid
cables in the central landing each leg of the span lengthens by ``u``, so ``w = alpha (ell - l_0)``:
exactly eq 12. Power balance: the block carries ``2 T`` (T the strand tension) and the counterweight
resists with ``F_b = m_w (g + w'') + F_brake``; ``2 T u' = F_b w'`` gives ``T = alpha F_b / 2``.

Brake (smooth stick-slip). The printed law is Coulomb friction: ``|F| <= F_f`` while stuck,
``F = F_f sign(w')`` while sliding. We write it as ``F_brake = F_f tanh(w' / v_width)``: a
regularised Coulomb law whose "stick" is a creep at ``|w'| ~ v_width * F / F_f``. ``v_width`` [m/s]
is a named parameter; its effect on z_max, a_max, sigma_max and on the step count is measured in
``experiments/bench_land.py``. Smaller widths are closer to Coulomb and stiffer: the brake's
linearised damping ``F_f / v_width`` over the counterweight mass sets a time constant
``m_w v_width / F_f`` (1.5e-4 s at the defaults), which an explicit solver must resolve.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp

from .._validation import check_positive


class BufferDevice(eqx.Module):
    """One buffer device (the paper has four identical ones). Fields are arrays (sweepable)."""

    counterweight_mass_kg: jax.Array = eqx.field(converter=jnp.asarray, default=920.0)
    """``m_w``: counterweight mass [kg] (Table 1: 0.92 t)."""
    brake_force_N: jax.Array = eqx.field(converter=jnp.asarray, default=3.13e5)
    """``F_f``: sliding friction force of the brake [N] (Table 1: 3.13e5 N)."""
    transfer_rate: jax.Array = eqx.field(converter=jnp.asarray, default=3.0)
    """``alpha``: counterweight travel per unit travel of the moving pulley block [-] (Table 1: 3)."""
    brake_velocity_width_m_s: jax.Array = eqx.field(converter=jnp.asarray, default=0.05)
    """Smoothing width of the stick-slip law ``F_f tanh(w'/width)`` [m/s]."""

    def __check_init__(self):
        check_positive("counterweight_mass_kg", self.counterweight_mass_kg)
        check_positive("brake_force_N", self.brake_force_N, allow_zero=True)
        check_positive("transfer_rate", self.transfer_rate)
        check_positive("brake_velocity_width_m_s", self.brake_velocity_width_m_s)

    def brake_force(self, w_dot):
        """Brake force opposing the counterweight's rise rate ``w_dot`` [m/s] -> [N] (>0 resists rise)."""
        return self.brake_force_N * jnp.tanh(w_dot / self.brake_velocity_width_m_s)

    def kinetic_energy(self, u_dot):
        """Counterweight kinetic energy [J] from the block rate ``u_dot`` [m/s]."""
        w_dot = self.transfer_rate * u_dot
        return 0.5 * self.counterweight_mass_kg * w_dot**2

    def potential_energy(self, u, g):
        """Counterweight potential energy ``m_w g w`` [J] (``g`` [m/s^2], > 0)."""
        return self.counterweight_mass_kg * g * self.transfer_rate * u

    def generalized_force(self, u_dot):
        """Brake force on the block coordinate ``u`` [N] (``-alpha F_brake(alpha u_dot)``)."""
        return -self.transfer_rate * self.brake_force(self.transfer_rate * u_dot)

    def brake_power(self, u_dot):
        """Power dissipated by the brake [W] (>= 0)."""
        w_dot = self.transfer_rate * u_dot
        return self.brake_force(w_dot) * w_dot
