r"""Passive-deceleration scenes at four fidelity levels that share one set of outputs.

Arresting-cable paper, sections II.B (1-DOF design model), III (flexible multibody model) and IV.C
(passive-phase robustness). The rocket's four hooks are engaged with the four cables at t = 0 (the
capture state); the counterweights and brakes stop it.

A level is a choice of components, not a flag inside the physics:

========  ===================================================  ==================================
level     rocket                                               cables
========  ===================================================  ==================================
``1dof``  point mass, vertical, central (section II.B)          rigid, massless (closed form eq 12)
``rigid`` rigid 6-DOF body, hooks fixed to it                   :class:`MasslessCables`
``ale``   rigid 6-DOF body, hooks fixed to it                   :class:`AleCables` + contact
``full``  flexible body chain + hinged, sprung hooks            :class:`AleCables` + contact
========  ===================================================  ==================================

Outputs (every level, :func:`landing_outputs`): histories of Fig 11 (drop, vertical velocity,
acceleration, max cable stress, counterweight rise), ``z_max_m`` (max drop of O, the hook-plane
centre), ``a_max_g`` (max |acceleration of the centre of mass| / 9.80, the criteria's g, after the
CFC 60 filter below), ``sigma_max_mpa`` (max cable stress, CFC 60), the unfiltered maxima
``a_max_raw_g`` and ``sigma_max_raw_mpa``, ``stop_time_s`` (first time the descent stops), the
criteria (z_max < 10 m, a_max < 5 g, sigma_max < 800 MPa), the energy budget and the solver status.

**Success** (``criteria_met``): the solve succeeded (``solve_ok``: diffrax ``successful`` or
``event_occurred``), the descent stopped within the run (``stopped``), and z_max, a_max and
sigma_max are below their limits (``z_ok``, ``a_ok``, ``sigma_ok``). A run cut short (out of solver
steps, or ``t_end`` before the stop) has not shown that the rocket is stopped within the limits, so it
does not meet the criteria whatever its maxima so far.

The acceleration is that of the rocket's centre of mass, ``g + F_cables / m``, exact for every level
(the flexible rocket's local accelerations also carry its vibration).

**The criteria's filter: SAE J211/1 (ISO 6487) CFC 60** (:data:`CRITERIA_CFC_HZ`,
:mod:`jaxcable.core.filters`). Crash and drop tests state an acceleration criterion together with a
channel frequency class; the paper gives none. a_max is the maximum of ``|filtered a|``, the three
components of the centre of mass's acceleration each filtered (J211 filters each channel, the
resultant is formed after), and sigma_max the maximum of the filtered history of the largest cable
stress (one channel: the largest of the four cables' stresses at each sample). Why CFC 60:

* J211 recommends CFC 60 for vehicle structural accelerations compared as a whole vehicle (and as
  collision-simulation input), and for barrier-force and belt load cells. a_max is the deceleration
  of the whole rocket against a whole-vehicle limit, the quantity the 1-DOF design model bounds
  (section II.B), and the cable stress is a restraint load like a belt's. J211's higher classes are
  for other uses: CFC 180 for accelerations to be integrated to velocity or displacement (nothing
  here integrates a_max), CFC 600/1000 for components and an occupant's head.
* The rocket's structural modes lie in CFC 60's pass band. The flexible rocket's linearised modes
  (free-free, hooks welded; 5 bodies, confirmed with 10) are 6.4 Hz (first bending), 17, 19, 24-25
  and 35-37 Hz; the modes above ~50 Hz differ between 5 and 10 bodies (discretisation, not
  structure). The cable-counterweight mode that sets a_max is ~5 Hz (30 rad/s). CFC 60's gain at
  1 ms spacing is 0.99997 at 10 Hz, 0.991 at 40 Hz, 0.956 at 60 Hz (:func:`.filters.cfc_gain`). It
  removes what the criteria should not see: the sub-millisecond hook-impact spikes of the ale/full
  levels, and the dependence of the maxima on where the samples fall.
* The 1 ms grid allows no higher class: J211 asks for at least ~10 samples per period of the
  class's 3 dB frequency ``F_H = 1.667 CFC`` (100 Hz for CFC 60), i.e. 1 kHz for CFC 60, exactly the
  scenes' 1 ms (:data:`SAVE_SPACING_S`; Nyquist 500 Hz). CFC 180 (``F_H`` = 300 Hz) would need
  ``save_spacing_s`` <= 0.33 ms, 3x the samples of every scene, sweep and design. A grid coarser
  than 4.01 ms (CFC 60's design frequency, 124.65 Hz, at the Nyquist frequency) is refused.

Measured on the 1 s design case (1 ms grid), filtered against raw: rigid a_max and sigma_max equal
to 1e-6 (the peaks are the 5 Hz ringing); ale a_max 7.888 / 7.882 g, sigma_max 780.6 / 805.9 MPa;
full a_max 7.586 / 7.637 g, sigma_max 778.8 / 797.6 MPa (the hook-impact stress peak, shorter
than 1 ms, is what the filter removes). Over 100 scenario I sweep cases (rigid) filtered and raw
differ by at most 1.2e-5 (a_max) and 1.1e-4 (sigma_max).

The filter, its ends (steady state at the first and last samples) and the samples after an early end
(the last finite sample held) are described in :mod:`jaxcable.core.filters`. ``smooth_landing_outputs``
takes its soft maxima over the same filtered histories, so the design's gradients are those of the
filtered criteria. The forward-backward Butterworth rings on a step: 3.8% overshoot on an ideal
step. A filtered maximum is therefore not always below the raw one: a peak that ends in a sharp
drop (the stop of a stiff cable, where the brakes stick) comes out up to a few percent higher.
"""

from __future__ import annotations

import dataclasses

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from jaxcable.core.filters import CFC_DESIGN_FACTOR, cfc_filter, cfc_max_spacing_s
from jaxcable.core.math import safe_norm
from jaxcable.core.validation import (
    check_choice,
    check_instance,
    check_int,
    check_positive,
    check_range,
    check_vector,
)
from jaxcable.core.scene import AbstractScene
from jaxcable.core.tracing import traced_once as _traced_once
from jaxcable.arresting.buffer import BufferDevice
from jaxcable.arresting.cable_sets import AleCables, HookPoints, MasslessCables, throat_weights
from jaxcable.arresting.landing_rocket import flexible_landing_rocket, rigid_landing_rocket
from jaxcable.arresting.layout import ArrestingLayout, CaptureState, check_hooks_inside_frame
from jaxcable.arresting.stiff import CableLinearisation, ExplicitLinearisation, HookCoupling, chain_plan
from jaxcable.components.contact import ContactLaw
from jaxcable.components.multibody import point_kinematics
from jaxcable.components.wind import AeroCoefficients, WindField, rocket_aero_loads

__all__ = [
    "CALIBRATED_CABLE_DAMPING_S",
    "CRITERIA_CFC_HZ",
    "DEFAULT_CABLE_DAMPING_S",
    "DEFAULT_FINE_ELEMENTS",
    "DEFAULT_HOOK_CONTACT",
    "DEFAULT_FINE_HALF_WIDTH_M",
    "DEFAULT_SPAN_ELEMENTS",
    "FIDELITY_LEVELS",
    "LEVEL_CABLE_MESH",
    "DEFAULT_ROCKET_BODIES",
    "check_rocket_bodies",
    "LIGHT_CABLE_DAMPING_S",
    "G_CRITERIA",
    "LandingCriteria",
    "PassiveLandingScene",
    "SAVE_SPACING_S",
    "SmoothingWidths",
    "criteria_met",
    "cable_mesh_at",
    "filtered_histories",
    "filtered_maxima",
    "hook_contact_at",
    "landing_outputs",
    "passive_landing_scene",
    "smooth_landing_outputs",
    "soft_max",
    "solve_succeeded",
]

G_CRITERIA = 9.80
"""The g of the paper's success criteria (section IV.A: "5 g where g = 9.80 m/s^2")."""

FIDELITY_LEVELS = ("1dof", "rigid", "ale", "full")

CRITERIA_CFC_HZ = 60.0
"""Channel frequency class [Hz] of the SAE J211/1 filter applied to the acceleration and stress
histories before a_max and sigma_max are taken (reasons in the module docstring)."""

SAVE_SPACING_S = 1e-3
"""Default spacing of the saved samples of a passive landing [s], every level: the scene saves
``round(t1 / SAVE_SPACING_S) + 1`` samples over ``[0, t1]`` (:meth:`PassiveLandingScene.default_save_ts`),
as do the sweeps (:func:`jaxcable.studies.sweep.passive_case_fn`).

The criteria a_max and sigma_max are maxima over the saved samples. The scene's old default, a
fixed *number* (401 samples: 5 ms at 2 s, 2.5 ms at 1 s), made them depend on the run's duration:
design case, 2 s against 1 s, rigid level a_max 7.0286 / 7.0359 g, sigma_max 630.91 / 631.21 MPa;
full level sigma_max 766 / 785 MPa. With a fixed *spacing* the maxima of two runs that both contain
the peaks are equal. Measured on the design case, 1 s, relative miss of (a_max, sigma_max) against
sampling at 0.05 ms (ale, full: one run, sub-grids) or 0.25 ms (rigid; ``/tmp`` scripts):

=======  ==================  ==================  ==================  ==================
level    5 ms                2.5 ms              1 ms                0.25 ms
=======  ==================  ==================  ==================  ==================
rigid    1.1e-3, 5.3e-4      2.1e-5, 4.7e-5      6.8e-6, 0           0, 0 (reference)
ale      9.0e-3, 2.5e-2      1.6e-3, 7.5e-3      0, 2.2e-3           0, 2.8e-5
full     2.6e-2, 4.2e-2      1.2e-2, 1.8e-2      2.8e-3, 2.5e-3      0, < 1e-4
=======  ==================  ==================  ==================  ==================

(z_max: < 2e-5 at 2.5 ms and finer; the interpolated stop time: < 1e-4.) Over the sweeps' 40 rigid
cases: 5 ms up to 0.13 %, 2.5 ms 0.03 %, 1 ms 4e-5. Cost of 1 ms against the old 401 samples (``run_landing``,
interleaved runs, median): rigid 1 s 0.049 -> 0.051 s, 2 s 0.092 -> 0.096 s; ale 1 s 4.18 -> 4.19 s
(the solver dominates; the probe costs ~33 us per sample); full 1 s 8.6 -> 9.0 s (single runs,
within this shared machine's ~25 % timing noise). Why 1 ms at every level: one grid for
``jaxcable land``, the sweeps and the design, cheap at the rigid level that the sweeps and the
design batch (0.25 ms costs 2.7x the solve of a 2 s rigid landing). A coarser 2 ms at ale/full was
rejected (misses sigma_max by 0.36 % / 1.9 %). At ale/full 1 ms still misses the hook-impact
stress and acceleration peaks by 0.2-0.3 % (they last less than 1 ms; small against the mesh's
4-5 %); pass ``save_spacing_s=2.5e-4`` for < 1e-4. These misses are of the unfiltered maxima
(``a_max_raw_g``, ``sigma_max_raw_mpa``). The criteria are taken after the CFC 60 filter, which
needs this 1 ms grid (J211: 10 samples per period of its 100 Hz 3 dB frequency); its maxima
converge with the spacing (``tests/arresting/test_passive.py``: a stiff-cable case, 2 / 1 / 0.5 /
0.25 ms, a_max 4.1912 / 4.1687 / 4.1660 / 4.1662 g)."""


MAX_T_END_S = 60.0
"""Longest passive landing a builder accepts [s]: the design case stops within 1 s (Fig 11) and
the runs here last 0.1-2 s; 60 s of 1 ms samples is 60,001 saved states."""

MAX_CABLE_DAMPING_S = 0.1
"""Largest stiffness-proportional cable damping beta a builder accepts [s]: the tests use up to
1e-2 s; at 0.1 s the cable-counterweight mode (~30 rad/s) is already over-damped
(``beta omega / 2 = 1.5``), and larger beta only makes the cables viscous rods."""

MAX_SPAN_ELEMENTS = 256
"""Most ALE elements per arresting span a builder accepts: 16x the default (the explicit step falls
with the shortest element, so 256 already costs hours per simulated second)."""


MAX_SAVE_SPACING_S = cfc_max_spacing_s(CRITERIA_CFC_HZ)
"""Coarsest saved grid a passive scene accepts [s], exclusive: 4.01 ms, where the design frequency
of the criteria's CFC 60 filter (124.65 Hz) reaches the Nyquist frequency. J211 asks for 1 ms
(:data:`SAVE_SPACING_S`); grids between the two run, with the filter under-sampled."""


def _check_save_grid(save_spacing_s, n_save):
    check_positive("save_spacing_s", save_spacing_s)
    check_range("save_spacing_s", save_spacing_s, 0.0, MAX_SAVE_SPACING_S, unit=" s",
                why=f"the criteria's CFC {CRITERIA_CFC_HZ:g} filter needs its design frequency below the Nyquist frequency")  # fmt: skip
    if n_save is not None and (isinstance(n_save, bool) or not isinstance(n_save, (int, np.integer)) or n_save < 2):
        raise ValueError(f"n_save must be an integer >= 2 or None, got {n_save!r}")
    if n_save is not None and n_save > 10**7:
        raise ValueError(f"n_save must be at most 1e7 (a saved state each), got {n_save!r}")


def check_t_end(name, t_end_s):
    """A passive landing's duration: in ``(0, MAX_T_END_S]`` seconds."""
    check_range(name, t_end_s, 0.0, MAX_T_END_S, high_inclusive=True, unit=" s",
                why="a landing stops within about 1 s, Fig 11")  # fmt: skip


def check_cable_damping(name, cable_damping_s):
    """The cables' stiffness-proportional damping beta: in ``[0, MAX_CABLE_DAMPING_S]`` seconds."""
    check_positive(name, cable_damping_s, allow_zero=True)
    check_range(name, cable_damping_s, 0.0, MAX_CABLE_DAMPING_S, inclusive=True, unit=" s",
                why="over-damped already at 0.1 s")  # fmt: skip


class LandingCriteria(eqx.Module):
    """Success criteria of the passive phase (section IV.A): positive and finite. A landing meets
    them when its solve succeeded, the rocket stopped, and z_max [m], a_max [g of 9.80 m/s^2] and
    sigma_max [MPa], the latter two after the SAE J211 filter of class ``filter_cfc_hz`` [Hz], are
    below the limits (:func:`landing_outputs`)."""

    z_max_m: float = 10.0
    a_max_g: float = 5.0
    sigma_max_mpa: float = 800.0
    filter_cfc_hz: float = CRITERIA_CFC_HZ
    """Channel frequency class of the filter of the acceleration and stress histories [Hz]
    (:data:`CRITERIA_CFC_HZ`, 60)."""

    def __check_init__(self):
        for name in ("z_max_m", "a_max_g", "sigma_max_mpa", "filter_cfc_hz"):
            check_positive(name, getattr(self, name))


def _check_spacing_of(name, value, n, t1=None):
    """The saved grid of ``n`` samples over ``[0, t1]`` is fine enough for the criteria's filter
    (:data:`MAX_SAVE_SPACING_S`); ``name``/``value`` name the field that set it."""
    t1 = float(value if t1 is None else t1)
    spacing = t1 / (n - 1)
    if not spacing < MAX_SAVE_SPACING_S:
        raise ValueError(
            f"{name} = {value!r} gives saved samples {spacing:g} s apart over [0, {t1:g}] s; the criteria's "
            f"CFC {CRITERIA_CFC_HZ:g} filter needs a spacing below {MAX_SAVE_SPACING_S:.6g} s (1 ms recommended)"
        )


class PassiveState(eqx.Module):
    rocket: eqx.Module
    cables: eqx.Module
    contact_work: jax.Array
    """Work done so far by all contact forces on both bodies [J] (minus the contact energy
    stored and dissipated); zero for the massless level."""
    hook_damping_work: jax.Array
    """Energy dissipated so far by the hook dampers [J] (zero when the hooks are welded)."""
    aero_work: jax.Array
    """Work done so far by the air on the rocket and the cables [J] (zero in still air)."""


def _hinge_rows(state):
    return state.rocket.hinge_angle, state.rocket.hinge_rate


def _rocket_rows(state):
    return state.rocket


def _speed_rows(state):
    return state.rocket.v, state.rocket.omega_body


def _cable_rows(state):
    q, qdot = state.cables.q, state.cables.qdot
    return q.r, q.s, q.h, q.u, qdot.r, qdot.s, qdot.h, qdot.u


class PassiveLandingScene(AbstractScene):
    """Rocket + cable set after capture. ``rocket`` is a landing rocket (rigid or flexible, see
    :mod:`jaxcable.arresting.landing_rocket`); ``cables`` is :class:`MasslessCables` or :class:`AleCables`."""

    rocket: eqx.Module
    cables: eqx.Module
    capture: CaptureState
    gravity: jax.Array
    t_end_s: float = eqx.field(static=True, default=2.0)
    save_spacing_s: float = eqx.field(static=True, default=SAVE_SPACING_S)
    """Spacing of the default saved samples [s] (:data:`SAVE_SPACING_S`; see :meth:`default_save_ts`)."""
    n_save: int | None = eqx.field(static=True, default=None)
    """Number of default saved samples over ``[0, t1]``; ``None`` (default): one per ``save_spacing_s``."""
    wind: eqx.Module | None = None
    """:class:`.wind.WindField` or None (still air): aerodynamic loads on the rocket (eqs 43-44, the
    free rocket: the engine and its guidance are off after capture) and, at the ale/full levels, on
    the arresting spans (eq 45, :class:`AleCables`). The rigid level's massless cables carry none."""
    aero: eqx.Module | None = None
    """:class:`.wind.AeroCoefficients` (required with ``wind``)."""
    wind_time_offset_s: jax.Array = eqx.field(converter=jnp.asarray, default=0.0)
    """Scene time 0 is wind time ``wind_time_offset_s`` [s] (the capture instant of a two-phase run)."""

    def __check_init__(self):
        _check_save_grid(self.save_spacing_s, self.n_save)
        if self.wind is not None and self.aero is None:
            raise ValueError("PassiveLandingScene: wind given without aero coefficients (aero=None)")

    def initial_state(self):
        c = self.capture
        return PassiveState(
            rocket=self.rocket.initial_state(c.position, c.velocity, c.rotation_vector, c.omega),
            cables=self.cables.initial_state(),
            contact_work=jnp.zeros(()),
            hook_damping_work=jnp.zeros(()),
            aero_work=jnp.zeros(()),
        )

    def hooks(self, rocket_state) -> HookPoints:
        pos, vel = self.rocket.hook_points_world(rocket_state)
        return HookPoints(positions=pos, velocities=vel)

    def _rocket_aero(self, t, rocket_state):
        """Aerodynamic point loads on the rocket, their resultant [N] and power [W]."""
        if self.wind is None:
            return (), jnp.zeros(3), jnp.zeros(())
        loads = rocket_aero_loads(self.rocket, rocket_state, self.wind, t + self.wind_time_offset_s, self.aero)
        power, total = jnp.zeros(()), jnp.zeros(3)
        for bodies, local, f in loads:
            _, v = point_kinematics(self.rocket.system, rocket_state, bodies, local)
            power = power + jnp.sum(f * v)
            total = total + jnp.sum(f.reshape(-1, 3), axis=0)
        return loads, total, power

    def _step(self, t, state):
        hooks = self.hooks(state.rocket)
        forces, dcables, aux = self.cables.respond(state.cables, hooks, t)
        loads, aero_total, aero_power = self._rocket_aero(t, state.rocket)
        drocket = self.rocket.derivative(state.rocket, self.gravity, hook_forces_N=forces, point_forces=loads)
        aux = dict(aux, aero_force_N=aero_total, aero_power_W=aero_power + aux.get("aero_power_W", 0.0))
        return drocket, dcables, forces, aux

    def vector_field(self, t, state):
        return _traced_once(type(self)._vector_field, self, t, state)

    def _vector_field(self, t, state):
        drocket, dcables, _, aux = self._step(t, state)
        rate = state.rocket.hinge_rate
        hook_power = self.rocket.params.hook_rotational_damping_N_m_s_per_rad * jnp.sum(rate**2)
        return PassiveState(
            rocket=drocket,
            cables=dcables,
            contact_work=aux.get("contact_power_W", jnp.zeros(())),
            hook_damping_work=hook_power,
            aero_work=aux["aero_power_W"],
        )

    def stiff_linearisation(self, t, state, hook_coupling: bool = True):
        return _traced_once(type(self)._stiff_linearisation, self, t, state, hook_coupling)

    def _stiff_linearisation(self, t, state, hook_coupling: bool = True):
        """The stiff part of the Jacobian for ``simulate(solver="rosw")``
        (:mod:`jaxcable.arresting.stiff`): the ALE cables' internal nodes and border, the hooks'
        hinges, and (``hook_coupling``) the cable rows' columns on the rocket's coordinates through
        the hook-cable contact; none for massless cables."""
        if not isinstance(self.cables, AleCables):
            return ExplicitLinearisation()
        hooks = self.hooks(state.rocket)
        # the cables' kinematics and the contact pick, shared by the blocks, the hinge rows and the coupling
        kin = self.cables.kinematics(state.cables)
        picked = self.cables.contact_pairs_picked(kin, hooks, stiff=True)
        blocks = self.cables.stiff_blocks(state.cables, hooks, t, kin=kin, picked=picked)
        hinge, reaction = None, None
        if state.rocket.hinge_rate.shape[0]:
            K_h, C_h, reaction = self._hinge_jacobian(t, state, kin, picked)
            hinge = (K_h, C_h)
        coupling = HookCoupling.at(self.cables, self.rocket, state.cables, state.rocket, rows=_rocket_rows, kin=kin, picked=picked) if hook_coupling else None  # fmt: skip
        return CableLinearisation(
            blocks, rows=_cable_rows, active=self.cables.subsystems.route.active_slots, hinge=hinge,
            hinge_rows=_hinge_rows if hinge is not None else None, coupling=coupling,
            hinge_reaction=reaction, speed_rows=_speed_rows if reaction is not None else None,
            plan=chain_plan([np.shape(f)[-1] for f in self.cables.subsystems.route.fractions]),
        )  # fmt: skip

    def _hinge_jacobian(self, t, state, kin=None, picked=None):
        """``(d phi_dd / d phi, d phi_dd / d phi_dot, reaction)``: the first two (nh, nh) the hooks'
        hinge rows, diagonal: the hook dampers (c_h l_h^2 / I ~ 2e4 1/s) and the contact on the
        hooks' small inertia (~5e6 1/s^2) are the stiff part of the rocket.

        ``phi_dd = G tau + ...`` with ``tau`` the hinge torques (spring-damper ``-k_h l_h^2 phi -
        c_h l_h^2 phi_dot``, and the contact's, ``sum_p F_p . dP_p/dphi`` over the hook's points)
        and ``G`` the hinges' rows of the inverse mass matrix. Each hook's contact sees only its own
        points, so one tangent on every hinge at once gives each hook's own torque derivative (one
        JVP of the contact for the angles, one for the rates), and one JVP of the rocket's
        equations per unit hinge torque gives ``G``'s columns (its diagonal here). Left out: the hooks' coupling through the rocket's
        inertia (the off-diagonal entries: 0.3% of the diagonal in angle, 1-3% in rate on the
        design case), the change of the mass matrix and of the lever with the angle, and the
        contact's push on the rocket's bodies (their mass is 10^2-10^3 times the hook's); a
        W-method keeps its order with any ``J`` (``tests/arresting/test_stiff.py`` checks the
        diagonal against ``jax.jacfwd`` of the vector field). Why not the exact 2 nh JVPs of the
        vector field: their derivative of the flexible rocket's mass matrix and Cholesky solve
        cost 1 ms of the 2.3 ms per step in the W-method's loop (full level, design case, beta =
        1e-2 s, 0.1 s, rtol 1e-4; 2-core CPU, float64), for the same steps
        (``docs/stiff_integrator.md``). ``kin``, ``picked``: the cables' kinematics and the
        contact pick at ``state`` if computed (the contact's derivative then runs on those pairs
        only, as the vector field's JVP does).

        ``reaction`` is the rocket bodies' rows through the spring-dampers, ``(G_v, G_w, -k_h
        l_h^2, -c_h l_h^2)`` (:attr:`.stiff.CableLinearisation.hinge_reaction`), from the same
        columns of ``G`` (``nh`` Cholesky solves, no derivative of the mass matrix). The spring-damper is a force pair
        between the hook and its body; with only the hook's side implicit, the W-method integrates
        the two sides differently and the pair does work: the full level's energy budget drifted
        to 7.9e-5 of the initial energy on the design case at rtol 1e-5 (14,432 steps), and closes
        to 2.1e-6 with both sides (14,393 steps; ``docs/stiff_integrator.md``). The contact's
        torque stays out of these rows: on a light hook the contact's direct push on the body and
        its torque through the hinge cancel."""
        rocket = state.rocket
        phi, rate = _hinge_rows(state)
        one, zero = jnp.ones_like(phi), jnp.zeros_like(phi)
        kin = self.cables.kinematics(state.cables) if kin is None else kin

        def hooks_at(phi_, rate_):
            return self.hooks(eqx.tree_at(lambda s: (s.hinge_angle, s.hinge_rate), rocket, (phi_, rate_)))

        lever = jax.jvp(lambda p: hooks_at(p, rate).positions, (phi,), (one,))[1]  # dP/dphi (4, 3, 3)

        def contact_torques(phi_, rate_):
            return jnp.sum(self.cables.contact_on_hooks(kin, hooks_at(phi_, rate_), picked) * lever, axis=(-2, -1))

        _, dtau = jax.vmap(lambda a, b: jax.jvp(contact_torques, (phi, rate), (a, b)))(
            jnp.stack([one, zero]), jnp.stack([zero, one])
        )

        def accel(tau):  # linear in the torques: its derivative needs no loads
            return self.rocket.derivative(rocket, self.gravity, hinge_torques_N_m=tau)

        p = self.rocket.params
        k, c = p.hook_rotational_stiffness_N_m_per_rad, p.hook_rotational_damping_N_m_s_per_rad
        # a unit torque on each hinge in turn: the inverse mass matrix's hinge columns
        cols = jax.vmap(lambda e: jax.jvp(accel, (zero,), (e,))[1])(jnp.eye(phi.shape[0], dtype=phi.dtype))
        g = jnp.diagonal(cols.hinge_rate)
        K, C = jnp.diag(g * (dtau[0] - k)), jnp.diag(g * (dtau[1] - c))
        return K, C, (cols.v, cols.omega_body, -k * one, -c * one)

    def num_saved(self, t1) -> int:
        """Number of default saved samples over ``[0, t1]``: ``n_save`` if given, else
        ``round(t1 / save_spacing_s) + 1`` (at least 2). ``t1`` must be concrete (not traced)."""
        if self.n_save is not None:
            if not isinstance(t1, jax.core.Tracer):
                _check_spacing_of("n_save", self.n_save, self.n_save, t1)
            return int(self.n_save)
        if isinstance(t1, jax.core.Tracer):
            raise ValueError(
                "PassiveLandingScene.default_save_ts: t1 is traced (under jit/vmap/grad), so the number of "
                f"samples at one per save_spacing_s = {self.save_spacing_s} s is unknown; pass t1 as a Python "
                "float, give the scene a fixed n_save, or pass save_ts to simulate"
            )
        check_positive("t1", t1)
        t1 = float(t1)
        n = max(2, round(t1 / self.save_spacing_s) + 1)
        if n > 10**7:
            raise ValueError(
                f"t1 must give at most 1e7 saved samples at save_spacing_s = {self.save_spacing_s:g} s "
                f"(t1 <= {1e7 * self.save_spacing_s:g} s), got t1 = {t1:g}"
            )
        _check_spacing_of("t1", t1, n)
        return n

    def default_save_ts(self, t1):
        """``num_saved(t1)`` equally spaced times over ``[0, t1]`` [s]: one per ``save_spacing_s``
        (1 ms, :data:`SAVE_SPACING_S`) unless ``n_save`` is given, so that the maxima a_max and
        sigma_max do not depend on the run's duration."""
        return jnp.linspace(0.0, t1, self.num_saved(t1))

    def default_snapshot_ts(self, t1):
        return jnp.linspace(0.0, t1, 5)

    def probe(self, t, state):
        return _traced_once(type(self)._probe, self, t, state)

    def _probe(self, t, state):
        drocket, dcables, forces, aux = self._step(t, state)
        hooks = self.hooks(state.rocket)
        o_pos, o_vel = self.rocket.reference_point(state.rocket)
        o0 = self.capture.position
        mass = self.rocket.total_mass_kg
        acc = self.gravity + (jnp.sum(forces, axis=(0, 1)) + aux["aero_force_N"]) / mass
        e_r = self.rocket.energies(state.rocket, self.gravity)
        e_c = self.cables.energies(state.cables, hooks)
        energy = {**{f"rocket_{k}": v for k, v in e_r.items() if k != "total"}, **e_c}
        energy["contact_work"] = state.contact_work
        energy["dissipated_hook_dampers"] = state.hook_damping_work
        energy["aero_work"] = state.aero_work
        return dict(
            drop_m=o0[2] - o_pos[2],
            velocity_m_s=o_vel,
            acceleration_m_s2=acc,
            stress_max_pa=aux["tension_max_N"] / self.cables_area(),
            counterweight_rise_m=aux["counterweight_rise_m"],
            hook_normal_force_N=aux["hook_normal_force_N"],
            **({"contact_pairs_touching": aux["contact_pairs_touching"]} if "contact_pairs_touching" in aux else {}),
            centre_xy_m=o_pos[:2],
            energy=energy,
        )

    def cables_area(self):
        return self.cables.layout.cable_area_m2 if isinstance(self.cables, MasslessCables) else (
            jnp.pi * self.cables.cable_radius_m**2
        )

    def snapshot(self, t, state):
        hooks = self.hooks(state.rocket)
        out = dict(hooks=hooks.positions)
        if isinstance(self.cables, AleCables):
            r = jax.vmap(lambda sub, q: sub.route.nodes(q)[0])(self.cables.subsystems, state.cables.q)
            out["cable_nodes"] = r
        return out

    def summarize(self, result):
        return landing_outputs(result.ts, result.probes, result.status)


def _energy_total(energy):
    # stored + dissipated - work done on the system (contact work is internal: the contact energy
    # stored and dissipated, counted on both bodies; the air's work is external)
    stored = sum(v for k, v in energy.items() if k not in ("contact_work", "aero_work"))
    return stored - energy["contact_work"] - energy.get("aero_work", 0.0)


_SUCCESSFUL = int(diffrax.RESULTS.successful._value)
_EVENT_OCCURRED = int(diffrax.RESULTS.event_occurred._value)


def solve_succeeded(status):
    """Whether a diffrax result code (an integer array under jit/vmap) is ``successful`` or
    ``event_occurred``: the solve reached ``t1`` or its terminal event (as
    :attr:`jaxcable.core.simulate.Result.ok`)."""
    return (status == _SUCCESSFUL) | (status == _EVENT_OCCURRED)


def _grid_spacing(ts, cfc_hz):
    """Spacing [s] of the uniformly spaced saved times ``ts`` (``ts[1] - ts[0]``), and whether it is
    fine enough for the CFC ``cfc_hz`` filter. When the run saved only its first sample the record
    is constant after :func:`.filters.hold_last_finite`, which every spacing filters to itself: half
    the limit is used."""
    limit = 1.0 / (2.0 * CFC_DESIGN_FACTOR * cfc_hz)  # cfc_max_spacing_s, traceable in cfc_hz
    if ts.shape[0] < 2:
        return jnp.asarray(0.5 * limit), jnp.asarray(True)
    dt = jnp.where(jnp.isfinite(ts[1]), ts[1] - ts[0], 0.5 * limit)
    ok = (dt > 0.0) & (dt < limit)
    return jnp.where(ok, dt, 0.5 * limit), ok


def filtered_histories(ts, probes, cfc_hz=CRITERIA_CFC_HZ, before=None):
    """The criteria's histories after the SAE J211 CFC ``cfc_hz`` filter (module docstring):
    ``acceleration_g`` (n,), the magnitude of the filtered components of the centre of mass's
    acceleration [g of 9.80 m/s^2], and ``stress_max_mpa`` (n,), the filtered largest cable stress
    [MPa]; samples after an early end (``ts`` not finite) hold the last finite ones. ``ts`` (n,) must
    be uniformly spaced (the scenes' saved grids are); also returns ``grid_ok``, False when the
    spacing is too coarse for the filter (the criteria are then NaN).

    ``before`` (default None: the scenes, whose histories are continuous at capture): the values of
    ``acceleration_m_s2`` (3,) and ``stress_max_pa`` before t = 0, for a record that jumps at t = 0
    (the 1-DOF model's rigid cables load at once; :func:`.filters.cfc_filter`'s ``initial``)."""
    finite = jnp.isfinite(ts)
    dt, grid_ok = _grid_spacing(ts, cfc_hz)
    before = {} if before is None else before
    acc = cfc_filter(probes["acceleration_m_s2"], dt, cfc_hz, valid=finite, initial=before.get("acceleration_m_s2"))
    stress = cfc_filter(probes["stress_max_pa"], dt, cfc_hz, valid=finite, initial=before.get("stress_max_pa"))
    return dict(acceleration_g=safe_norm(acc, axis=1) / G_CRITERIA, stress_max_mpa=stress / 1e6), grid_ok


def filtered_maxima(ts, probes, cfc_hz=CRITERIA_CFC_HZ, before=None):
    """``a_max_g``, ``sigma_max_mpa`` (filtered, :func:`filtered_histories`, ``before`` there) and
    ``a_max_raw_g``, ``sigma_max_raw_mpa`` (unfiltered): maxima over the saved samples with finite
    times."""
    finite = jnp.isfinite(ts)
    hist, grid_ok = filtered_histories(ts, probes, cfc_hz, before)

    def peak(v):
        return jnp.max(jnp.where(finite, v, -jnp.inf))

    raw_acc = jnp.linalg.norm(jnp.where(finite[:, None], probes["acceleration_m_s2"], 0.0), axis=1)
    return dict(
        a_max_g=jnp.where(grid_ok, peak(hist["acceleration_g"]), jnp.nan),
        sigma_max_mpa=jnp.where(grid_ok, peak(hist["stress_max_mpa"]), jnp.nan),
        a_max_raw_g=peak(raw_acc) / G_CRITERIA,
        sigma_max_raw_mpa=peak(probes["stress_max_pa"]) / 1e6,
    )


def landing_outputs(ts, probes, status, criteria: LandingCriteria = LandingCriteria()):
    """Scalar outputs shared by every level (dict of arrays; traceable under jit/vmap).

    ``z_max_m`` [m]; ``a_max_g`` [g] and ``sigma_max_mpa`` [MPa] after the criteria's CFC filter,
    ``a_max_raw_g`` and ``sigma_max_raw_mpa`` without it (:func:`filtered_maxima`); ``stop_time_s``
    [s] (NaN when not stopped); the flags ``solve_ok`` (diffrax ``successful`` or
    ``event_occurred``), ``stopped``, ``z_ok``, ``a_ok``, ``sigma_ok`` and ``criteria_met``, their
    conjunction; ``energy_budget_error`` [-] and the diffrax ``status``."""
    finite = jnp.isfinite(ts)
    drop = jnp.where(finite, probes["drop_m"], -jnp.inf)
    vz = probes["velocity_m_s"][:, 2]
    z_max = jnp.max(drop)
    maxima = filtered_maxima(ts, probes, criteria.filter_cfc_hz)
    # stop: first sample where the descent has stopped (vz >= 0), linearly interpolated
    stopped = (vz >= 0.0) & finite
    idx = jnp.argmax(stopped)
    i0 = jnp.maximum(idx - 1, 0)
    frac = jnp.clip(-vz[i0] / jnp.where(vz[idx] - vz[i0] == 0, 1.0, vz[idx] - vz[i0]), 0.0, 1.0)
    stop_time = jnp.where(jnp.any(stopped), ts[i0] + frac * (ts[idx] - ts[i0]), jnp.nan)
    totals = jax.vmap(lambda i: _energy_total(jax.tree_util.tree_map(lambda x: x[i], probes["energy"])))(
        jnp.arange(ts.shape[0])
    )
    e0 = totals[0]
    scale = jnp.abs(totals[0] - probes["energy"]["rocket_gravitational"][0] + 1.0)
    budget_err = jnp.max(jnp.where(finite, jnp.abs(totals - e0), 0.0)) / scale
    flags = dict(
        solve_ok=solve_succeeded(status),
        stopped=jnp.any(stopped),
        z_ok=z_max < criteria.z_max_m,
        a_ok=maxima["a_max_g"] < criteria.a_max_g,
        sigma_ok=maxima["sigma_max_mpa"] < criteria.sigma_max_mpa,
    )
    return dict(
        z_max_m=z_max,
        **maxima,
        stop_time_s=stop_time,
        **flags,
        criteria_met=criteria_met(flags),
        energy_budget_error=budget_err,
        status=status,
    )


def criteria_met(flags):
    """A landing's success from its flags (dict of bools or bool arrays): the solve succeeded, the
    rocket stopped, and every criterion is within its limit."""
    return flags["solve_ok"] & flags["stopped"] & flags["z_ok"] & flags["a_ok"] & flags["sigma_ok"]


class SmoothingWidths(eqx.Module):
    """Widths of the soft maxima in :func:`smooth_landing_outputs` (units of each output)."""

    z_m: float = 0.05
    a_g: float = 0.05
    sigma_mpa: float = 5.0


def soft_max(values, width, valid=None):
    """``width * logsumexp(values / width)`` over valid samples: a smooth upper bound of the max,
    above it by at most ``width * log(n)`` (the bias is measured in the tests)."""
    values = jnp.where(valid, values, -jnp.inf) if valid is not None else values
    return width * jax.scipy.special.logsumexp(values / width)


def smooth_landing_outputs(ts, probes, widths: SmoothingWidths = SmoothingWidths(), cfc_hz=CRITERIA_CFC_HZ):
    """Differentiable versions of z_max [m], a_max [g], sigma_max [MPa] (soft maxima over the saved
    history) for gradients and design; a_max and sigma_max over the histories filtered like the hard
    criteria (CFC ``cfc_hz`` [Hz], :func:`filtered_histories`); see :func:`landing_outputs` for the
    hard ones."""
    finite = jnp.isfinite(ts)
    hist, _ = filtered_histories(ts, probes, cfc_hz)
    return dict(
        z_max_m=soft_max(probes["drop_m"], widths.z_m, finite),
        a_max_g=soft_max(hist["acceleration_g"], widths.a_g, finite),
        sigma_max_mpa=soft_max(hist["stress_max_mpa"], widths.sigma_mpa, finite),
    )


CALIBRATED_CABLE_DAMPING_S = 6.3e-3
"""The cables' Rayleigh beta [s] fitted to the paper's section III.F (:mod:`.calibration`, which
exports it too): the fit of ``experiments/calibrate_damping.py`` (rigid level, 20 Adam iterations
from 1e-3 s) ends at the upper bound ``2 ZETA_MAX / OMEGA_1_RAD_S`` = 6.33e-3 s, because the
objective falls monotonically with beta over the whole plausible range (the section III.F
histories ask for more damping than a steel rope plausibly has; results and sensitivities in
``experiments/results/calibrate_damping.md`` and ``docs/arresting_validation.md``). Rounded.
Defined here, beside the defaults that use it, so that the scenes need not import the calibration."""

DEFAULT_CABLE_DAMPING_S = CALIBRATED_CABLE_DAMPING_S
"""The cables' stiffness-proportional damping beta [s] of every scene, sweep and design unless
given: the value fitted to the paper's section III.F (6.3e-3 s, the upper bound of a steel rope's
damping; :data:`jaxcable.arresting.calibration.CALIBRATED_CABLE_DAMPING_S`). The paper prints none;
with a lightly damped cable (1e-5 s) the rocket-cable-counterweight mode rings around the 1-DOF
solution (the design case's a_max 7.6 g at the full level against 4.1 g), which the paper's model
does not show. The ale and full levels run it on the W-method (:func:`.landing.level_solver_settings`)."""

LIGHT_CABLE_DAMPING_S = 1e-5
"""A lightly damped cable, beta [s] (the scenes' default before the calibration): the damping at which
explicit solvers run the ale and full levels at their cheapest (Bosh3, ``LEVEL_DEFAULTS``), the
level's default there with the capsule contact; with the hook as a sliding node the W-method is the
faster there too (:data:`.landing.STIFF_DAMPING_S`). The cables' mode rings (a_max 7.6 g on the full
level's design case), so it suits solver benchmarks and tests of the numerics, not criteria."""

LEVEL_CABLE_MESH = {"ale": (80, 16), "full": (80, 16)}
"""Each level's ALE cable mesh unless given: (elements per arresting span, of them fine elements over
+-3 m next to each hook). Chosen by measurement with the hook as a sliding node
(:data:`DEFAULT_HOOK_CONTACT`; ``experiments/convergence_landing.py``, ``docs/arresting_validation.md``):

* ``ale``: 80 (16 fine, 0.375 m): a_max within 0.3-1.2% of 128-256 elements on both cases, the
  energy budget closed to 3e-6, in 0.6x the steps of 64 (32 fine), which reads the design case's
  a_max 3.6-4.1% high at this level.
* ``full``: 80 (16 fine): a_max within 0.1% of 128 elements (64 fine) on the design case (5.13 g)
  and on section IV.A's deviated case (6.09 g), where 64 (32 fine), the default before, reads them
  within 0.9%, in 0.64x its steps, the energy budget closed to 6e-6 with the hooks' spring-dampers
  on both sides in the W-method's ``J`` (``docs/stiff_integrator.md``); at 32 (16 fine) the design
  case's a_max reads 11% high."""

DEFAULT_ROCKET_BODIES = 5
"""Rigid bodies of the full level's flexible rocket (joined by beams); 1 is a rigid rocket with the
sprung hinged hooks, within 0.6% of 5 bodies in every criterion on the design case, section IV.A's
and 4 cases of section IV's scenario I (``experiments/results/fidelity_ladder_rocket.md``,
``sweep_two_phase_full_1body_I_n4_screen.csv``)."""

DEFAULT_SPAN_ELEMENTS, DEFAULT_FINE_ELEMENTS = LEVEL_CABLE_MESH["full"]
"""The full level's mesh (:data:`LEVEL_CABLE_MESH`): ALE elements per arresting span, and of them
equal fine elements next to each hook (0.375 m over +-3 m)."""


def cable_mesh_at(fidelity: str, n_span_elements: int | None = None, n_fine: int | None = None) -> tuple[int, int]:
    """``(n_span_elements, n_fine)`` as given, each None replaced by the level's default
    (:data:`LEVEL_CABLE_MESH`; the ``full`` level's, else the ``ale`` level's: a scene with ALE
    cables on the rigid rocket is the ale level's rocket)."""
    span, fine = LEVEL_CABLE_MESH["full" if fidelity == "full" else "ale"]
    return (span if n_span_elements is None else n_span_elements, fine if n_fine is None else n_fine)


DEFAULT_HOOK_CONTACT = "node"
"""How a hook holds an ALE cable unless given: ``"node"``, the hook as a sliding node of its cable
(:class:`~jaxcable.arresting.cable_sets.AleCables`). The capsule contact (``"capsule"``) pushes the
cable along itself where it kinks over the hook, and the deviated case's sigma_max then scatters
over 765-846 MPa with the mesh instead of converging; the node's converges within 0.3%. The rigid
level's massless cables have no nodes: there it means the capsule contact."""

DEFAULT_FINE_HALF_WIDTH_M = 3.0
"""Half-width of the fine region around each hook's throat at capture [m] unless given."""

DEFAULT_CONTACT_SLIP_M_S = 0.5
"""Hook-cable friction: slip speed ``v_s`` [m/s] at which ``mu`` reaches ``mu_s`` in the ale/full
scenes unless a ``contact`` law is given (``v_d = 2.5 v_s``; reasons in :func:`passive_landing_scene`)."""


def scene_contact_law(v_s_m_s: float = DEFAULT_CONTACT_SLIP_M_S):
    """The scenes' hook-cable contact law (:class:`.contact.ContactLaw` defaults) with static slip
    speed ``v_s`` [m/s] and dynamic slip speed ``v_d = 2.5 v_s``."""
    return ContactLaw(v_s=v_s_m_s, v_d=2.5 * v_s_m_s)


def hook_contact_at(hook_contact: str | None, cable_model: str) -> str:
    """``hook_contact`` as given, or where it is None the default for the ``cable_model``:
    :data:`DEFAULT_HOOK_CONTACT` with the ALE cables (``"ale"``, the ``ale`` and ``full`` levels'),
    ``"capsule"`` with the massless ones (the ``rigid`` level's, which have no nodes)."""
    if hook_contact is not None:
        return hook_contact
    return DEFAULT_HOOK_CONTACT if cable_model == "ale" else "capsule"


LEGACY_ALE_MODEL = ("capsule", 32, 16)
"""The ALE cables' hook model and mesh (hook contact, span elements, fine ones) of the scenes before
:data:`DEFAULT_HOOK_CONTACT` and 64 span elements: sweeps written with them name none in their
identity (:func:`ale_model_identity`), so that they still resume with these settings given."""


def ale_model_identity(
    fidelity: str, hook_contact: str | None, n_span_elements: int | None, n_fine: int | None, n_rocket_bodies: int | None = None
) -> dict:
    """The part of a sweep's identity (``describe()``) that names the ALE cables' hook model and mesh
    (a None: the level's default, :func:`cable_mesh_at`): ``{}`` at the rigid level and for
    :data:`LEGACY_ALE_MODEL`, else ``hook_contact``, ``n_span_elements`` and ``n_fine``; and
    ``n_rocket_bodies`` at the full level where it is not the default 5. A CSV resumes only rows
    computed with the same model."""
    if fidelity == "rigid":
        return {}
    span, fine = cable_mesh_at(fidelity, n_span_elements, n_fine)
    model = (hook_contact_at(hook_contact, "ale"), int(span), int(fine))  # the sweeps' ale/full scenes: ALE cables
    bodies = {} if fidelity != "full" or n_rocket_bodies in (None, DEFAULT_ROCKET_BODIES) else {"n_rocket_bodies": int(n_rocket_bodies)}
    if model == LEGACY_ALE_MODEL:
        return bodies
    return {**dict(zip(("hook_contact", "n_span_elements", "n_fine"), model)), **bodies}


def check_cable_mesh(n_span_elements: int, n_fine: int):
    """ValueError unless ``n_span_elements`` (ALE elements per arresting span) and ``n_fine`` (of
    them, fine ones next to the hook) are integers in range with a coarse element on each side."""
    check_int("n_span_elements", n_span_elements, 3, MAX_SPAN_ELEMENTS)
    check_int("n_fine", n_fine, 1, MAX_SPAN_ELEMENTS)
    if n_span_elements < n_fine + 2:
        raise ValueError(
            f"n_span_elements must be >= n_fine + 2 (a coarse element on each side), got "
            f"n_span_elements={n_span_elements}, n_fine={n_fine}"
        )


def ale_model_kwargs(
    fidelity: str, hook_contact: str | None, n_span_elements: int | None, n_fine: int | None, n_rocket_bodies: int | None = None
) -> dict:
    """The keyword arguments of :func:`passive_landing_scene` that set the ALE cables' hook model and
    mesh (none at the rigid level, whose massless cables have neither; a None: the level's default),
    and at the full level the flexible rocket's bodies (``n_rocket_bodies``, None: 5)."""
    if fidelity == "rigid":
        return {}
    span, fine = cable_mesh_at(fidelity, n_span_elements, n_fine)
    bodies = {} if fidelity != "full" or n_rocket_bodies is None else {"n_rocket_bodies": int(n_rocket_bodies)}
    return {"hook_contact": hook_contact, "n_span_elements": int(span), "n_fine": int(fine), **bodies}


def check_rocket_bodies(n_rocket_bodies: int | None, fidelity: str):
    """ValueError unless ``n_rocket_bodies`` is None (5 at the full level) or an integer in [1, 100]
    at the full level (the other levels' rocket is one rigid body): the case functions check this."""
    if n_rocket_bodies is None:
        return
    check_int("n_rocket_bodies", n_rocket_bodies, 1, 100)
    if fidelity != "full":
        raise ValueError(f"n_rocket_bodies={n_rocket_bodies} needs fidelity 'full' (the {fidelity} level's rocket is one rigid body)")


def check_hook_contact(hook_contact: str | None, fidelity: str):
    """ValueError unless ``hook_contact`` is None (the level's default, :func:`hook_contact_at`),
    ``"capsule"`` or ``"node"``, and ``"node"`` only at a level with ALE cables (``ale``, ``full``):
    the case functions of the sweeps check this."""
    if hook_contact is None:
        return
    if hook_contact not in ("capsule", "node"):
        raise ValueError(f"hook_contact must be 'capsule' or 'node', got {hook_contact!r}")
    if hook_contact == "node" and fidelity == "rigid":
        raise ValueError("hook_contact='node' needs fidelity 'ale' or 'full' (the rigid level's cables have no nodes)")


def passive_landing_scene(
    fidelity: str = "full",
    capture: CaptureState | None = None,
    layout: ArrestingLayout | None = None,
    buffer: BufferDevice | None = None,
    *,
    contact=None,
    n_span_elements: int | None = None,
    n_fine: int | None = None,
    fine_half_width_m: float = DEFAULT_FINE_HALF_WIDTH_M,
    n_rocket_bodies: int = DEFAULT_ROCKET_BODIES,
    t_end_s: float = 2.0,
    cable_damping_s: float = DEFAULT_CABLE_DAMPING_S,
    frame_centre_xy=None,
    wind=None,
    aero=None,
    wind_time_offset_s=0.0,
    cable_model: str | None = None,
    rocket_params=None,
    save_spacing_s: float = SAVE_SPACING_S,
    n_save: int | None = None,
    hook_contact: str | None = None,
):
    """The passive-deceleration scene with the paper's Table 1 defaults at a fidelity level
    (``rigid``, ``ale`` or ``full``; the ``1dof`` level is run by :func:`run_landing`).

    A level is a choice of components: the rocket (``rigid``/``ale``: one rigid body, hooks welded;
    ``full``: the flexible rocket with hinged, sprung hooks) and the cables (``cable_model``:
    ``"massless"``, the massless elastic cables of the ``rigid`` level, or ``"ale"``, the ALE cables
    with mass and hook contact; default ``"massless"`` at ``rigid``, ``"ale"`` at ``ale`` and
    ``full``). ``cable_model="massless"`` at ``full`` keeps the flexible rocket and the sprung hooks
    and drops the cables' mass: the ``rhoA -> 0`` member of the full level, which the 1-DOF limit
    test uses (``tests/arresting/test_passive.py``). ``rocket_params``
    (:class:`~jaxcable.arresting.landing_rocket.LandingRocketParams`, default Table 1) sets the rocket's
    and the hooks' values (e.g. the hook spring ``k_h``).

    Defaults chosen by measurement (``experiments/bench_land.py``, ``experiments/convergence_landing.py``):

    * ``cable_damping_s`` (the paper's beta, value not given) = :data:`DEFAULT_CABLE_DAMPING_S`
      (6.3e-3 s), fitted to the paper's section III.F (``docs/arresting_validation.md``). Explicit
      solvers cannot take it at the ale and full levels (the highest element modes decay at
      ``beta omega^2``: ~1e-6 s steps), so those levels run the W-method by default; beta = 1e-5 s
      (the former default) leaves the cable-counterweight mode (~30 rad/s) almost undamped, and
      a_max rings with it (see docs/arresting.md, "Findings worth knowing").
    * contact friction: Coulomb with the STEP law, static regime regularised over
      ``v_s = 0.5`` m/s (``v_d = 1.25`` m/s): the stick "creep" damping ``1.5 mu_s f_n / v_s`` on a
      ~3 kg cable node at the hook is the stiffest rate of the model once the hook load has grown
      (-7.6e4 1/s at t = 0.7 s with v_s = 0.2 m/s; real, so it holds an explicit solver to ~5e-5 s
      steps). Over 1 s landings of the design case and a deviated, tilted capture at the full level,
      v_s = 0.05, 0.1, 0.2 and 0.5 m/s give z_max, sigma_max and the stop time within 0.13% of each
      other and a_max within 0.5% (the ringing peak's own spread); 1.0 m/s moves a_max by 1.7%.
      In the passive phase of the two-phase deviated case (13 m off centre, the cables slide far over
      the hooks) 0.5 m/s lowers sigma_max by 1.25% against 0.05 m/s (0.2 m/s: 0.5%).
      0.5 m/s halves the steps against 0.2 m/s (``docs/notes/contact_slip.md``; 0.3 s landings end
      before the hook load grows and do not show the difference).
    * the hook as a sliding node of its cable (:data:`DEFAULT_HOOK_CONTACT`) on the level's mesh
      (``n_span_elements``, ``n_fine`` None: :data:`LEVEL_CABLE_MESH`): 80 span elements, 16 of
      them over +-3 m next to each hook (0.375 m), 2 per tower, at both levels. The design case's
      and the deviated case's criteria converge there (a_max within 0.1% of 128 elements at the
      full level, within 0.3-1.2% of 128-256 at the ale level; ``docs/arresting_validation.md``).
      ``hook_contact="capsule", n_span_elements=32, n_fine=16`` (a former default) ran 1.5x (ale)
      and 1.4x (full) faster than the node on 64 elements (``experiments/bench_hook_model.py``),
      but takes about 1.3x the steps of the node on 80 (16 fine); on the design case its a_max
      reads 2% low, on the deviated case a_max 14% high and sigma_max unconverged (765-846 MPa
      over the meshes).

    ``frame_centre_xy`` (2,) [m]: centre of the capture frame (the sliders' positions) at capture;
    default: under O (perfect tracking). The two-phase scene passes the tracked frame's centre.

    ``wind`` (:class:`.wind.WindField`, default None: still air), ``aero``
    (:class:`.wind.AeroCoefficients`, default ``AeroCoefficients()`` when wind is given) and
    ``wind_time_offset_s`` [s]: air loads on the rocket and (ale/full) the arresting spans.

    ``save_spacing_s`` [s] (default :data:`SAVE_SPACING_S`, 1 ms) or ``n_save`` (a fixed number of
    samples, default None): the saved grid when :func:`jaxcable.core.simulate` gets no ``save_ts``
    (:meth:`PassiveLandingScene.default_save_ts`); the maxima a_max and sigma_max are taken over it.

    ``hook_contact`` (ALE cables only; default None: :func:`hook_contact_at`, the node with ALE
    cables): ``"node"``, the hook as a sliding node of its cable held at the throat by a ring
    (:meth:`AleCables._node_contact`): no push along a kinked cable, at the price of a cable that
    can never leave its hook; or ``"capsule"``, the Hertz/Coulomb contact of the hooks' capsules
    with every span element. With the node the design case's a_max converges from
    ``n_span_elements=64, n_fine=32`` on (5.18 / 5.13 g at 64 / 128; 5.69 g at 32), and the deviated
    case's sigma_max converges at every mesh tried (``docs/arresting_validation.md``, "The hook as
    a sliding node").
    """
    check_choice("fidelity", fidelity, FIDELITY_LEVELS)
    if fidelity == "1dof":
        raise ValueError("fidelity '1dof' has no scene: run it with run_landing('1dof')")
    if cable_model is None:
        cable_model = "massless" if fidelity == "rigid" else "ale"
    check_choice("cable_model", cable_model, ("massless", "ale"))
    hook_contact = hook_contact_at(hook_contact, cable_model)
    check_choice("hook_contact", hook_contact, ("capsule", "node"))
    if hook_contact == "node" and cable_model == "massless":
        raise ValueError(
            f"hook_contact='node' needs the ALE cables (cable_model 'ale'), got cable_model={cable_model!r} "
            f"at fidelity {fidelity!r}: the massless cables have no nodes"
        )
    check_instance("capture", capture, CaptureState, allow_none=True)
    check_instance("layout", layout, ArrestingLayout, allow_none=True)
    check_instance("buffer", buffer, BufferDevice, allow_none=True)
    check_instance("contact", contact, eqx.Module, allow_none=True)
    check_instance("rocket_params", rocket_params, eqx.Module, allow_none=True)
    check_instance("wind", wind, WindField, allow_none=True)
    check_instance("aero", aero, AeroCoefficients, allow_none=True)
    check_cable_damping("cable_damping_s", cable_damping_s)
    check_t_end("t_end_s", t_end_s)
    _check_save_grid(save_spacing_s, n_save)
    n_span_elements, n_fine = cable_mesh_at(fidelity, n_span_elements, n_fine)
    check_cable_mesh(n_span_elements, n_fine)
    check_positive("fine_half_width_m", fine_half_width_m)
    check_range("fine_half_width_m", fine_half_width_m, 0.0, 1000.0, high_inclusive=True, unit=" m")
    check_int("n_rocket_bodies", n_rocket_bodies, 1, 100)
    if n_rocket_bodies != DEFAULT_ROCKET_BODIES:  # refused, not ignored, where the rocket is one rigid body
        check_rocket_bodies(n_rocket_bodies, fidelity)
    check_positive("wind_time_offset_s", wind_time_offset_s, allow_zero=True)
    if frame_centre_xy is not None:
        check_vector("frame_centre_xy", frame_centre_xy, (2,))
    capture = CaptureState() if capture is None else capture
    layout = ArrestingLayout() if layout is None else layout
    buffer = BufferDevice() if buffer is None else buffer
    check_hooks_inside_frame(layout, capture)
    gravity = jnp.array([0.0, 0.0, -9.81])
    if fidelity == "full":
        rocket = flexible_landing_rocket(n_bodies=n_rocket_bodies, hinged_hooks=True, params=rocket_params)
    else:
        rocket = rigid_landing_rocket(hinged_hooks=False, params=rocket_params)
    state0 = rocket.initial_state(capture.position, capture.velocity, capture.rotation_vector, capture.omega)
    pos0, vel0 = rocket.hook_points_world(state0)
    hooks0 = HookPoints(positions=pos0, velocities=vel0)
    hook_radius = 0.5 * rocket.params.hook_diameter_m
    clearance = hook_radius + layout.cable_radius_m
    w = throat_weights(pos0[0, 0], pos0[0, 1], pos0[0, 2], clearance)
    # Put O so that the mean throat height is on the top plane (cables straight at capture in the
    # design case): shift the capture position down by the throat's height above O.
    throat0 = jnp.einsum("j,kjd->kd", w, pos0)
    dz = jnp.mean(throat0[:, 2])  # height of the throats above the plane (z = 0)
    capture = eqx.tree_at(lambda c: c.z_m, capture, capture.z_m - dz)
    state0 = rocket.initial_state(capture.position, capture.velocity, capture.rotation_vector, capture.omega)
    pos0, vel0 = rocket.hook_points_world(state0)
    hooks0 = HookPoints(positions=pos0, velocities=vel0)
    frame_centre = capture.position[:2] if frame_centre_xy is None else jnp.asarray(frame_centre_xy)
    if cable_model == "massless":
        cables = MasslessCables.build(layout, buffer, frame_centre, hooks0, w, damping_s=cable_damping_s)
    else:
        contact = scene_contact_law() if contact is None else contact
        cables = AleCables.build(
            layout,
            buffer,
            contact,
            frame_centre,
            hooks0,
            w,
            hook_radius,
            n_span_elements=n_span_elements,
            n_fine=n_fine,
            fine_half_width_m=fine_half_width_m,
            damping_s=cable_damping_s,
            hook_contact=hook_contact,
        )
    if wind is not None:
        aero = AeroCoefficients() if aero is None else aero
        if isinstance(cables, AleCables):
            cables = dataclasses.replace(cables, wind=wind, aero=aero, wind_time_offset_s=wind_time_offset_s)
    return PassiveLandingScene(
        rocket=rocket, cables=cables, capture=capture, gravity=gravity, t_end_s=t_end_s, wind=wind, aero=aero,
        wind_time_offset_s=wind_time_offset_s, save_spacing_s=save_spacing_s, n_save=n_save,
    )  # fmt: skip
