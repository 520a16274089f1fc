"""The arresting-cable landing's benchmark cases for ``jaxcable bench`` (:mod:`jaxcable.studies.bench`).

=============  =====================================================================================
scene          quantities
=============  =====================================================================================
``passive``    z_max [m], a_max [g], sigma_max [MPa] (passive deceleration, design case, Table 1)
``two_phase``  capture margin [m], tracking error at t_c/2 [m], z_max, a_max, sigma_max (deviated
               case of section IV.A, scenario I; both phases at the same solver and tolerances)
=============  =====================================================================================

Registered at import (sizes chosen to compile and run in ~2 min on 2 cores): ``"1dof"`` (2 s),
``"rigid"`` (1 s), ``"two_phase"`` (rigid passive phase, 1 s after capture), ``"ale"`` and
``"full"`` (the levels' first 0.05 s) and ``"ale_stiff"`` (the ale level at cable damping beta =
1e-2 s, first 0.05 s: ``jaxcable bench --cases ale_stiff --solvers rosw bosh3`` shows what the
W-method buys).

The ``two_phase`` runner integrates phase 1 with the requested solver too
(:func:`~jaxcable.arresting.two_phase.two_phase_outputs` fixes phase 1 at Tsit5, rtol = 1e-6), so
it rebuilds the capture outputs here from the tracking scene's own methods. In float32 the
two-phase case draws its noise and gust in float32, a different realisation than float64 for the
same seed (``jax.random`` draws depend on the dtype): compare float32 with float32 only.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import ClassVar

import diffrax
import equinox as eqx
import jax.numpy as jnp

from jaxcable.arresting.buffer import BufferDevice
from jaxcable.arresting.landing_rocket import rigid_landing_rocket
from jaxcable.arresting.layout import ArrestingLayout
from jaxcable.arresting.one_dof import OneDofParams, simulate_one_dof
from jaxcable.arresting.passive import LIGHT_CABLE_DAMPING_S, passive_landing_scene
from jaxcable.arresting.two_phase import captured_state, event_occurred, interp, tracking_scene
from jaxcable.core.simulate import make_solver, simulate
from jaxcable.studies import registry
from jaxcable.studies.bench import AbstractBenchCase, simulation_runner

__all__ = ["PassiveBenchCase", "TwoPhaseBenchCase", "one_dof_params"]

PASSIVE_QUANTITIES = ("z_max_m", "a_max_g", "sigma_max_mpa")


def one_dof_params() -> OneDofParams:
    """:class:`~jaxcable.arresting.one_dof.OneDofParams` of the design case with the mass, layout and
    buffer of the other passive levels (the mapping :func:`jaxcable.arresting.landing.run_landing`
    uses for level ``1dof``)."""
    layout, buffer = ArrestingLayout(), BufferDevice()
    return OneDofParams(
        m_r=rigid_landing_rocket(hinged_hooks=False).total_mass_kg,
        v0=20.0,
        l_0=layout.half_span_m,
        alpha=buffer.transfer_rate,
        m_w=buffer.counterweight_mass_kg,
        F_f=buffer.brake_force_N,
        cable_radius=layout.cable_radius_m,
    )


class PassiveBenchCase(AbstractBenchCase):
    """The passive deceleration of the design case (Table 1) at one fidelity level.

    Attributes:
        level: ``"1dof"``, ``"rigid"``, ``"ale"`` or ``"full"``.
        t_end_s: time after capture [s].
        n_span_elements, n_fine: ALE span mesh (levels ``ale``/``full``), see
            :func:`jaxcable.arresting.passive.passive_landing_scene`.
    """

    n_span_elements: int = eqx.field(static=True, default=16)
    n_fine: int = eqx.field(static=True, default=8)
    cable_damping_s: float = eqx.field(static=True, default=LIGHT_CABLE_DAMPING_S)
    """Cables' Rayleigh damping beta [s] (levels ``ale``/``full``; default the light 1e-5 s, at which
    the explicit solvers the benchmark compares can run: the scenes' calibrated default is stiff)."""
    hook_contact: str = eqx.field(static=True, default="capsule")
    """How a hook holds its cable (levels ``ale``/``full``): the benchmark's solver comparisons and
    records are the capsule contact's (the scenes' default is the hook as a sliding node)."""

    scene: ClassVar[str] = "passive"
    levels: ClassVar[tuple[str, ...]] = ("1dof", "rigid", "ale", "full")
    quantities: ClassVar[tuple[str, ...]] = PASSIVE_QUANTITIES

    @property
    def label(self) -> str:
        if self.level in ("ale", "full"):
            return f"{self.level} ({self.n_span_elements} el., beta {self.cable_damping_s:g} s)"
        return self.level

    def runner(self) -> Callable:
        if self.level == "1dof":
            return self._one_dof_runner()
        kw = (
            dict(n_span_elements=self.n_span_elements, n_fine=self.n_fine, cable_damping_s=self.cable_damping_s,
                 hook_contact=self.hook_contact)
            if self.level != "rigid"
            else {}
        )
        scene = passive_landing_scene(self.level, t_end_s=self.t_end_s, **kw)
        return simulation_runner(scene, self.t_end_s, self.quantities)

    def _one_dof_runner(self) -> Callable:
        """The 1-DOF model of section II.B (:func:`one_dof_params`)."""
        params = one_dof_params()

        def run(solver, rtol, atol, max_steps):
            controller = diffrax.PIDController(rtol=rtol, atol=atol)
            sol = simulate_one_dof(params, t1=self.t_end_s, solver=make_solver(solver), stepsize_controller=controller,
                                   max_steps=max_steps)  # fmt: skip
            # simulate_one_dof reports no step count or status; a failed solve shows as NaN outputs.
            # Its own (unfiltered) maxima: this case measures the ODE solver's error, not the criteria
            # (run_landing("1dof") reports the CFC 60 filtered ones)
            nan_i = jnp.asarray(-1)
            return dict(z_max_m=sol.z_max, a_max_g=sol.a_max, sigma_max_mpa=sol.sigma_max, num_steps=nan_i,
                        num_rejected=nan_i, status=jnp.where(jnp.isfinite(sol.z_max), 0, -1))  # fmt: skip

        return run


def _two_phase(scene, t_end_s, solver, rtol, atol, max_steps):
    """Both phases at one solver setting (the outputs of ``two_phase_outputs`` that we compare)."""
    track = simulate(scene, scene.t_max_s, solver=solver, rtol=rtol, atol=atol, max_steps=max_steps)
    final = track.final_state
    passive = passive_landing_scene(
        "rigid", captured_state(scene, final), scene.layout, frame_centre_xy=scene.frame_centre(final),
        t_end_s=t_end_s,
    )  # fmt: skip
    land = simulate(passive, t_end_s, solver=solver, rtol=rtol, atol=atol, max_steps=max_steps)
    o = land.outputs
    ok = event_occurred(track.status) & land.ok
    return dict(
        capture_margin_m=jnp.min(scene.capture_margins(final)),
        tracking_error_m=interp(track.ts, track.probes["tracking_error_m"], 0.5 * scene.controller.tracking_time_s),
        z_max_m=o["z_max_m"],
        a_max_g=o["a_max_g"],
        sigma_max_mpa=o["sigma_max_mpa"],
        num_steps=track.num_steps + land.num_steps,
        num_rejected=track.num_rejected + land.num_rejected,
        status=jnp.where(ok, 0, jnp.where(event_occurred(track.status), land.status, track.status)),
    )


_two_phase_jit = eqx.filter_jit(_two_phase)


class TwoPhaseBenchCase(AbstractBenchCase):
    """The two-phase landing of the deviated case (section IV.A): tracking, capture, passive phase.

    Attributes:
        level: ``"rigid"`` (the passive phase's level).
        t_end_s: time after capture of the passive phase [s].
        scenario: wind scenario of Table 4 (``"I"``, ``"II"``, ``"III"``).
    """

    scenario: str = eqx.field(static=True, default="I")

    scene: ClassVar[str] = "two_phase"
    levels: ClassVar[tuple[str, ...]] = ("rigid",)
    quantities: ClassVar[tuple[str, ...]] = ("capture_margin_m", "tracking_error_m", *PASSIVE_QUANTITIES)

    def runner(self) -> Callable:
        scene = tracking_scene(scenario=self.scenario)

        def run(solver, rtol, atol, max_steps):
            return _two_phase_jit(scene, self.t_end_s, make_solver(solver), rtol, atol, max_steps)

        return run


registry.register_bench_case("1dof", PassiveBenchCase("1dof", t_end_s=2.0))
registry.register_bench_case("rigid", PassiveBenchCase("rigid", t_end_s=1.0))
registry.register_bench_case("two_phase", TwoPhaseBenchCase("rigid", t_end_s=1.0))
registry.register_bench_case("ale", PassiveBenchCase("ale", t_end_s=0.05))
registry.register_bench_case("full", PassiveBenchCase("full", t_end_s=0.05))
registry.register_bench_case("ale_stiff", PassiveBenchCase("ale", t_end_s=0.05, cable_damping_s=1e-2))
