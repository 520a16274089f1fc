"""Buffer device: the brake profile F_f(w) = F_f phi(w) (an extension of the paper's constant brake).

Checked against the work-energy closed form of the rigid-cable (1-DOF) limit, the energy budget of
the rigid level, the constant brake it must reduce to, and bad input."""

import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

from jaxcable.arresting.buffer import BufferDevice
from jaxcable.arresting.landing import run_landing
from jaxcable.arresting.layout import ArrestingLayout, CaptureState
from jaxcable.arresting.landing_rocket import rigid_landing_rocket


def test_profile_factor_interpolates_and_brake_only_dissipates():
    b = BufferDevice(brake_profile=[0.5, 1.5, 1.0], brake_profile_travel_m=4.0)
    w = jnp.array([-1.0, 0.0, 1.0, 2.0, 3.0, 4.0, 9.0])
    np.testing.assert_allclose(b.profile_factor(w), [0.5, 0.5, 1.0, 1.5, 1.25, 1.0, 1.0], rtol=1e-12)
    u_dot = jnp.linspace(-3.0, 3.0, 13)
    for u in (0.0, 0.4, 1.7):
        assert np.all(np.asarray(b.brake_power(u_dot, u)) >= 0.0)
    # generalized force = -alpha F(alpha u_dot, alpha u); power = -Q u_dot
    np.testing.assert_allclose(-b.generalized_force(u_dot, 0.4) * u_dot, b.brake_power(u_dot, 0.4), rtol=1e-12)
    # no profile: the paper's constant brake, whatever u
    c = BufferDevice()
    np.testing.assert_allclose(c.generalized_force(u_dot, 3.0), c.generalized_force(u_dot), rtol=0, atol=0)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(brake_profile=[1.0]), "at least 2"),
        (dict(brake_profile=[1.0, -0.1]), "brake_profile must be non-negative"),
        (dict(brake_profile=[1.0, np.nan]), "brake_profile must be finite"),
        (dict(brake_profile_travel_m=0.0), "brake_profile_travel_m must be positive"),
    ],
)
def test_bad_profile_names_the_field(kwargs, match):
    with pytest.raises(ValueError, match=match):
        BufferDevice(**kwargs)


def _stop_drop_by_work_energy(buffer, layout, capture, m_r):
    """Drop [m] at which the rocket of a vertical central capture stops with rigid cables: kinetic +
    released potential energy = 4 (m_w g w + F_f int_0^w phi) (the 1-DOF energy equation with a
    profiled brake), w = alpha (sqrt(l_0^2 + z^2) - l_0). The cable-counterweight kinetic energy is
    zero at the stop and the rocket's speed is zero there, so no dynamics is needed."""
    g, a = 9.81, float(buffer.transfer_rate)
    m_w, F_f = float(buffer.counterweight_mass_kg), float(buffer.brake_force_N)
    l0 = float(layout.half_span_m)
    v0 = float(-capture.vz_m_s)

    def phi(w):
        return float(buffer.profile_factor(w))

    def residual(z):
        w = a * (np.hypot(l0, z) - l0)
        work = 4.0 * (m_w * g * w + F_f * quad(phi, 0.0, w, limit=200)[0])
        return 0.5 * m_r * v0**2 + m_r * g * z - work

    return brentq(residual, 1.0, 30.0, xtol=1e-10)


def test_profiled_brake_stops_where_work_energy_says_in_the_rigid_cable_limit():
    """A falling profile (strong first, weak last) and a rising one move the stop by metres; the
    rigid level with 1000x stiffer, overdamped cables (the 1-DOF limit of
    test_rigid_level_converges_to_one_dof_with_stiff_damped_cables) stops where the work-energy
    balance of the profiled brake says, to 1% (the same tolerance as that limit test), and closes
    its own energy budget."""
    layout, capture = ArrestingLayout(EA_N=2.64e11), CaptureState()
    drops = {}
    for name, profile in (("falling", [1.6, 1.0, 0.6]), ("rising", [0.6, 1.0, 1.6])):
        buffer = BufferDevice(brake_profile=profile)
        run = run_landing("rigid", layout=layout, capture=capture, buffer=buffer, cable_damping_s=1e-2, t_end_s=1.5)
        o = run.outputs
        assert o["solver_status"] == "successful" and o["stopped"], name
        assert o["energy_budget_error"] < 1e-4, name
        drops[name] = (o["z_max_m"],)
    # the rocket's mass of the simulated scenes (hooks included), as the 1-DOF level takes it
    m_r = float(rigid_landing_rocket(hinged_hooks=False).total_mass_kg)
    for name, profile in (("falling", [1.6, 1.0, 0.6]), ("rising", [0.6, 1.0, 1.6])):
        z_ref = _stop_drop_by_work_energy(BufferDevice(brake_profile=profile), layout, capture, m_r)
        assert drops[name][0] == pytest.approx(z_ref, rel=0.01), (name, drops[name][0], z_ref)
    # the profile matters: the falling brake takes energy early and stops the rocket sooner
    assert drops["falling"][0] < drops["rising"][0] - 0.5


def test_all_ones_profile_is_the_constant_brake():
    base = run_landing("rigid", t_end_s=0.6).outputs
    ones = run_landing("rigid", t_end_s=0.6, buffer=BufferDevice(brake_profile=[1.0, 1.0, 1.0, 1.0])).outputs
    for key in ("z_max_m", "a_max_g", "sigma_max_mpa"):
        assert ones[key] == pytest.approx(base[key], rel=1e-9), key


def test_cli_land_with_a_brake_profile(capsys):
    """``jaxcable land --brake-profile``: a falling profile stops the design case sooner than the
    constant brake (as in the work-energy test above); bad profiles are refused naming the flag."""
    import json

    from jaxcable.cli import main

    args = ["land", "--fidelity", "rigid", "--t-end", "1.0", "--json"]
    assert main(args) == 0
    const = json.loads(capsys.readouterr().out)
    assert main(args + ["--brake-profile", "1.6,1.0,0.6"]) == 0
    falling = json.loads(capsys.readouterr().out)
    assert falling["z_max_m"] < const["z_max_m"] - 0.3
    assert main(args + ["--brake-profile", "1.0,x"]) == 2
    assert "--brake-profile must be comma-separated numbers" in capsys.readouterr().err
    assert main(["land", "--fidelity", "1dof", "--brake-profile", "1,1"]) == 2
    assert "needs --fidelity rigid" in capsys.readouterr().err
    assert main(args + ["--brake-profile", "1.0,-1.0"]) == 2
    assert "brake_profile must be non-negative" in capsys.readouterr().err
