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

Brake profile (an extension; the paper's brake is constant). ``brake_profile`` (K,) scales the
sliding force along the counterweight's rise ``w``: ``F_f(w) = F_f * phi(w)``, ``phi`` the linear
interpolation of the K factors at equally spaced knots ``w_k = k * brake_profile_travel_m / (K-1)``,
held at the last factor beyond the last knot (and at the first below 0). It plays the part of the
metering cam of an aircraft arresting-gear engine, which shapes the braking force along the payout.
The force still opposes the motion and is a function of position times ``tanh(w'/width)``, so the
brake only dissipates (``brake_power >= 0``) and the energy budget is unchanged in form. ``None``
(default) is the constant brake of the paper, at no extra cost. The design module
(:mod:`jaxcable.arresting.design`, variables ``b0 .. b{K-1}``) optimises the factors.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp

from jaxcable.core.validation import as_array, check_fields, check_finite, check_positive, check_range, check_real, positive


class BufferDevice(eqx.Module):
    """One buffer device (the paper has four identical ones). Fields are arrays (sweepable).

    Bounds (checked on concrete values), each far outside Table 1 and the design bounds
    (:data:`jaxcable.arresting.design.DEFAULT_BOUNDS`: m_w 300-5000 kg, F_f 2e5-5e5 N, profile factors
    0.25-2): ``0 < m_w <= 1e5 kg``, ``0 <= F_f <= 1e7 N`` (above it the cables, which carry
    ``alpha F_f / 2`` each, would break many times over: 800 MPa on a 20 mm cable is 1e6 N),
    ``0 < alpha <= 100``, ``0 < width <= 10 m/s`` (half the design descent speed: wider, the brake
    is no longer a friction brake), profile factors in ``[0, 100]`` and ``0 < travel <= 1000 m``.
    """

    counterweight_mass_kg: jax.Array = eqx.field(converter=as_array, default=920.0)
    """``m_w``: counterweight mass [kg] (Table 1: 0.92 t)."""
    brake_force_N: jax.Array = eqx.field(converter=as_array, default=3.13e5)
    """``F_f``: sliding friction force of the brake [N] (Table 1: 3.13e5 N)."""
    transfer_rate: jax.Array = eqx.field(converter=as_array, default=3.0)
    """``alpha``: counterweight travel per unit travel of the moving pulley block [-] (Table 1: 3)."""
    brake_velocity_width_m_s: jax.Array = eqx.field(converter=as_array, default=0.05)
    """Smoothing width of the stick-slip law ``F_f tanh(w'/width)`` [m/s]."""
    brake_profile: jax.Array | None = eqx.field(converter=lambda v: None if v is None else as_array(v), default=None)
    """Factors ``phi_k`` [-] (K >= 2,) of the sliding force at K equally spaced knots of the
    counterweight rise over ``[0, brake_profile_travel_m]`` (module docstring); ``None``: constant."""
    brake_profile_travel_m: jax.Array = eqx.field(converter=as_array, default=6.0)
    """Counterweight rise [m] of the profile's last knot (default 6 m: the rise at a 10 m drop of the
    central landing is 5.8 m in the 1-DOF model and 5.7 m at the rigid level, Table 1 layout)."""

    def __check_init__(self):
        check_fields(
            self,
            {
                "counterweight_mass_kg": positive(high=1e5, unit=" kg", why="Table 1: 920 kg"),
                "brake_force_N": positive(allow_zero=True, high=1e7, unit=" N", why="Table 1: 3.13e5 N"),
                "transfer_rate": positive(high=100.0, why="Table 1: 3"),
                "brake_velocity_width_m_s": positive(high=10.0, unit=" m/s", why="default 0.05 m/s"),
                "brake_profile_travel_m": positive(high=1000.0, unit=" m", why="default 6 m"),
            },
        )
        if self.brake_profile is not None:
            check_real("brake_profile", self.brake_profile)
            if self.brake_profile.ndim < 1 or self.brake_profile.shape[-1] < 2:
                raise ValueError(
                    f"brake_profile must hold at least 2 factors (last axis), got shape {self.brake_profile.shape}"
                )
            check_finite("brake_profile", self.brake_profile)
            check_positive("brake_profile", self.brake_profile, allow_zero=True)
            check_range("brake_profile", self.brake_profile, 0.0, 100.0, inclusive=True, why="factors of F_f")

    def profile_factor(self, w):
        """The profile's factor ``phi(w)`` [-] at counterweight rise ``w`` [m] (1 without a profile)."""
        if self.brake_profile is None:
            return jnp.ones_like(jnp.asarray(w, dtype=float))
        k = self.brake_profile.shape[-1]
        knots = jnp.linspace(0.0, 1.0, k) * self.brake_profile_travel_m
        return jnp.interp(w, knots, self.brake_profile)

    def brake_force(self, w_dot, w=0.0):
        """Brake force opposing the counterweight's rise rate ``w_dot`` [m/s] at rise ``w`` [m] -> [N]
        (>0 resists rise); ``w`` matters only with a ``brake_profile``."""
        force = self.brake_force_N * jnp.tanh(w_dot / self.brake_velocity_width_m_s)
        if self.brake_profile is None:
            return force
        return force * self.profile_factor(w)

    def kinetic_energy(self, u_dot):
        """Counterweight kinetic energy [J] from the block rate ``u_dot`` [m/s]."""
        w_dot = self.transfer_rate * u_dot
        return 0.5 * self.counterweight_mass_kg * w_dot**2

    def potential_energy(self, u, g):
        """Counterweight potential energy ``m_w g w`` [J] (``g`` [m/s^2], > 0)."""
        return self.counterweight_mass_kg * g * self.transfer_rate * u

    def generalized_force(self, u_dot, u=0.0):
        """Brake force on the block coordinate ``u`` [N] (``-alpha F_brake(alpha u_dot, alpha u)``);
        ``u`` [m], the block's travel, matters only with a ``brake_profile``."""
        a = self.transfer_rate
        return -a * self.brake_force(a * u_dot, a * u)

    def brake_power(self, u_dot, u=0.0):
        """Power dissipated by the brake [W] (>= 0) at block rate ``u_dot`` [m/s] and travel ``u`` [m]."""
        a = self.transfer_rate
        w_dot = a * u_dot  # F(w') w', not F(w') a u': the round-off of the constant brake before
        # the profile existed (tests/test_design.py::test_reverse_mode_matches_forward_mode)
        return self.brake_force(w_dot, a * u) * w_dot
