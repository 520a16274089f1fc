r"""Active-tracking controller of the capture phase: measurement, filter, target rule, PD law with
the saturation ramp, motor lag and dead time, as a state-space block that a scene embeds in its ODE.

Arresting-cable paper (Zhang et al. 2021), section II.A (eqs 1-11, Fig 4) and section III.E
(eqs 46-47). Everything is written for the four slider channels at once (arrays of shape (4,));
there is no batch axis: sweeps ``jax.vmap`` over a :class:`TrackingController`'s array fields.

Glossary
--------
=================  ===========================  ============================================
paper              code                         meaning [unit]
=================  ===========================  ============================================
Delta t            ``sample_period_s``          sampling period of the laser measurement [s]
sigma_r            ``noise_rms_m``              RMS of the measurement noise, per axis [m]
r_h, r_b           ``r_head``, ``r_bottom``     filtered head/bottom positions (3,) [m]
r_t                ``target_point``             target point on the top plane (x_t, y_t) [m]
d^target, d        ``slider_target``, ``d``     slider targets / displacements (4,) [m]
e                  ``error_m``                  d^target - d (4,) [m]
a_p                ``gain_per_s``               proportional gain [1/s]
(1 in eq 4)        ``derivative_gain``          gain of e' in eq 4 [-] (1: the paper's PD; 0: P)
kappa(t), t_c      :func:`kappa`,               saturation ramp (eq 6), duration of the
                   ``tracking_time_s``          tracking/capturing phase [s]
tau                ``motor_delay_s``            dead time of the servo motor [s]
(1 in eqs 7-8)     ``motor_bandwidth_per_s``    bandwidth b of the motor's position loop [1/s]
                                               (calibrated for the two-phase landing: 5)
v_p, d_p           ``v_p``, ``d``               reel-out speed (4,) [m/s], displacement [m]
D_cmd              ``command``                  commanded position, integral of v_smooth [m]
I                  ``command_integral``         the state behind D_cmd (see below) [m]
=================  ===========================  ============================================

Measurement, filter and target rule (eqs 1-3)
---------------------------------------------
In :mod:`jaxcable.arresting.measurement`: the noisy, filtered measurement of head and bottom
(:func:`~jaxcable.arresting.measurement.filtered_measurement`, ``r - 2 Delta t v`` plus the
filtered noise of a :class:`~jaxcable.arresting.measurement.NoiseTrack`) and the target rule
(:func:`~jaxcable.arresting.measurement.slider_target`).

PD law, ramp and motor (eqs 4-8) as a state space (eq 46)
---------------------------------------------------------
eq 4-6: ``v_smooth = kappa(t) (a_p e + g_d e')``, kappa = min(2 t / t_c, 1) (g_d = 1 in the paper).

Eq 7 as printed, ``v_p = -d_p + integral_0^{t - tau} v_smooth``, is dimensionally a position servo
with a unit bandwidth. Our reading: with ``D_cmd(t) = integral_0^t v_smooth`` (D_cmd = 0 for t <= 0)
and v_p = d_p',

    d_p' = b (D_cmd(t - tau) - d_p),      b = motor_bandwidth_per_s (1 /s in the paper),

a first-order lag of bandwidth b on the delayed commanded position. Its Laplace transform from rest
is ``V_p = s D_p = b e^{-tau s} V_smooth / (s + b)``; with V_smooth = (a_p + s) E (kappa = 1) this is
eq 8 for b = 1. Eq 8's "K(s)" is read as the time-domain factor kappa(t) (a product in time is not a
product of transforms): the transfer function holds once kappa = 1, t >= t_c / 2.

The noisy error is never differentiated. Integrating eq 5 by parts,

    D_cmd(t) = integral_0^t kappa (a_p e + g_d e') = g_d kappa(t) e(t) + I(t),
    I' = (kappa a_p - g_d kappa') e,      I(0) = -g_d kappa(0) e(0),

so D_cmd needs e, not e' (with the ramp kappa(0) = 0 and I(0) = 0; without it, I(0) = -g_d e(0):
the command starts from rest, e'(0) carries no impulse). The controller's state is
(I, delay-filter states, d_p); its input is e and its outputs v_p and d = d_p (eq 47's d_p = d).
v_p has a direct feed-through of e (the D of eq 46) but d does not, so a scene that forms
e = d^target - d from the controller's own d has no algebraic loop.

Motor lag off (``motor_lag=False``): ``d_p' = v_smooth(t - tau)`` directly, for checking eq 9.
Only the P law is allowed then (``derivative_gain = 0``): the PD law without the lag is improper
(e' feeds straight into d_p', an algebraic loop); the paper's 1/(s + 1) is what makes eq 46 proper.

Eq 9 (tau = 0, no lag, P law, constant target): ``e' = -kappa a_p e`` gives
``e = e_0 exp(-a_p t^2 / t_c)`` for t <= t_c / 2 (eqs 9-10), and ``a_p >= 20 / t_c`` (eq 11) makes
``|e / e_0| <= e^{-5}`` at t_c / 2. With the paper's PD law and lag, eq 9 is only a design estimate.
Fig 4's "e = 17" is read as an initial error of 17 m (constant target 17 m, sliders at rest at 0).

Dead time
---------
diffrax has no delay equations: ``e^{-tau s}`` is replaced by a rational approximant in state-space
form, :class:`~jaxcable.arresting.motor_delay.PadeDelay` (default, order 2) or
:class:`~jaxcable.arresting.motor_delay.LagChainDelay`, in :mod:`jaxcable.arresting.motor_delay`
(realisation, behaviour at tau = 0, and the errors measured on the Fig 4 case).
"""

from __future__ import annotations

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from jaxcable.arresting.measurement import (  # noqa: F401  (re-exported: imported from here by tests and experiments)
    FILTER_DELAYS,
    FILTER_WEIGHTS,
    NoiseTrack,
    delayed_measurement,
    filter_noise_samples,
    filtered_measurement,
    measurement_noise,
    measurement_noise_track,
    slider_target,
    target_point,
)
from jaxcable.arresting.motor_delay import AbstractDelay, LagChainDelay, PadeDelay
from jaxcable.core.validation import as_array, check_choice, check_fields, check_finite, check_positive, check_range, positive

__all__ = [
    "CALIBRATED_MOTOR_BANDWIDTH_PER_S",
    "ControllerState",
    "RocketPath",
    "TrackingController",
    "TrackingRun",
    "delayed_loop_reference",
    "kappa",
    "kappa_rate",
    "run_tracking_loop",
]

# ---------------------------------------------------------------------------------------------
# saturation ramp (eq 6)
# ---------------------------------------------------------------------------------------------


def kappa(t, t_c):
    """Eq 6: kappa = 2 t / t_c for t < t_c / 2, then 1 (0 before t = 0). [-]"""
    return jnp.clip(2.0 * t / t_c, 0.0, 1.0)


def kappa_rate(t, t_c):
    """d kappa / dt [1/s]: 2 / t_c on [0, t_c / 2), else 0 (right-continuous)."""
    return jnp.where((t >= 0.0) & (t < 0.5 * t_c), 2.0 / t_c, 0.0)


# ---------------------------------------------------------------------------------------------
# the controller (eqs 4-8 as eq 46)
# ---------------------------------------------------------------------------------------------

N_CHANNELS = 4
DELAY_MODELS = ("pade", "lags")

CALIBRATED_MOTOR_BANDWIDTH_PER_S = 5.0
"""b of the tracking phase's servo motors [1/s], calibrated to what the paper shows of its tracking
phase (:mod:`jaxcable.arresting.tracking_calibration`, ``experiments/calibrate_tracking.py``): the fit
gives 5.17 /s within ``[1, 8]`` /s, adopted as 5. Eq 7's unit coefficient equates a velocity with a
position, so its unit is not printed; eqs 9-11 design the gain for a motor without lag. With the
printed 1 /s the loop's rate is 1 /s whatever a_p (poles of ``s^2 + 2 s + a_p``), and the tracking
error at t_c / 2 reached 2.6 m (scenario II) and 3.5 m (III) in 16 QMC cases where Figs 15-17 show it
near zero; at 5 /s (with the calibrated rocket) 0.09 and 0.08 m, all 48 cases of I-III captured. The
loop keeps a sensitivity peak of 1.69 at tau = 0.1 s and a_p = 6 (2 at 8 /s).
The two-phase scene uses it (:func:`jaxcable.arresting.two_phase.tracking_scene`);
:class:`TrackingController`'s own default stays eq 8's printed 1 /s: the controller alone as printed
(Fig 4's reproduction, ``experiments/figure4_controller.py``)."""


class ControllerState(eqx.Module):
    """State of the four channels."""

    command_integral: jax.Array
    """I: D_cmd - g_d kappa e, (4,) [m]."""
    delay: jax.Array
    """Dead-time filter states, (4, n) [m] (lag on) or [m/s] (lag off)."""
    slider: jax.Array
    """d = d_p: slider displacement from its home position = reeled-out length, (4,) [m]."""


_CONTROLLER_BOUNDS = {
    "gain_per_s": positive(high=100.0, unit=" 1/s", why="Table 4: 2-6 1/s"),
    "derivative_gain": positive(allow_zero=True, high=100.0, why="the paper's PD law: 1"),
    "tracking_time_s": positive(high=600.0, unit=" s", why="Table 4: 5-10 s"),
    "motor_delay_s": positive(allow_zero=True, high=10.0, unit=" s", why="Table 2: up to 0.1 s"),
    "motor_bandwidth_per_s": positive(high=1e4, unit=" 1/s", why="eq 8: 1 1/s"),
    "sample_period_s": lambda name, v: (
        check_positive(name, v), check_range(name, v, 1e-4, 1.0, inclusive=True, unit=" s", why="default 0.02 s")
    ),
    "noise_rms_m": positive(allow_zero=True, high=10.0, unit=" m", why="Table 2: up to 0.1 m"),
}
"""The bound of each :class:`TrackingController` array field (reasons in :meth:`TrackingController.check_arguments`)."""


class TrackingController(eqx.Module):
    """PD tracking law with the saturation ramp, motor lag and dead time (eqs 4-8, 46).

    Array fields are parameters (vmappable, differentiable); ``delay_order``, ``delay_model``,
    ``ramp`` and ``motor_lag`` are structure. Defaults: the Fig 4 case (a_p = 2 /s, t_c = 10 s,
    tau = 0.1 s, sigma_r = 0.1 m). The time t of :meth:`derivative` counts from the start of
    tracking.
    """

    gain_per_s: jax.Array = eqx.field(converter=as_array, default=2.0)
    """a_p: proportional gain [1/s], > 0 (eq 11: a_p >= 20 / t_c for e^-5 at t_c / 2)."""
    derivative_gain: jax.Array = eqx.field(converter=as_array, default=1.0)
    """g_d: gain of e' in eq 4 [-], >= 0 (1: the paper's PD law; 0: P law)."""
    tracking_time_s: jax.Array = eqx.field(converter=as_array, default=10.0)
    """t_c: duration of the tracking/capturing phase [s], > 0 (the ramp ends at t_c / 2)."""
    motor_delay_s: jax.Array = eqx.field(converter=as_array, default=0.1)
    """tau: motor dead time [s], >= 0."""
    motor_bandwidth_per_s: jax.Array = eqx.field(converter=as_array, default=1.0)
    """b: bandwidth of the motor's position loop [1/s], > 0 (eq 8: 1; the two-phase scene's motors:
    :data:`CALIBRATED_MOTOR_BANDWIDTH_PER_S`)."""
    sample_period_s: jax.Array = eqx.field(converter=as_array, default=0.02)
    """Delta t: sampling period [s], > 0 (not in the paper; 50 Hz, see :mod:`jaxcable.arresting.measurement`)."""
    noise_rms_m: jax.Array = eqx.field(converter=as_array, default=0.1)
    """sigma_r: RMS of each component of the measurement noise [m], >= 0."""
    delay_order: int = eqx.field(static=True, default=2)
    """Order of the dead-time approximant (Pade order or number of lags). Default 2: on the Fig 4
    case the Pade error is 2.2e-5 m in d and 1.0e-3 m/s in v_p (0.02 % of the 6.3 m/s peak),
    far below the 0.1 m noise. Order 1 errs 20 times more in d (4.8e-4 m) and 5 times more in v_p
    (5.3e-3 m/s); order 3 gains only 4x in d and 2.5x in v_p for one more state per channel and a
    ~50 % faster pole (:mod:`jaxcable.arresting.motor_delay`; ``experiments/results/figure4_controller.md``)."""
    delay_model: str = eqx.field(static=True, default="pade")
    """``"pade"`` (:class:`~jaxcable.arresting.motor_delay.PadeDelay`) or ``"lags"``
    (:class:`~jaxcable.arresting.motor_delay.LagChainDelay`)."""
    ramp: bool = eqx.field(static=True, default=True)
    """Multiply the PD law by kappa(t) (eq 5); ``False``: kappa = 1 (Fig 4's "without kappa")."""
    motor_lag: bool = eqx.field(static=True, default=True)
    """Motor as a position servo of bandwidth b (eq 7); ``False``: d_p' = v_smooth(t - tau)."""

    def __check_init__(self):
        TrackingController.check_arguments(**{name: getattr(self, name) for name in _CONTROLLER_BOUNDS})
        check_choice("delay_model", self.delay_model, DELAY_MODELS)
        max_order = 8 if self.delay_model == "pade" else 10_000
        order = self.delay_order
        if not isinstance(order, (int, np.integer)) or not 1 <= int(order) <= max_order:
            raise ValueError(
                f"delay_order must be an integer in [1, {max_order}] for delay_model "
                f"{self.delay_model!r}, got {self.delay_order!r}"
            )
        if not self.motor_lag and not isinstance(self.derivative_gain, jax.core.Tracer):
            if np.any(np.asarray(self.derivative_gain) != 0.0):
                raise ValueError(
                    f"derivative_gain must be 0 with motor_lag=False (the PD law without the motor "
                    f"lag is improper), got {self.derivative_gain!r}"
                )
        _ = self.delay  # builds (and so validates) the dead-time approximant

    @staticmethod
    def check_arguments(**values):
        """Check some fields' values by the class's bounds (:data:`_CONTROLLER_BOUNDS`) before
        building one, e.g. a scene builder's arguments: ``gain_per_s`` in ``(0, 100]`` 1/s (Table 4:
        2-6; the design bounds 0.5-10), ``derivative_gain`` in ``[0, 100]``, ``tracking_time_s`` in
        ``(0, 600]`` s (Table 4: 5-10 s), ``motor_delay_s`` in ``[0, 10]`` s (Table 2: up to 0.1 s) and
        below ``tracking_time_s`` (a motor that acts only after the capture tracks nothing),
        ``motor_bandwidth_per_s`` in ``(0, 1e4]`` 1/s (eq 8: 1), ``sample_period_s`` in
        ``[1e-4, 1]`` s (50 Hz default) and ``noise_rms_m`` in ``[0, 10]`` m (Table 2: up to 0.1 m;
        10 m is 3x the capture frame's half-width, a measurement of nothing)."""
        for name in values:
            if name not in _CONTROLLER_BOUNDS:
                raise ValueError(f"unknown TrackingController field {name!r}; choose one of {sorted(_CONTROLLER_BOUNDS)}")
        check_fields(values, _CONTROLLER_BOUNDS)
        delay, t_c = values.get("motor_delay_s"), values.get("tracking_time_s")
        if delay is not None and t_c is not None and not any(isinstance(v, jax.core.Tracer) for v in (delay, t_c)):
            if np.any(np.asarray(delay, float) >= np.asarray(t_c, float)):
                raise ValueError(
                    f"motor_delay_s must be below tracking_time_s = {t_c!r} s (the motor would act only "
                    f"after the capture), got {delay!r}"
                )

    @property
    def delay(self) -> AbstractDelay:
        """The dead-time approximant with this controller's tau."""
        if self.delay_model == "pade":
            return PadeDelay(delay_s=self.motor_delay_s, order=int(self.delay_order))
        return LagChainDelay(delay_s=self.motor_delay_s, n_lags=int(self.delay_order))

    def kappa(self, t):
        """(kappa, kappa') at time t: eq 6, or (1, 0) with ``ramp=False``."""
        if not self.ramp:
            one = jnp.ones_like(jnp.asarray(t, dtype=float))
            return one, jnp.zeros_like(one)
        return kappa(t, self.tracking_time_s), kappa_rate(t, self.tracking_time_s)

    def jump_times(self):
        """Times where the vector field jumps (kappa' at t_c / 2), for the step-size controller."""
        if not self.ramp:
            return None
        return jnp.reshape(0.5 * self.tracking_time_s, (1,))

    def initial_state(self, initial_error_m=None) -> ControllerState:
        """Sliders at home and at rest, zero command (I(0) = -g_d kappa(0) e(0), see the docstring).

        ``initial_error_m`` (4,) [m] matters only with ``ramp=False`` (kappa(0) = 1)."""
        zeros = jnp.zeros(N_CHANNELS)
        e0 = zeros if initial_error_m is None else jnp.broadcast_to(initial_error_m, (N_CHANNELS,))
        k0, _ = self.kappa(0.0)
        integral = -self.derivative_gain * k0 * e0 if self.motor_lag else zeros
        return ControllerState(
            command_integral=integral,
            delay=jnp.zeros((N_CHANNELS, self.delay.n_states)),
            slider=zeros,
        )

    def derivative(self, t, state: ControllerState, error_m):
        """Vector field of the controller.

        Args:
            t: time since the start of tracking [s].
            state: :class:`ControllerState`.
            error_m: e = d^target - d, (4,) [m].

        Returns:
            (d state / dt, reel-out speed v_p (4,) [m/s], slider displacement d (4,) [m]).
        """
        k, k_rate = self.kappa(t)
        a_p, g_d = self.gain_per_s, self.derivative_gain
        e = error_m
        d = state.slider
        if self.motor_lag:
            command = g_d * k * e + state.command_integral  # D_cmd
            d_integral = (k * a_p - g_d * k_rate) * e
            d_delay, command_delayed = self.delay.derivative(state.delay, command)
            v_p = self.motor_bandwidth_per_s * (command_delayed - d)
        else:
            # d_p' = v_smooth(t - tau) with the P law (g_d = 0 is enforced: traced values too)
            v_smooth = k * a_p * e
            v_smooth = eqx.error_if(
                v_smooth, g_d != 0.0, "derivative_gain must be 0 with motor_lag=False"
            )
            d_integral = v_smooth
            d_delay, v_p = self.delay.derivative(state.delay, v_smooth)
        dstate = ControllerState(command_integral=d_integral, delay=d_delay, slider=v_p)
        return dstate, v_p, d

    def slider_displacement(self, state: ControllerState):
        """d (4,) [m]: the sliders' displacements from home (= reeled-out lengths, eq 47)."""
        return state.slider

    def measured_slider_target(self, t, positions_m, velocities_m_s, noise=None):
        """d^target (4,) [m] from the true head/bottom positions and velocities (2, 3) (eqs 1-3).

        ``positions_m[0]`` is the head, ``[1]`` the bottom; ``noise`` a :class:`~jaxcable.arresting.measurement.NoiseTrack` or None."""
        measured = filtered_measurement(positions_m, velocities_m_s, t, noise, self.sample_period_s)
        return slider_target(measured[0], measured[1])


# ---------------------------------------------------------------------------------------------
# the standalone loop (Fig 4)
# ---------------------------------------------------------------------------------------------


class RocketPath(eqx.Module):
    """A prescribed rigid translation of the rocket with constant acceleration (quadratic in t).

    Velocity and acceleration default to zero: a rocket hanging still (Fig 4's constant target)."""

    head_m: jax.Array = eqx.field(converter=as_array)
    """Head position at t = 0, (3,) [m] (z up, top plane z = 0)."""
    bottom_m: jax.Array = eqx.field(converter=as_array)
    """Bottom position at t = 0, (3,) [m]."""
    velocity_m_s: jax.Array = eqx.field(converter=as_array, default=(0.0, 0.0, 0.0))
    """Velocity at t = 0, (3,) [m/s]."""
    acceleration_m_s2: jax.Array = eqx.field(converter=as_array, default=(0.0, 0.0, 0.0))
    """Constant acceleration, (3,) [m/s^2]."""

    def __check_init__(self):
        for name in ("head_m", "bottom_m", "velocity_m_s", "acceleration_m_s2"):
            value = getattr(self, name)
            check_finite(name, value)
            if value.shape != (3,):
                raise ValueError(f"{name} must have shape (3,), got {value.shape}")

    def positions(self, t):
        """(2, 3) [m]: head, bottom at time t."""
        shift = self.velocity_m_s * t + 0.5 * self.acceleration_m_s2 * t**2
        return jnp.stack([self.head_m, self.bottom_m]) + shift

    def velocities(self, t):
        """(2, 3) [m/s]."""
        v = self.velocity_m_s + self.acceleration_m_s2 * t
        return jnp.stack([v, v])


class TrackingRun(eqx.Module):
    """Histories of :func:`run_tracking_loop` on ``ts``."""

    ts: jax.Array
    """Saved times [s], (n,)."""
    slider_m: jax.Array
    """d: slider displacements, (n, 4) [m]."""
    reelout_m_s: jax.Array
    """v_p: reel-out speeds of the active pulleys, (n, 4) [m/s]."""
    target_m: jax.Array
    """d^target as the controller sees it (filtered, noisy), (n, 4) [m]."""
    state: ControllerState
    """Controller states on ``ts`` (leading axis n)."""
    status: jax.Array
    """diffrax result code (0: success)."""
    num_steps: jax.Array
    """Accepted solver steps."""
    num_rejected: jax.Array
    """Rejected solver steps."""


def _loop_outputs(t, state, controller, rocket, noise):
    target = controller.measured_slider_target(
        t, rocket.positions(t), rocket.velocities(t), noise
    )
    dstate, v_p, d = controller.derivative(t, state, target - state.slider)
    return dstate, v_p, d, target


@eqx.filter_jit
def _solve_loop(controller, rocket, noise, save_ts, solver, rtol, atol, max_steps, adjoint, clip_jumps):
    def field(t, y, args):
        return _loop_outputs(t, y, controller, rocket, noise)[0]

    step = diffrax.PIDController(rtol=rtol, atol=atol)
    jumps = controller.jump_times() if clip_jumps else None
    # the noise track is piecewise linear: stepping onto its sample times keeps every step smooth
    # (Fig 4 with noise, rtol = atol = 1e-8: 1935 accepted + 214 rejected steps; 2816 + 4116 without)
    kinks = None if (noise is None or not clip_jumps) else noise.sample_times
    if jumps is not None or kinks is not None:
        step = diffrax.ClipStepSizeController(step, step_ts=kinks, jump_ts=jumps)
    t0 = jnp.zeros_like(save_ts[0])
    target0 = controller.measured_slider_target(
        t0, rocket.positions(t0), rocket.velocities(t0), noise
    )
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(field),
        solver,
        t0=t0,
        t1=save_ts[-1],
        dt0=None,
        y0=controller.initial_state(target0),
        saveat=diffrax.SaveAt(ts=save_ts),
        stepsize_controller=step,
        max_steps=max_steps,
        adjoint=adjoint,
        throw=False,
    )
    # outputs from the saved states, outside the solver loop (cheaper to compile than SaveAt(fn=))
    _, v_p, d, target = jax.vmap(lambda t, y: _loop_outputs(t, y, controller, rocket, noise))(
        sol.ts, sol.ys
    )
    return TrackingRun(
        ts=sol.ts,
        slider_m=d,
        reelout_m_s=v_p,
        target_m=target,
        state=sol.ys,
        status=sol.result._value,
        num_steps=sol.stats["num_accepted_steps"],
        num_rejected=sol.stats["num_rejected_steps"],
    )


def run_tracking_loop(
    controller: TrackingController,
    rocket: RocketPath,
    save_ts,
    *,
    noise: NoiseTrack | None = None,
    solver=None,
    rtol=1e-8,
    atol=1e-8,
    max_steps: int = 100_000,
    adjoint=None,
    clip_jumps: bool = True,
) -> TrackingRun:
    """The closed tracking loop alone (sliders as ideal position-controlled masses, Fig 4).

    The rocket follows ``rocket`` (prescribed); the controller sees its filtered, noisy
    measurement (eqs 1-3) and drives the four sliders from rest at home (d = 0).

    Args:
        controller: :class:`TrackingController`.
        rocket: :class:`RocketPath` (Fig 4: a still rocket, ``experiments/figure4_controller.py``).
        save_ts: output times [s], increasing, from 0; the run ends at ``save_ts[-1]``.
        noise: a :class:`~jaxcable.arresting.measurement.NoiseTrack` (``measurement_noise_track(key, controller, t1)``) or None.
        solver: a diffrax solver (default ``Tsit5``: the loop is smooth and non-stiff for
            tau >~ 0.01 s; kappa's kink at t_c / 2 is passed to the step-size controller).
        rtol, atol: PID tolerances (arrays inside: changing them does not recompile).
        max_steps: step budget.
        adjoint: a diffrax adjoint (default ``RecursiveCheckpointAdjoint``: reverse mode).
        clip_jumps: step exactly onto kappa's kink at t_c / 2 and onto the noise samples
            (``ClipStepSizeController``); ``False`` leaves them to the error control (many rejected
            steps with noise).
    """
    check_positive("rtol", rtol)
    check_positive("atol", atol)
    save_ts = jnp.asarray(save_ts, dtype=float)
    if save_ts.ndim != 1 or save_ts.shape[0] < 2:
        raise ValueError(f"save_ts must be 1-D with at least 2 times, got shape {save_ts.shape}")
    solver = diffrax.Tsit5() if solver is None else solver
    adjoint = diffrax.RecursiveCheckpointAdjoint() if adjoint is None else adjoint
    return _solve_loop(
        controller, rocket, noise, save_ts, solver, jnp.asarray(rtol), jnp.asarray(atol),
        max_steps, adjoint, bool(clip_jumps),
    )


# ---------------------------------------------------------------------------------------------
# exact delayed reference (NumPy): a true delay, not an approximant
# ---------------------------------------------------------------------------------------------


def delayed_loop_reference(controller: TrackingController, target_m: float, t1_s: float,
                           steps_per_delay: int = 20):
    """The Fig 4 loop with the *exact* dead time, for one channel and a constant target.

    Classical RK4 with a step h = tau / steps_per_delay dividing tau (and t_c / 2 and t1), so every
    delayed value D_cmd(t - tau) falls on the history grid or halfway between two of its points;
    the half-way values use cubic Hermite interpolation with the stored D_cmd and its derivative
    v_smooth (error O(h^4), the order of RK4). kappa' is taken at each step's midpoint, so the
    jump at t_c / 2 falls between steps. Error ~ 2e-11 m at steps_per_delay = 20 on Fig 4 (halving
    h changes d by 3e-10 -> 2e-11: fourth order). Needs concrete parameters, tau > 0, ``motor_lag``.

    Returns:
        (ts (N+1,) [s], d (N+1,) [m], v_p (N+1,) [m/s]) on the grid t_k = k h.
    """
    if not controller.motor_lag:
        raise ValueError("delayed_loop_reference needs motor_lag=True")
    tau = float(controller.motor_delay_s)
    if tau <= 0.0:
        raise ValueError(f"delayed_loop_reference needs motor_delay_s > 0, got {tau!r}")
    m = int(steps_per_delay)
    h = tau / m
    n_steps = int(round(t1_s / h))
    half_tc = 0.5 * float(controller.tracking_time_s)
    for name, value in (("t1_s", t1_s), ("t_c / 2", half_tc)):
        if abs(value / h - round(value / h)) > 1e-9:
            raise ValueError(f"{name} = {value!r} s must be a multiple of the step tau / m = {h!r} s")
    a_p = float(controller.gain_per_s)
    g_d = float(controller.derivative_gain)
    b = float(controller.motor_bandwidth_per_s)
    t_c = float(controller.tracking_time_s)
    ramp = controller.ramp

    def kap(t):
        return min(max(2.0 * t / t_c, 0.0), 1.0) if ramp else 1.0

    def kap_rate(t):
        return (2.0 / t_c if 0.0 <= t < 0.5 * t_c else 0.0) if ramp else 0.0

    ts = h * np.arange(n_steps + 1)
    integral = np.zeros(n_steps + 1)
    d = np.zeros(n_steps + 1)
    command = np.zeros(n_steps + 1)  # D_cmd on the grid
    command_rate = np.zeros(n_steps + 1)  # v_smooth on the grid (right limits)
    v_p = np.zeros(n_steps + 1)
    integral[0] = -g_d * kap(0.0) * target_m

    def history(k):
        return (command[k], command_rate[k]) if k >= 0 else (0.0, 0.0)

    def history_mid(k):
        """D_cmd at t_k + h / 2 (cubic Hermite); D_cmd = 0 (and rate 0) up to t = 0."""
        y0, r0 = history(k)
        # at t = 0 take the left limits (D_cmd = 0, rate 0): without the ramp v_smooth jumps there
        y1, r1 = (0.0, 0.0) if k + 1 <= 0 else history(k + 1)
        return 0.5 * (y0 + y1) + h * (r0 - r1) / 8.0

    def rhs(t, t_mid, integral_, d_, delayed):
        e = target_m - d_
        return (kap(t) * a_p - g_d * kap_rate(t_mid)) * e, b * (delayed - d_)

    def grid_values(k):
        e = target_m - d[k]
        rate = b * (history(k - m)[0] - d[k])
        v_p[k] = rate
        command[k] = g_d * kap(ts[k]) * e + integral[k]
        command_rate[k] = kap(ts[k]) * (a_p * e - g_d * rate)

    grid_values(0)
    for k in range(n_steps):
        t, tm = ts[k], ts[k] + 0.5 * h
        del0, delm, del1 = history(k - m)[0], history_mid(k - m), history(k - m + 1)[0]
        k1 = rhs(t, tm, integral[k], d[k], del0)
        k2 = rhs(tm, tm, integral[k] + 0.5 * h * k1[0], d[k] + 0.5 * h * k1[1], delm)
        k3 = rhs(tm, tm, integral[k] + 0.5 * h * k2[0], d[k] + 0.5 * h * k2[1], delm)
        k4 = rhs(t + h, tm, integral[k] + h * k3[0], d[k] + h * k3[1], del1)
        integral[k + 1] = integral[k] + h / 6.0 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        d[k + 1] = d[k] + h / 6.0 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        grid_values(k + 1)
    return ts, d, v_p
