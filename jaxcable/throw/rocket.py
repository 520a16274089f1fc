"""The line-throwing rocket as a planar point mass with a solid motor (paper section 3.3.1, 4.1).

Thrust acts along the rocket axis, which the paper takes equal to the velocity direction; the
propellant burns at a constant rate over the burn time, so the mass falls linearly and the thrust
is the constant ``total_impulse / burn_time``. Both switch off at ``burn_time`` (a jump the solver
is told about through ``jump_ts``).
"""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from jaxcable.core.math import safe_normalize
from jaxcable.core.validation import _concrete, check_positive


class PointRocket(eqx.Module):
    """Point-mass rocket.

    Attributes:
        mass_kg: launch mass including propellant [kg].
        propellant_mass_kg: propellant burnt during the boost [kg].
        total_impulse_Ns: motor total impulse [N s].
        burn_time_s: motor burn time [s].
        diameter_m: body diameter; reference area ``pi d^2 / 4`` [m].
        drag_coefficient: drag coefficient on the reference area [-].
        axis_blend_speed_mps: speed scale over which the rocket axis turns from the launcher's
            direction to its velocity (weathercocking needs airspeed) [m/s] (static).
    """

    mass_kg: Float[Array, ""]
    propellant_mass_kg: Float[Array, ""]
    total_impulse_Ns: Float[Array, ""]
    burn_time_s: Float[Array, ""]
    diameter_m: Float[Array, ""]
    drag_coefficient: Float[Array, ""]
    axis_blend_speed_mps: float = eqx.field(static=True, default=10.0)

    def __check_init__(self):
        check_positive("rocket.mass_kg", self.mass_kg)
        check_positive("rocket.propellant_mass_kg", self.propellant_mass_kg, allow_zero=True)
        check_positive("rocket.total_impulse_Ns", self.total_impulse_Ns, allow_zero=True)
        check_positive("rocket.burn_time_s", self.burn_time_s)
        check_positive("rocket.diameter_m", self.diameter_m)
        check_positive("rocket.drag_coefficient", self.drag_coefficient, allow_zero=True)
        prop, mass = _concrete(self.propellant_mass_kg), _concrete(self.mass_kg)
        if prop is not None and mass is not None and np.any(prop >= mass):
            raise ValueError(
                f"rocket.propellant_mass_kg ({prop}) must be less than rocket.mass_kg ({mass})"
            )

    @property
    def reference_area_m2(self):
        return jnp.pi * self.diameter_m**2 / 4.0

    def mass(self, t):
        """Rocket mass at time t [kg]."""
        burnt = jnp.clip(t / self.burn_time_s, 0.0, 1.0)
        return self.mass_kg - self.propellant_mass_kg * burnt

    def thrust_magnitude(self, t):
        """Thrust [N]: ``total_impulse / burn_time`` during the burn, zero after."""
        return jnp.where(t < self.burn_time_s, self.total_impulse_Ns / self.burn_time_s, 0.0)

    def axis(self, velocity, launch_direction):
        """Unit vector of the rocket axis: the launcher's direction at rest, the velocity at speed.

        The paper takes the axis along the velocity. Taken literally from rest that is ill-posed:
        with thrust along a velocity that starts at zero, gravity turns the heading by
        ``(g cos(angle) / a) ln t`` as ``t -> 0``, so the result depends on the solver's first step.
        Blending with the launch direction over ``axis_blend_speed_mps`` (the launcher sets the axis;
        weathercocking aligns it once there is airspeed) bounds the early heading change at about
        ``g cos(angle) / a`` (about 1 deg here) and makes the start well posed.
        """
        return safe_normalize(velocity + self.axis_blend_speed_mps * launch_direction, launch_direction)

    def thrust(self, t, velocity, launch_direction):
        """Thrust vector [N] along the rocket axis (see :meth:`axis`)."""
        return self.thrust_magnitude(t) * self.axis(velocity, launch_direction)


def paper_rocket(drag_coefficient=0.5) -> PointRocket:
    """The paper's rocket (section 4.1): 20 kg, 2.33 kg propellant, 4770 N s over 0.43 s, 122 mm."""
    check_positive("drag_coefficient", drag_coefficient, allow_zero=True)
    f = lambda x: jnp.asarray(x, dtype=float)
    return PointRocket(
        mass_kg=f(20.0),
        propellant_mass_kg=f(2.33),
        total_impulse_Ns=f(4770.0),
        burn_time_s=f(0.43),
        diameter_m=f(0.122),
        drag_coefficient=f(drag_coefficient),
    )
