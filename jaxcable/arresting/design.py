r"""Gradient-based design of the buffer devices over a quasi-Monte Carlo batch of captures.

Arresting-cable paper, section II.B (the 1-DOF design: counterweight mass ``m_w`` and brake friction
``F_f`` through the groups ``m_t_bar``, ``F_t_bar`` of eqs 15-24) and section IV (success criteria
``z_max < 10 m``, ``a_max < 5 g``, ``sigma_max < 800 MPa``; Table 8 captured-state ranges). The paper
picks ``m_w`` and ``F_f`` from the 1-DOF model (vertical, central capture, rigid cables) and then
checks them by Monte Carlo. Here the same two numbers and the PD gain ``a_p`` (section II.A, eq 4;
Table 4) are optimised directly on the criteria of a batch of deviated landings, with gradients
through the diffrax solve: ``phase="passive"`` simulates Table 8 captured states in the passive
scene at a chosen fidelity (``rigid`` by default; at ``ale`` and ``full`` :func:`design_problem`
meshes each case's cables on the host once, and the objective swaps the design's buffer into those
scenes, since the mesh does not depend on the buffer; forward-mode gradients through an ALE solve
agree with central differences to 3e-6, ``tests/test_design_ale.py``); ``phase="full"`` simulates Table 3
terminal-guidance states under Table 4 wind, gust, motor delay and noise through both phases of
:mod:`jaxcable.arresting.two_phase` (tracking at the rigid level, the capture event, the passive
phase at level ``rigid``), so the capture margin and the tracking error join the criteria. A set
of variables with ``a_p`` needs ``phase="full"`` and gets it by default (:func:`default_phase`).

Pieces
------
* :class:`DesignSpace`: which variables, their bounds, and the unconstrained reparametrisation the
  optimisers work in (a scaled logistic: ``x = lo + (hi - lo) sigmoid(u)``; every ``u`` is a design
  inside the bounds, and the bounds are reached only as ``|u| -> inf``).
* :class:`ObjectiveWeights`: the weights of the objective's terms (arrays: sweepable).
* :class:`DesignProblem`: the fixed QMC batch of captures, the fixed parts of the scene, the limits,
  widths and weights; :func:`design_problem` builds one from Table 8 samples.
* :func:`objective` (pure) and its jitted entry points, one ``filter_jit`` each:
  :func:`objective_value` (forward), :func:`objective_and_grad` (value and gradient) and
  :func:`batch_criteria` (per-case smooth and hard criteria at a physical design).
* :func:`optimise` (optax, adam by default), :func:`lbfgs` (optax's L-BFGS direction with a
  backtracking line search on the host) and :func:`nelder_mead` (scipy, derivative-free baseline on
  the same reparametrisation and objective); all return a :class:`DesignHistory`.
* The brake profile: ``b0 .. b{K-1}`` (``--vars m_w,profile:8``) are the K factors of
  ``F_f(w) = F_f phi(w)`` along the counterweight's rise (:mod:`jaxcable.arresting.buffer`), a
  design with many variables where gradients pay (``experiments/bench_design_profile.py``).
* :func:`cvar` (exact, sort-based) and :func:`smooth_cvar` (sort-free, smooth).
* :func:`optax_minimise`, :func:`lbfgs_minimise` and :func:`nelder_mead_minimise`: the loops for any objective on a
  :class:`DesignSpace` (the line-throwing design of :mod:`jaxcable.throw.design` uses them too).
* :func:`design_main`: the ``jaxcable design`` command line (``--scene throw``: the line-throwing
  launch design).

The objective
-------------
Per capture ``j`` the smooth criteria ``c_ij`` (``i`` = z, a, sigma) are the soft maxima over the
saved history of :func:`jaxcable.arresting.passive.smooth_landing_outputs`; normalised by their
limits ``L_i`` (10 m, 5 g, 800 MPa), ``r_ij = c_ij / L_i`` (``r < 1``: criterion met; the *margin*
is ``1 - r``). With weights ``w`` (:class:`ObjectiveWeights`)::

    J(x) = w_expected * E_j[ sum_i w_criteria_i r_ij ]                  expected cost
         + w_tail     * CVaR_alpha( r_tail,j )                           tail risk
         + sum_i w_penalty_i * E_j[ max(0, r_ij - 1 + margin)^2 ]        violation penalties
         + sum_k w_design_k * x_k / upper_k                              design cost (default 0)

* The *expected cost* is the batch mean of a weighted mix of the three normalised criteria (default
  equal thirds): it rewards margin on every criterion, i.e. a gentler, shorter, less loaded arrest.
* The *tail risk* is the conditional value at risk of one normalised criterion over the batch
  (default ``a_max``, the binding one at the rigid level; ``"worst"`` takes each case's largest
  normalised criterion): the mean of the worst ``(1 - alpha)`` fraction of the cases. The default
  form is :func:`smooth_cvar` (Rockafellar-Uryasev with a softplus, no sort); ``tail_form="exact"``
  uses :func:`cvar`.
* The *penalties* are squared hinges (C^1) on the batch mean, so every violating case pulls.
* The *design cost* is a linear cost of the variables relative to their upper bounds (e.g. the
  counterweight's mass); off by default.
* **To meet every criterion over the batch**, weigh the worst case, not the mean:
  ``ObjectiveWeights(expected=0, tail_criterion="worst", alpha=0.9)`` (CLI: ``--expected 0
  --tail-criterion worst --alpha 0.9``) minimises the CVaR of each case's largest normalised
  criterion. Measured (``experiments/design_feasibility.py``, rigid level, beta = 1e-2 s): adam
  meets all three criteria on all 64 training captures from step 23 and on 99% of 128 fresh ones;
  with the default weights it settles where the mean criteria are lowest and z_max is 2-4% over
  on a quarter of the cases.

``phase="full"`` adds two normalised criteria per landing (``CAPTURE_CRITERIA``), with their own
weights ``capture_criteria`` (default 0.25 each in the expected cost) and ``capture_penalty``
(default 100 each)::

    r_capture  = 1 - m / m_ref     m: soft minimum of the four hooks' capture margins [m]
                                   (width 0.02 m); m_ref: the margin of a centred vertical capture,
                                   1.405 m (:func:`capture_reference`); r < 1 <=> captured
    r_tracking = e / e_tol         e: true tracking error at capture [m]; e_tol = 1 m

``"worst"`` as the tail criterion then takes the largest of the five.

The expected cost and the penalties pull in different directions (a shorter stroke needs more
friction, which raises the deceleration and the cable load); the weights set the compromise.

Gradients
---------
:func:`objective_and_grad` differentiates through ``diffrax.diffeqsolve``. Two modes, both checked
against central differences in float64 (``tests/test_design.py``) and agreeing to 1e-5:

* ``gradient="forward"`` (default): ``diffrax.ForwardMode`` + ``jax.jacfwd``, the k tangents carried
  along the same adaptive solve. Chosen for its compile time (15-35 s against 35-65 s for reverse
  mode on the shared 2-core machine) and because it is the cheaper mode at every batch size
  measured (below).
* ``gradient="reverse"``: ``RecursiveCheckpointAdjoint`` + ``jax.grad``. ``checkpoints``
  (default ``REVERSE_CHECKPOINTS`` = 2048) is its checkpoint count: with at least as many
  checkpoints as solver steps (a rigid-level landing takes ~1100) every step is stored once and
  none is recomputed. diffrax's own default, ~sqrt(2 max_steps) = 632 for the rigid level's step
  budget, recomputes part of the solve (4.25x against 3.92x at n = 32, session 11); memory
  ~2048 x 70 floats per case, 37 MB at n = 32. Its cost does not grow with the number of design
  variables: 17 variables at n = 16 cost 0.78 s against 0.24 s forward
  (``bench_design_profile.md``), which is what makes L-BFGS beat Nelder-Mead there.
  ``BacksolveAdjoint`` cannot be used: :func:`jaxcable.core.simulate` saves its probes
  with ``SubSaveAt``, which diffrax's backsolve adjoint does not support.

Cost (gradient call / forward call, rigid level, m_w and F_f, 2-core AMD EPYC, JAX 0.10.2 CPU,
float64; session 11, after the rocket's Newton-Euler path in :mod:`jaxcable.components.multibody`;
``experiments/bench_free_body.py``, ``experiments/bench_design.py --sections chunk cost``):
forward mode 2.6-2.8x at n = 8, 2.9-3.0x at n = 32, 2.9-3.2x at n = 64 (batch chunks "auto");
reverse mode 3.8-4.1x. The goal of <= 3x is met by forward mode up to n = 32 and sits at it at
n = 64 (the runs spread by +-5% on this machine). With XLA's CPU library fusions off every call is
faster, and forward mode over chunks of 32 costs 2.96x (n = 32) and 2.75x (n = 64)
(``experiments/bench_xla_flags.py``). What remains is diffrax's loop carrying the tangents and the
vector field's tangent, which costs ~4x its value at 32 cases
(``experiments/bench_gradient_cost.py``). At the ale level (design case, 0.1 s) forward mode costs
3.5-4.3x the forward call and reverse mode 4.5x (session 12, after the ALE cable's slow-coordinate
blocks became dots in ``CableSubsystem.accelerations``; 4.4-4.7x and 5.5x before).
The gradient is that of the discrete adaptive solve: at the rigid level's rtol = 1e-6 it is 0.6 %
from the converged gradient (rtol 1e-8: 0.07 %), which is ample for the optimiser but not for a
finite-difference check (the tests use rtol 1e-8). Measurements: ``experiments/bench_design.py``.

Readings, corrections and measurements
--------------------------------------
* **Which "paper design".** :func:`paper_start` takes the paper's section II.B design through the
  1-DOF module: ``m_t_bar = 2`` and ``F_t_bar`` from eq 19 (unrounded, 15.7789) with eq 15 inverted
  for ``m_r = 25 t``: ``m_w = 1388.9 kg``, ``F_f = 3.0886e5 N`` (see :mod:`jaxcable.arresting.one_dof`
  for why this differs from Table 1's 0.92 t / 3.13e5 N). The rocket of the simulated scenes weighs
  25.18 t (hooks included); the design is not rescaled for the hooks.
* **The criteria's acceleration** is the magnitude of the centre of mass's acceleration (kinematic,
  gravity included in the force balance), as in :func:`~jaxcable.arresting.passive.landing_outputs`.
* **Soft maxima are upper bounds.** ``width * logsumexp(v / width) >= max(v)``, so a design whose
  smooth criteria meet the limits meets the hard ones. Their bias (soft - hard) grows with the number
  of samples within a few widths of the maximum, ``width * log(k)``: it is largest for ``z_max``,
  whose history sits on a plateau after the stop. Measured at the paper design over 64 Table 8
  captures of scenario I (rigid, 1.2 s, the scene's 1 ms grid = 1201 samples): with the default
  widths (0.05 m, 0.05 g, 5 MPa) the mean bias is 0.228 m on z_max, 0.133 g on a_max, 13.2 MPa on
  sigma_max (2.3 %, 2.7 %, 1.6 % of the limits; range over the cases 0.22-0.26 m, 0.11-0.17 g,
  11.8-16.1 MPa); half the widths give 0.104 m, 0.057 g, 5.6 MPa. (On the former 401-sample grid:
  0.173 m, 0.079 g, 7.7 MPa: the bias grows with the samples near the maximum, by at most
  ``width * log 3`` for 3x the samples.) The penalties therefore act about 2-3 % inside the hard
  limits; the bias of z is nearly constant over the batch, so it shifts the optimum rather than
  distorting the objective's shape.
* **Can m_w and F_f alone meet the criteria over Table 8?** At the rigid level with the default
  cable damping (1e-5 s): no. On a grid m_w = 300-4500 kg x F_f = 2.2e5-4.4e5 N over the 16-case
  optimisation batch, no design meets all three criteria in more than 25 % of the cases, and the
  lowest worst-case a_max among designs whose worst-case z_max < 10 m is 7.0 g (m_w = 300 kg,
  F_f = 3.4e5 N). A scratch grid down to m_w = 100 kg (17 cases, central one included) gave at best
  5.9 g with z_max = 10.08 m. What limits it: the stroke limit fixes the friction group (eq 19:
  F_t_bar ~ 15.8, a bit more for elastic cables), and with that friction the deceleration peaks of
  the off-centre, tilted captures and of the cable-counterweight oscillation (the README's
  sensitivity table) stay above 5 g; a lighter counterweight lowers them (less oscillating mass),
  so every optimiser ends at the lower bound of m_w and trades stroke against deceleration. From
  the paper design (worst z / a / sigma = 10.0 m / 9.0 g / 937 MPa over an independent 64-case
  batch, 6 % success) adam reaches about 320-380 kg and 2.6e5-2.7e5 N: 11.2-11.4 m / 6.5 g /
  550-565 MPa, 9-16 % success (``experiments/results/bench_design.md``). The objective does not
  maximise the success rate (a step function); the grid's best success rate is 25 %.
* **Stiffness at small m_w.** The brake's time constant ``m_w v_width / F_f`` (see
  :mod:`jaxcable.arresting.buffer`) shrinks with m_w; an explicit solver's step count grows like
  F_f / m_w (rigid, 1.2 s, worst of 16 cases at F_f = 3e5 N: 1000 steps at 1.4 t, 4200 at 300 kg;
  16000 at 100 kg and 3.6e5 N, where 20000 steps did not always suffice). The default lower
  bound of m_w is 300 kg to keep batches affordable; a batch under ``vmap`` runs in lockstep, so
  its cost is set by its slowest case.
* **a_p** (the PD law's proportional gain [1/s], eq 4 ``v_p = a_p e + e_dot``; eq 11 asks
  ``a_p >= 20 / t_c``; Table 4: 2, 5, 6) acts only in the active-tracking phase, so it needs
  ``phase="full"``: each case runs :func:`~jaxcable.arresting.two_phase.two_phase_outputs` with the
  scene of the two-phase sweeps (:class:`~jaxcable.arresting.two_phase.TwoPhaseCaseFunction`, same
  per-case noise and gust keys as ``jaxcable sweep --phase full``). The "paper design" of a full
  problem adds Table 4's a_p for its scenario. Restrictions, each from two_phase.py: the passive
  phase runs at level ``rigid`` (the ale/full levels mesh their cables on the host); the tracking
  phase runs at two_phase.py's fixed tolerance (rtol 1e-6) whatever ``rtol`` says (``rtol`` sets
  the passive phase's). Both gradient modes work (reverse mode of the two-phase program failed on
  jaxlib 0.10.2 until session 5: see ``body/multibody.py::_spd_solve``); forward is the default and
  the cheaper one for up to three design variables.
* **Which tracking error.** Section IV.A's criterion is that the tracking error "approaches zero";
  two_phase.py reports the *measured* error (frame centre vs. the noisy filtered target) at the
  last saved sample before capture and its ``tracking_ok`` holds it below 1 m. That value jumps
  with the save grid and the noise samples, so the objective uses the *true* error at the capture
  event, ``|frame centre - target point of the true rocket state|``: continuous in the design, and
  the miss distance the capture actually depends on; its hard value is the same number.
* **Wind after capture.** The passive phase of a full problem keeps the tracking phase's wind
  and the free rocket's aerodynamics (two_phase.py's ``passive_air``, default True here too;
  ``DesignProblem.passive_air=False``: still air after capture).
* **Measured**: the slow test (scenario III, 2 cases, 0.5 s after capture, passive rtol 1e-8:
  compile, value and gradient, six central differences, ``jaxcable design --steps 1``) took 61 s
  on the 2-core machine at load ~4; the gradient agrees with central differences to 1 % (the
  tracking phase's rtol 1e-6 sets that tolerance). Before the wind was kept after capture, the
  first objective-and-gradient call (scenario III, 2 cases, 1 s, rtol 1e-6) took 176 s under load
  7-10 (63 s of CPU), a compiled call 1.2 s.
  ``jaxcable design --vars m_w,F_f,a_p --n 4 --steps 2`` (scenario I, 1.2 s): 376 s wall under
  load 10 (98 s of CPU), J 32.87 -> 31.01, a_p 2 -> 2.27.
* **Optimising a_p** (``experiments/bench_design.py --sections two_phase``, scenario I, 8 cases):
  at the paper design (a_p = 2, Table 4) the worst capture margin is 0.01 m and the worst true
  tracking error 1.27 m (eq 8's unit motor bandwidth: see two_phase.py). Adam (16 steps, lr 0.2)
  raised a_p to 4.0: worst margin 0.25 m, tracking error 1.0 m, J 33.7 -> 28.2; Nelder-Mead (30
  evaluations) went to a_p = 8.7, m_w = 302 kg, F_f = 2.58e5 N: margin 0.73 m, error 0.46 m, and
  the passive criteria of the rigid-level optimum above (worst a_max 6.1 g, z_max 11.4 m), J = 5.2;
  no design met all criteria (a_max, as for m_w and F_f alone). Nelder-Mead reached adam's best in
  6 evaluations (24 s) against adam's 7 (104 s): with three variables, the derivative-free search
  still wins on this objective (its penalty terms make adam's fixed-size steps slow).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from jaxcable.core.validation import check_choice, check_finite, check_positive, check_range
from jaxcable.core.validation import float_array as _float_array, concrete as _concrete
from jaxcable.arresting.buffer import BufferDevice
from jaxcable.arresting.cable_sets import AleCables
from jaxcable.arresting.landing import LEVEL_DEFAULTS, LEVEL_STEP_CONTROL
from jaxcable.arresting.layout import ArrestingLayout, CaptureState
from jaxcable.arresting.passive import (
    DEFAULT_CABLE_DAMPING_S,
    FIDELITY_LEVELS,
    LandingCriteria,
    SmoothingWidths,
    passive_landing_scene,
    smooth_landing_outputs,
)

__all__ = [
    "CAPTURE_CRITERIA",
    "CONDITIONS",
    "CRITERIA",
    "DEFAULT_BOUNDS",
    "DESIGN_VARIABLES",
    "DesignHistory",
    "DesignProblem",
    "DesignSpace",
    "ObjectiveWeights",
    "batch_criteria",
    "capture_reference",
    "criteria_summary",
    "cvar",
    "design_main",
    "default_phase",
    "design_problem",
    "lbfgs",
    "lbfgs_minimise",
    "nelder_mead",
    "nelder_mead_minimise",
    "objective",
    "objective_terms",
    "objective_and_grad",
    "objective_value",
    "optimise",
    "optax_minimise",
    "paper_start",
    "profile_names",
    "smooth_cvar",
]

DESIGN_VARIABLES = {
    # name: (description [unit], phase it needs)
    "m_w": ("counterweight mass of one buffer device [kg]", "passive"),
    "F_f": ("sliding friction force of one brake [N]", "passive"),
    "a_p": ("proportional gain a_p of the PD law, eq 4 [1/s]", "full"),
}
MAX_PROFILE_KNOTS = 16
"""Most knots of the brake profile ``phi`` (variables ``b0 .. b15``; :mod:`jaxcable.arresting.buffer`)."""
DESIGN_VARIABLES.update(
    {
        f"b{k}": (f"brake-profile factor phi at knot {k} of the counterweight rise, F_f(w) = F_f phi(w) [-]", "passive")
        for k in range(MAX_PROFILE_KNOTS)
    }
)
"""The design variables one may choose, with what they are and the phase whose scene they act in.
``b0 .. b{K-1}`` (K >= 2, contiguous from ``b0``) are the K factors of the brake profile at equally
spaced knots of the counterweight rise over ``[0, buffer.brake_profile_travel_m]`` (6 m by default);
``profile_names(K)`` lists them and ``--vars m_w,profile:8`` chooses them on the command line."""

DEFAULT_BOUNDS = {
    # m_w: lower bound by cost, not physics (steps ~ 1/m_w, module docstring); upper 3.6x the paper
    "m_w": (300.0, 5000.0),
    # F_f: F_t_bar from 7.4 to 20 at m_w = 300-5000 kg (the stop needs F_t_bar > 1; eq 19: 15.8)
    "F_f": (2.0e5, 5.0e5),
    # a_p: Table 4 uses 2, 5, 6; eq 11 asks a_p >= 20 / t_c (2 to 4 1/s for t_c = 10 to 5 s)
    "a_p": (0.5, 10.0),
    # brake-profile factors: from a quarter to twice the brake's F_f along the rise
    **{f"b{k}": (0.25, 2.0) for k in range(MAX_PROFILE_KNOTS)},
}
"""Default bounds ``(lower, upper)`` per variable, in the variable's unit."""

CRITERIA = ("z_max_m", "a_max_g", "sigma_max_mpa")
"""The three success criteria of section IV.A, in the order used by every (3,) weight array."""

CAPTURE_CRITERIA = ("capture_margin_m", "tracking_error_m")
"""The two tracking-phase criteria of a ``phase="full"`` problem, in the order of every (2,) weight
array: the smallest capture margin of the four hooks [m] (met when > 0; larger is better) and the
true tracking error at capture [m] (met when below the tolerance, 1 m)."""

REVERSE_CHECKPOINTS = 2048
"""Default checkpoint count of reverse-mode design gradients (module docstring, "Gradients")."""
TAIL_CRITERIA = ("z_max", "a_max", "sigma_max", "worst", "capture_margin", "tracking_error")
GRADIENT_MODES = ("forward", "reverse")
PHASES = ("passive", "full")
# the five non-state uncertain parameters of Table 2 that a phase="full" case needs besides its
# terminal-guidance state (wind, gust, motor delay, measurement noise)
CONDITIONS = ("wind_angle_deg", "wind_speed_m_s", "gust_intensity", "motor_delay_s", "noise_rms_m")


def profile_names(knots: int) -> tuple:
    """The design variables ``("b0", ..., "b{knots-1}")`` of a brake profile with ``knots`` factors."""
    _check_count("knots", knots, 2, f" (brake-profile knots, at most {MAX_PROFILE_KNOTS})")
    if knots > MAX_PROFILE_KNOTS:
        raise ValueError(f"knots must be at most {MAX_PROFILE_KNOTS} (brake-profile knots), got {knots}")
    return tuple(f"b{k}" for k in range(knots))


def _profile_indices(names) -> list:
    """Positions in ``names`` of ``b0, b1, ...`` in knot order; an error unless they are ``b0 ..
    b{K-1}`` with K >= 2 (or none)."""
    knots = sorted(int(n[1:]) for n in names if n in DESIGN_VARIABLES and n.startswith("b"))
    if not knots:
        return []
    if knots != list(range(len(knots))) or len(knots) < 2:
        raise ValueError(
            f"brake-profile variables must be b0 .. b(K-1) with K >= 2 (no gaps), got {[f'b{k}' for k in knots]}"
        )
    return [list(names).index(f"b{k}") for k in knots]


def _expand_profile_tokens(names):
    """``"profile:K"`` in a list of names -> ``b0 .. b{K-1}`` (the command line's shorthand)."""
    out = []
    for n in names:
        if n.startswith("profile:"):
            try:
                k = int(n.split(":", 1)[1])
            except ValueError:
                raise ValueError(f"design variable {n!r}: write profile:K with K the number of knots, e.g. profile:8") from None
            out.extend(profile_names(k))
        else:
            out.append(n)
    return out






# ------------------------------------------------------------------------------------------------
# Design space and reparametrisation
# ------------------------------------------------------------------------------------------------


class DesignSpace(eqx.Module):
    """The chosen design variables, their bounds, and the scaled-logistic reparametrisation.

    ``x = lower + (upper - lower) * sigmoid(u)`` maps any ``u`` in R^k into the open box; the
    optimisers work in ``u``. Build one with :meth:`from_names`. The space is generic: ``catalogue``
    names the variables one may choose (the buffer design's ``DESIGN_VARIABLES`` by default; the
    line-throwing design of :mod:`jaxcable.throw.design` passes its own).
    """

    names: tuple = eqx.field(static=True)
    """names of the variables, a subset of ``catalogue`` in the user's order"""
    lower: jax.Array = eqx.field(converter=_float_array)
    """lower bound of each variable, in its unit (kg, N, 1/s, ...), shape (k,)"""
    upper: jax.Array = eqx.field(converter=_float_array)
    """upper bound of each variable, in its unit, shape (k,)"""
    catalogue: tuple = eqx.field(static=True, default=tuple(DESIGN_VARIABLES))
    """the names one may choose"""

    def __check_init__(self):
        if len(self.names) == 0:
            raise ValueError("names must name at least one design variable, got none")
        for name in self.names:
            check_choice("design variable", name, self.catalogue)
        if len(set(self.names)) != len(self.names):
            raise ValueError(f"names has a repeated design variable: {self.names}")
        k = len(self.names)
        if self.lower.shape != (k,) or self.upper.shape != (k,):
            raise ValueError(
                f"lower and upper must have shape ({k},) for names {self.names}, "
                f"got {self.lower.shape} and {self.upper.shape}"
            )
        lo, hi = _concrete(self.lower), _concrete(self.upper)
        if lo is None or hi is None:
            return
        for i, name in enumerate(self.names):
            check_finite(f"lower bound of {name}", lo[i])
            check_finite(f"upper bound of {name}", hi[i])
            if not lo[i] < hi[i]:
                raise ValueError(
                    f"bounds of {name} are inverted or empty: lower = {lo[i]:g} must be < upper = {hi[i]:g}"
                )
            # every variable of both catalogues is a positive physical quantity; a brake may be off
            if name == "F_f":
                check_positive("lower bound of F_f [N]", lo[i], allow_zero=True)
            else:
                check_positive(f"lower bound of {name}", lo[i])

    @classmethod
    def from_names(cls, names, bounds: dict | None = None, *, variables=None, default_bounds=None) -> "DesignSpace":
        """``names``: a sequence or a comma-separated string (``"m_w,F_f"``); ``bounds``:
        ``{name: (lower, upper)}`` overriding the default bounds for some names. ``variables`` and
        ``default_bounds``: the catalogue and its bounds (default ``DESIGN_VARIABLES``,
        ``DEFAULT_BOUNDS``)."""
        variables = DESIGN_VARIABLES if variables is None else variables
        default_bounds = DEFAULT_BOUNDS if default_bounds is None else default_bounds
        if isinstance(names, str):
            names = [n.strip() for n in names.split(",") if n.strip()]
        names = tuple(_expand_profile_tokens(names) if "b0" in variables else names)
        bounds = {} if bounds is None else dict(bounds)
        for name in bounds:
            check_choice("design variable in bounds", name, variables)
        for name in names:
            check_choice("design variable", name, variables)
        lo = [float(bounds.get(n, default_bounds[n])[0]) for n in names]
        hi = [float(bounds.get(n, default_bounds[n])[1]) for n in names]
        return cls(names=names, lower=np.array(lo), upper=np.array(hi), catalogue=tuple(variables))

    @property
    def size(self) -> int:
        return len(self.names)

    def to_physical(self, u) -> jax.Array:
        """Unconstrained ``u`` (k,) -> design ``x`` (k,) in the bounds, in each variable's unit."""
        return self.lower + (self.upper - self.lower) * jax.nn.sigmoid(u)

    def to_unconstrained(self, x) -> jax.Array:
        """Design ``x`` (k,) strictly inside the bounds -> ``u`` (k,) (the inverse of
        :meth:`to_physical`). Concrete values outside the open box raise an error naming the variable."""
        x = jnp.asarray(x, dtype=float)
        self.check_design(x)
        p = (x - self.lower) / (self.upper - self.lower)
        return jnp.log(p) - jnp.log1p(-p)

    def check_design(self, x):
        """Raise a clear error if a concrete design is not (k,) and strictly inside the bounds."""
        xv, lo, hi = _concrete(x), _concrete(self.lower), _concrete(self.upper)
        if xv is None or lo is None or hi is None:
            return
        if xv.shape != (self.size,):
            raise ValueError(f"a design for {self.names} must have shape ({self.size},), got {xv.shape}")
        for i, name in enumerate(self.names):
            check_range(name, float(xv[i]), float(lo[i]), float(hi[i]))

    def as_dict(self, x) -> dict:
        """``{name: float}`` of a concrete design."""
        return {n: float(v) for n, v in zip(self.names, np.asarray(x, dtype=float))}

    def from_dict(self, values: dict) -> jax.Array:
        """A design (k,) from ``{name: value}`` naming every variable of the space."""
        missing = [n for n in self.names if n not in values]
        if missing:
            raise ValueError(f"design values lack {missing} (space: {self.names})")
        extra = [n for n in values if n not in self.names]
        if extra:
            raise ValueError(f"design values name {extra}, which are not in the space {self.names}")
        x = jnp.asarray([float(values[n]) for n in self.names])
        self.check_design(x)
        return x


# ------------------------------------------------------------------------------------------------
# Tail risk
# ------------------------------------------------------------------------------------------------


def _check_alpha(alpha):
    a = _concrete(alpha)
    if a is not None and not (0.0 <= float(a) < 1.0):
        raise ValueError(f"alpha must be in [0, 1), got {alpha!r}")


def cvar(values, alpha) -> jax.Array:
    """Exact conditional value at risk of an empirical distribution (equal weights): the mean of
    the worst ``(1 - alpha)`` fraction of ``values`` (n,), with the boundary sample weighted by the
    fractional part of ``k = n (1 - alpha)``. ``alpha`` in [0, 1): 0 gives the mean, values near 1
    the maximum. Equal to Rockafellar-Uryasev's ``min_t t + E[(X - t)_+] / (1 - alpha)``.
    Continuous and piecewise linear in ``values`` (differentiable almost everywhere through the sort).
    """
    _check_alpha(alpha)
    values = jnp.asarray(values)
    n = values.shape[0]
    k = n * (1.0 - alpha)
    desc = -jnp.sort(-values)
    # weight of the i-th largest sample: min(1, max(0, k - i)), summing to k
    weights = jnp.clip(k - jnp.arange(n), 0.0, 1.0)
    return jnp.sum(weights * desc) / k


def smooth_cvar(values, alpha, width) -> jax.Array:
    """Sort-free smooth CVaR: ``min_t t + E[width softplus((X - t) / width)] / (1 - alpha)``.

    The softplus replaces the hinge of Rockafellar-Uryasev's formula, so the result lies in
    ``[cvar, cvar + width log 2 / (1 - alpha)]`` (softplus >= hinge, and exceeds it by at most
    ``log 2``). The minimiser ``t*`` solves ``E[sigmoid((X - t*) / width)] = 1 - alpha``, a monotone
    equation solved by bisection; the gradient w.r.t. ``values`` is
    ``sigmoid((X - t*) / width) / (n (1 - alpha))`` by the envelope theorem (``d/dt = 0`` at
    ``t*``), so ``t*`` is held fixed (``stop_gradient``) and the bisection is not differentiated.
    ``values`` (n,), ``alpha`` in [0, 1), ``width`` > 0 in the units of ``values``.
    """
    _check_alpha(alpha)
    check_positive("width", width)
    values = jnp.asarray(values)
    x = jax.lax.stop_gradient(values)
    target = 1.0 - alpha

    def excess(t):
        return jnp.mean(jax.nn.sigmoid((x - t) / width)) - target

    # bracket: 40 widths beyond the extremes, where every sigmoid is within 4e-18 of 0 or 1
    lo = jnp.min(x) - 40.0 * width
    hi = jnp.max(x) + 40.0 * width

    def body(_, bracket):
        a, b = bracket
        m = 0.5 * (a + b)
        above = excess(m) > 0.0  # root is to the right of m
        return jnp.where(above, m, a), jnp.where(above, b, m)

    # 80 halvings: (hi - lo) 2^-80 is far below float64 resolution of t
    a, b = jax.lax.fori_loop(0, 80, body, (lo, hi))
    t = jax.lax.stop_gradient(0.5 * (a + b))
    return t + jnp.mean(width * jax.nn.softplus((values - t) / width)) / target


# ------------------------------------------------------------------------------------------------
# Objective weights and the problem
# ------------------------------------------------------------------------------------------------


class ObjectiveWeights(eqx.Module):
    """Weights and shape parameters of the objective (module docstring). Arrays: sweepable and
    differentiable. The (3,) arrays follow ``CRITERIA`` = (z_max, a_max, sigma_max)."""

    expected: jax.Array = eqx.field(converter=_float_array, default=1.0)
    """weight of the expected cost [-], shape ()"""
    criteria: jax.Array = eqx.field(converter=_float_array, default=(1.0 / 3, 1.0 / 3, 1.0 / 3))
    """weights of the normalised criteria inside the expected cost [-], shape (3,)"""
    tail: jax.Array = eqx.field(converter=_float_array, default=1.0)
    """weight of the tail risk (CVaR) [-], shape ()"""
    alpha: jax.Array = eqx.field(converter=_float_array, default=0.75)
    """CVaR level: the tail is the worst (1 - alpha) fraction of the batch [-], shape (), in [0, 1)"""
    tail_width: jax.Array = eqx.field(converter=_float_array, default=0.01)
    """softplus width of :func:`smooth_cvar`, in normalised criterion units (0.01 = 1 % of a
    limit) [-], shape ()"""
    penalty: jax.Array = eqx.field(converter=_float_array, default=(100.0, 100.0, 100.0))
    """weights of the squared violation penalties [-], shape (3,). 100: a 10 % violation in every
    case costs 1, as much as the whole expected cost at the limits, so violations dominate (with 10,
    the optimiser traded a 19 % stroke violation for lower decelerations; bench_design.md)"""
    margin: jax.Array = eqx.field(converter=_float_array, default=0.0)
    """fractional margin the penalties demand below each limit (0.02: r < 0.98) [-], shape ()"""
    capture_criteria: jax.Array = eqx.field(converter=_float_array, default=(0.25, 0.25))
    """weights of the normalised tracking-phase criteria (``CAPTURE_CRITERIA``: capture margin,
    tracking error) inside the expected cost [-], shape (2,); used by ``phase="full"`` problems only.
    A quarter each: together they weigh half as much as the three passive criteria (which sum to 1),
    so a design is not bought with a worse arrest, yet the gain a_p (which acts on the passive
    criteria only through the captured state) has a term of its own"""
    capture_penalty: jax.Array = eqx.field(converter=_float_array, default=(100.0, 100.0))
    """weights of the squared violation penalties of the tracking-phase criteria [-], shape (2,)
    (``phase="full"`` only): as ``penalty``: a miss is a failed landing"""
    design_cost: jax.Array | None = None
    """weight of each variable's ``x_k / upper_k`` in the design cost [-], shape (k,); None: 0"""
    tail_criterion: str = eqx.field(static=True, default="a_max")
    """which normalised criterion the CVaR is taken of: z_max, a_max, sigma_max or worst"""
    tail_form: str = eqx.field(static=True, default="smooth")
    """``smooth`` (:func:`smooth_cvar`) or ``exact`` (:func:`cvar`)"""

    def __check_init__(self):
        check_choice("tail_criterion", self.tail_criterion, TAIL_CRITERIA)
        check_choice("tail_form", self.tail_form, ("smooth", "exact"))
        for name in ("expected", "tail", "margin"):
            check_positive(name, getattr(self, name), allow_zero=True)
        for name in ("criteria", "penalty"):
            v = getattr(self, name)
            if v.shape != (3,):
                raise ValueError(f"{name} must have shape (3,) (z, a, sigma), got {v.shape}")
            check_positive(name, v, allow_zero=True)
        for name in ("capture_criteria", "capture_penalty"):
            v = getattr(self, name)
            if v.shape != (2,):
                raise ValueError(f"{name} must have shape (2,) (capture margin, tracking error), got {v.shape}")
            check_positive(name, v, allow_zero=True)
        check_positive("tail_width", self.tail_width)
        _check_alpha(self.alpha)
        if self.design_cost is not None:
            check_positive("design_cost", self.design_cost, allow_zero=True)


class DesignProblem(eqx.Module):
    """Everything the objective depends on except the design: the variables and bounds, the fixed
    QMC batch of cases, the fixed parts of the scene, the limits, widths, weights and the solver
    settings. Build one with :func:`design_problem`.

    ``phase="passive"``: each case is a captured state (Table 8) and runs the passive scene at
    ``fidelity``. ``phase="full"``: each case is a terminal-guidance state (Table 3) with its wind,
    gust, motor delay and noise (``conditions``, Table 4) and runs the two-phase landing of
    :func:`jaxcable.arresting.two_phase.two_phase_outputs` (tracking with the rigid rocket, then the
    passive phase at level ``rigid``); the capture margin and the tracking error join the criteria."""

    space: DesignSpace
    captures: CaptureState
    """the batch: every field an array of shape (n,); captured states (passive) or terminal-guidance
    states (full: their ``z_m`` and ``vz_m_s`` are replaced by the scenario's ``h`` and ``-h / t_c``)"""
    buffer: BufferDevice
    """fields not designed (transfer rate, brake smoothing width) and the defaults of the rest"""
    layout: ArrestingLayout
    weights: ObjectiveWeights = ObjectiveWeights()
    limits: LandingCriteria = LandingCriteria()
    widths: SmoothingWidths = SmoothingWidths()
    conditions: dict | None = None
    """``phase="full"``: ``{name: (n,) array}`` for the five names of ``CONDITIONS`` (wind angle
    [deg], steady wind speed [m/s], gust intensity [-], motor delay [s], noise RMS [m]); None for
    ``phase="passive"``"""
    gain_per_s: jax.Array = eqx.field(converter=_float_array, default=2.0)
    """PD gain a_p [1/s] used when ``a_p`` is not a design variable (``phase="full"``), shape ()"""
    tracking_tolerance_m: jax.Array = eqx.field(converter=_float_array, default=1.0)
    """limit of the tracking error at capture [m] (two_phase.py's reading of "approaches zero"), shape ()"""
    capture_reference_m: jax.Array = eqx.field(converter=_float_array, default=1.0)
    """capture margin of a centred, vertical capture [m] (the throat's half-width less the
    clearance; :func:`design_problem` computes it from the hook geometry), shape (): the capture
    criterion is normalised as ``r = 1 - margin / capture_reference_m`` (0: centred, 1: the edge)"""
    margin_width_m: jax.Array = eqx.field(converter=_float_array, default=0.02)
    """width of the soft minimum over the four hooks' capture margins [m], shape ()"""
    cable_damping_s: float = eqx.field(static=True, default=DEFAULT_CABLE_DAMPING_S)
    """The cables' stiffness-proportional damping beta [s] in the passive phase (the paper gives no
    value; 1e-5 is the scenes' default, chosen for the ALE level's step cost). a_max depends strongly
    on it: the cable-counterweight mode rings with beta = 1e-5 (README, sensitivity table)."""
    passive_air: bool = eqx.field(static=True, default=True)
    """``phase="full"``: the passive phase keeps the tracking phase's wind and the rocket's
    aerodynamics after capture (two_phase.py's default); False: still air after capture"""
    fidelity: str = eqx.field(static=True, default="rigid")
    phase: str = eqx.field(static=True, default="passive")
    scenario: str = eqx.field(static=True, default="I")
    """Table 4 scenario (``phase="full"``: h, t_c and the default a_p)"""
    seed: int = eqx.field(static=True, default=0)
    """seed of the per-case noise and gust keys (``phase="full"``; as in the two-phase sweeps)"""
    t_end_s: float = eqx.field(static=True, default=1.2)
    """simulated time after capture [s]: covers the stop (~0.75 s centrally) and the first rebound"""
    rtol: float = eqx.field(static=True, default=1e-6)
    atol: float = eqx.field(static=True, default=1e-6)
    max_steps: int = eqx.field(static=True, default=50_000)
    gradient: str = eqx.field(static=True, default="forward")
    """``forward`` (ForwardMode + jacfwd) or ``reverse`` (RecursiveCheckpointAdjoint + grad)"""
    checkpoints: int | None = eqx.field(static=True, default=None)
    """checkpoints of RecursiveCheckpointAdjoint in reverse mode (None: ``REVERSE_CHECKPOINTS``)"""
    chunk: int | str | None = eqx.field(static=True, default="auto")
    """most cases per vmapped call inside the objective: the batch runs as ``lax.map`` over as few
    equal chunks of at most this many cases as that allows (padded with copies of the last case,
    whose outputs are dropped, to less than one case per chunk).
    ``"auto"``: on the CPU ``AUTO_CHUNK`` (forward value and reverse mode 32, forward mode 16; a
    vmapped solve's cost per case grows with the batch beyond these on the CPU: at n = 64 the
    forward call runs 1.28x, the forward-mode gradient 1.11x and reverse mode 1.17x faster; ``python
    experiments/bench_design.py --sections chunk``), elsewhere the whole batch in one vmap.
    ``None``: the whole batch. Results agree with the unchunked batch to the integration
    tolerance (vectorised round-off differs with the batch's shape)."""
    scenes: eqx.Module | None = None
    """``fidelity`` ale or full (phase passive): the batch's passive scenes, built on the host by
    :func:`design_problem` (their cable meshes need the concrete captured state) and stacked along
    a leading axis (n,); the objective swaps the design's buffer into them. None at level rigid,
    whose scenes are built inside the traced objective."""

    def __check_init__(self):
        check_choice("fidelity", self.fidelity, tuple(k for k in FIDELITY_LEVELS if k != "1dof"))
        check_choice("phase", self.phase, PHASES)
        check_choice("gradient", self.gradient, GRADIENT_MODES)
        if self.checkpoints is not None:
            _check_count("checkpoints", self.checkpoints, 1, " or None")
        if self.chunk is not None and self.chunk != "auto":
            _check_count("chunk", self.chunk, 1, ", 'auto' or None")
        check_choice("scenario", self.scenario, ("I", "II", "III"))
        check_positive("t_end_s", self.t_end_s)
        check_positive("rtol", self.rtol)
        check_positive("atol", self.atol)
        check_positive("gain_per_s", self.gain_per_s)
        check_positive("tracking_tolerance_m", self.tracking_tolerance_m)
        check_positive("capture_reference_m", self.capture_reference_m)
        check_positive("margin_width_m", self.margin_width_m)
        _profile_indices(self.space.names)
        for name in self.space.names:
            check_choice("design variable", name, DESIGN_VARIABLES)
            needs = DESIGN_VARIABLES[name][1]
            if needs == "full" and self.phase != "full":
                raise ValueError(
                    f"design variable {name!r} ({DESIGN_VARIABLES[name][0]}) acts in the active-tracking "
                    f"phase: it needs phase='full' (the two-phase scene); got phase={self.phase!r}"
                )
        if self.phase == "full":
            if self.fidelity != "rigid":
                raise ValueError(
                    f"fidelity {self.fidelity!r}: phase='full' design runs at fidelity 'rigid' (the ale/full "
                    "levels mesh their cables on the host from the captured state, outside the traced objective)"
                )
            if self.conditions is None or set(self.conditions) != set(CONDITIONS):
                got = None if self.conditions is None else sorted(self.conditions)
                raise ValueError(f"phase='full' needs conditions with the entries {list(CONDITIONS)}, got {got}")
        elif self.conditions is not None:
            raise ValueError("conditions (wind, delay, noise per case) belong to phase='full'; got them with phase='passive'")
        elif self.fidelity != "rigid" and self.scenes is None:
            raise ValueError(
                f"fidelity {self.fidelity!r} needs the batch's scenes built on the host (scenes=None): build the "
                "problem with design_problem(..., fidelity=...), which meshes each case's cables"
            )
        if self.weights.design_cost is not None and self.weights.design_cost.shape != (self.space.size,):
            raise ValueError(
                f"weights.design_cost must have shape ({self.space.size},) for {self.space.names}, "
                f"got {self.weights.design_cost.shape}"
            )
        if self.phase != "full" and self.weights.tail_criterion in ("capture_margin", "tracking_error"):
            raise ValueError(
                f"weights.tail_criterion {self.weights.tail_criterion!r} is a tracking-phase criterion: it needs phase='full'"
            )

    @property
    def n_cases(self) -> int:
        return int(self.captures.x_m.shape[0])

    @property
    def criteria_names(self) -> tuple:
        """The criteria this problem reports: ``CRITERIA`` (+ ``CAPTURE_CRITERIA`` for phase full)."""
        return CRITERIA + (CAPTURE_CRITERIA if self.phase == "full" else ())


def default_phase(variables) -> str:
    """The phase a set of design variables needs: ``full`` when one of them acts in the tracking
    phase (``a_p``), else ``passive``."""
    names = DesignSpace.from_names(variables).names
    return "full" if any(DESIGN_VARIABLES[n][1] == "full" for n in names) else "passive"


def capture_reference(layout: ArrestingLayout | None = None) -> float:
    """Capture margin [m] of a centred, vertical rocket with the frame at rest at the centre: the
    smallest of the four hooks' margins of :meth:`TrackingScene.capture_margins` at t = 0 (the
    horizontal geometry does not depend on the height)."""
    from jaxcable.arresting.two_phase import tracking_scene

    if layout is None and _CAPTURE_REFERENCE:  # building the scene eagerly takes seconds: memo
        return _CAPTURE_REFERENCE[0]
    scene = tracking_scene(CaptureState(), layout=layout, wind_speed_m_s=0.0, noise_rms_m=0.0)
    value = float(jnp.min(scene.capture_margins(scene.initial_state())))
    if layout is None:
        _CAPTURE_REFERENCE.append(value)
    return value


_CAPTURE_REFERENCE = []  # the default layout's capture reference, once computed


def design_problem(
    variables="m_w,F_f",
    n: int = 64,
    scenario: str = "I",
    fidelity: str = "rigid",
    seed: int = 0,
    *,
    bounds: dict | None = None,
    weights: ObjectiveWeights | None = None,
    phase: str | None = None,
    buffer: BufferDevice | None = None,
    layout: ArrestingLayout | None = None,
    **settings,
) -> DesignProblem:
    """A design problem over ``n`` Halton cases of ``scenario``, deterministic for ``seed``
    (:func:`jaxcable.arresting.uncertainty.halton_samples`).

    ``phase``: ``"passive"`` (Table 8 captured states, passive scene at ``fidelity``), ``"full"``
    (Table 3 terminal-guidance states with Table 4 wind, delay and noise; two-phase landing at level
    rigid) or None (default): ``"full"`` when ``a_p`` is a design variable, else ``"passive"``
    (:func:`default_phase`). ``settings`` go to :class:`DesignProblem` (``t_end_s``, ``rtol``,
    ``gradient``, ``gain_per_s``, ...)."""
    from jaxcable.arresting.uncertainty import captures_from_samples, halton_samples, scenario_settings

    space = DesignSpace.from_names(variables, bounds)
    _check_count("n", n, 1, " (captures in the batch)")
    phase = default_phase(space.names) if phase is None else phase
    check_choice("phase", phase, PHASES)
    for name in space.names:  # the clear a_p / phase error before any sampling
        if DESIGN_VARIABLES[name][1] == "full" and phase != "full":
            raise ValueError(
                f"design variable {name!r} ({DESIGN_VARIABLES[name][0]}) acts in the active-tracking phase: "
                f"it needs phase='full' (the two-phase scene); got phase={phase!r}"
            )
    if phase == "full":  # the clear errors before the (slow, eager) capture reference
        if fidelity != "rigid":
            raise ValueError(f"fidelity {fidelity!r}: phase='full' design runs at fidelity 'rigid'")
    samples = halton_samples(int(n), scenario=scenario, phase=phase, seed=seed)
    captures = captures_from_samples(samples)
    if phase == "full":
        layout_given = layout is not None
        layout = ArrestingLayout() if layout is None else layout
        settings.setdefault("conditions", {k: jnp.asarray(samples[k]) for k in CONDITIONS})
        settings.setdefault("gain_per_s", scenario_settings(scenario)["a_p"])
        settings.setdefault("capture_reference_m", capture_reference(layout if layout_given else None))
    if fidelity in LEVEL_DEFAULTS:  # the level's measured tolerances unless given
        settings.setdefault("rtol", LEVEL_DEFAULTS[fidelity][1])
        settings.setdefault("atol", settings["rtol"])
    buffer = BufferDevice() if buffer is None else buffer
    layout = ArrestingLayout() if layout is None else layout
    if phase == "passive" and fidelity != "rigid" and settings.get("scenes") is None:
        settings["scenes"] = _host_built_scenes(
            fidelity, captures, layout, buffer, settings.get("t_end_s", DesignProblem.t_end_s),
            settings.get("cable_damping_s", DEFAULT_CABLE_DAMPING_S),
        )  # fmt: skip
    return DesignProblem(
        space=space,
        captures=captures,
        buffer=buffer,
        layout=layout,
        weights=ObjectiveWeights() if weights is None else weights,
        fidelity=fidelity,
        phase=phase,
        scenario=scenario,
        seed=int(seed),
        **settings,
    )


def paper_start(problem: DesignProblem) -> jax.Array:
    """The paper's section II.B design as a point of ``problem.space``: ``m_w``, ``F_f`` of
    :func:`jaxcable.arresting.one_dof.paper_design` (m_t_bar = 2, F_t_bar of eq 19; 1388.9 kg,
    3.0886e5 N), ``a_p`` of Table 4 for the problem's scenario (``problem.gain_per_s``) and brake-profile
    factors of 1 (the constant brake); a variable other than those takes the middle of its bounds.
    What is not a design variable keeps ``problem.buffer``'s value: with ``--vars m_w,profile:K`` the
    brake's F_f is Table 1's 3.13e5 N (the default ``BufferDevice``), not eq 19's 3.0886e5 N."""
    from jaxcable.arresting.one_dof import paper_design

    p = paper_design()
    # a_p: Table 4's gain of the problem's scenario (2, 5, 6 1/s for I, II, III)
    known = {"m_w": float(p.m_w), "F_f": float(p.F_f), "a_p": float(problem.gain_per_s)}
    known.update({f"b{k}": 1.0 for k in range(MAX_PROFILE_KNOTS)})  # the paper's constant brake
    sp = problem.space
    mid = 0.5 * (np.asarray(sp.lower) + np.asarray(sp.upper))
    return sp.from_dict({n: known.get(n, float(mid[i])) for i, n in enumerate(sp.names)})


# ------------------------------------------------------------------------------------------------
# Simulation of the batch and the objective
# ------------------------------------------------------------------------------------------------

# How each design variable enters the buffer devices; ``a_p`` enters the controller of the
# two-phase scene (:func:`_gain`).
_PASSIVE_SETTERS = {
    "m_w": lambda buffer, v: eqx.tree_at(lambda b: b.counterweight_mass_kg, buffer, v),
    "F_f": lambda buffer, v: eqx.tree_at(lambda b: b.brake_force_N, buffer, v),
}


def _buffer(problem: DesignProblem, x):
    buffer = problem.buffer
    for i, name in enumerate(problem.space.names):
        if name in _PASSIVE_SETTERS:
            buffer = _PASSIVE_SETTERS[name](buffer, x[i])
    knots = _profile_indices(problem.space.names)
    if knots:
        profile = x[jnp.asarray(knots)]
        buffer = eqx.tree_at(lambda b: b.brake_profile, buffer, profile, is_leaf=lambda v: v is None)
    return buffer


def _gain(problem: DesignProblem, x):
    names = problem.space.names
    return x[names.index("a_p")] if "a_p" in names else problem.gain_per_s


def _scene(problem: DesignProblem, capture: CaptureState, x):
    return passive_landing_scene(
        problem.fidelity, capture, problem.layout, _buffer(problem, x), t_end_s=problem.t_end_s,
        cable_damping_s=problem.cable_damping_s,
    )  # fmt: skip


def _host_built_scenes(fidelity, captures: CaptureState, layout, buffer, t_end_s, cable_damping_s):
    """The passive scenes of a batch of concrete captures at level ale or full, stacked (n, ...)."""
    from jaxcable.studies.sweep import _stack_cases

    n = int(np.shape(captures.x_m)[0])
    one = lambda j: jax.tree_util.tree_map(lambda v: v[j], captures)  # noqa: E731
    return _stack_cases([
        passive_landing_scene(fidelity, one(j), layout, buffer, t_end_s=t_end_s, cable_damping_s=cable_damping_s)
        for j in range(n)
    ])  # fmt: skip


def _with_buffer(scene, buffer: BufferDevice):
    """``scene`` with ``buffer`` in its cables: the massless cables hold one buffer, the ALE cables'
    four subsystems a stacked one (leading axis 4). The mesh does not depend on the buffer."""
    if isinstance(scene.cables, AleCables):
        stacked = jax.tree_util.tree_map(lambda v: jnp.broadcast_to(v, (4,) + jnp.shape(v)), buffer)
        return eqx.tree_at(lambda s: s.cables.subsystems.buffer, scene, stacked)
    return eqx.tree_at(lambda s: s.cables.buffer, scene, buffer)


def _one_case(problem: DesignProblem, scene, adjoint):
    """One built scene: smooth and hard criteria, solver status and steps (scalars), with the
    level's solver and step-size control (``LEVEL_DEFAULTS``, ``LEVEL_STEP_CONTROL``)."""
    from jaxcable.core.simulate import simulate

    pcoeff, icoeff = LEVEL_STEP_CONTROL[problem.fidelity]
    res = simulate(
        scene,
        problem.t_end_s,
        solver=LEVEL_DEFAULTS[problem.fidelity][0],
        rtol=problem.rtol,
        atol=problem.atol,
        max_steps=problem.max_steps,
        adjoint=adjoint,
        pcoeff=pcoeff,
        icoeff=icoeff,
    )
    smooth = smooth_landing_outputs(res.ts, res.probes, problem.widths)
    hard = {k: res.outputs[k] for k in CRITERIA}
    out = dict(smooth=smooth, hard=hard, status=res.status, num_steps=res.num_steps)
    m = getattr(scene.cables, "contact_tangent_pairs", None)
    if m is not None and "contact_pairs_touching" in res.probes:
        # ale/full: the contact's derivative is exact while at most m pairs touch (checked on the
        # saved samples; AleCables.contact_tangent_pairs)
        touching = jnp.where(jnp.isfinite(res.ts), jax.lax.stop_gradient(res.probes["contact_pairs_touching"]), 0.0)
        out["contact_tangent_exact"] = jnp.max(touching) <= m
    return out


def _one_two_phase_case(problem: DesignProblem, terminal, conditions, x, adjoint):
    """One two-phase landing (phase full): tracking from the terminal-guidance state under the
    case's wind, gust, delay and noise, the capture event, then the passive phase (level rigid).

    The scene is built by the sweeps' :class:`TwoPhaseCaseFunction` (same per-case noise and gust
    keys as ``jaxcable sweep --phase full``). Criteria: the passive three (soft maxima with
    ``problem.widths``) and the tracking two: the capture margin (hard: the smallest of the four
    hooks'; smooth: their soft minimum, width ``margin_width_m``) and the *true* tracking error at
    capture, ``|frame centre - target of the true rocket state|`` at the event (continuous in the
    design: no noise sample and no save-grid index enters it), hard = smooth."""
    from jaxcable.arresting.two_phase import TwoPhaseCaseFunction, _event_occurred, two_phase_outputs
    from jaxcable.arresting.uncertainty import UNCERTAIN_PARAMETERS

    buffer = _buffer(problem, x)
    case_fn = TwoPhaseCaseFunction(
        buffer=buffer, layout=problem.layout, gain_per_s=_gain(problem, x), scenario=problem.scenario,
        seed=problem.seed, t_end_s=problem.t_end_s,
    )  # fmt: skip
    params = {k: getattr(terminal, k) for k in UNCERTAIN_PARAMETERS[:10]} | dict(conditions)
    scene = case_fn.scene(params)
    out = two_phase_outputs(
        scene, "rigid", buffer, passive_t_end_s=problem.t_end_s, tracking_tolerance_m=problem.tracking_tolerance_m,
        margin_width_m=problem.margin_width_m, criteria=problem.limits, keep_histories=True, adjoint=adjoint,
        solver_settings={"rigid": ("tsit5", problem.rtol, problem.atol, problem.max_steps)},
        passive_air=problem.passive_air, passive_kwargs=dict(cable_damping_s=problem.cable_damping_s),
    )  # fmt: skip
    land, track = out["passive"], out["tracking"]
    final = track.final_state
    x_true, _ = scene.rocket.head_and_bottom_world(final.rocket)
    from jaxcable.arresting.control import target_point

    error = jnp.linalg.norm(scene.frame_centre(final) - target_point(x_true[0], x_true[1]))
    smooth = dict(smooth_landing_outputs(land.ts, land.probes, problem.widths))
    smooth["capture_margin_m"] = out["smooth_capture_margin_m"]
    smooth["tracking_error_m"] = error
    hard = {k: out[k] for k in CRITERIA}
    hard["capture_margin_m"] = out["capture_margin_m"]
    hard["tracking_error_m"] = error
    status = jnp.where(_event_occurred(out["tracking_status"]), out["passive_status"], out["tracking_status"])
    return dict(smooth=smooth, hard=hard, status=status, num_steps=out["tracking_steps"] + out["passive_steps"])


AUTO_CHUNK = {"forward": 32, "forward_mode": 16, "reverse_mode": 32}
"""``DesignProblem.chunk = "auto"`` on the CPU: cases per vmapped call for the forward objective and
for the gradients (measured at the rigid level, n = 32 and 64: ``bench_design.py --sections chunk``).
With XLA's CPU library fusions turned off (``XLA_FLAGS=--xla_cpu_experimental_ynn_fusion_type=``)
forward mode is faster over chunks of 32 (``bench_xla_flags.py``): pass ``chunk=32`` then."""


def _chunk_size(problem: DesignProblem, adjoint) -> int | None:
    if problem.chunk != "auto":
        return problem.chunk
    if jax.default_backend() != "cpu":
        return None
    if adjoint is None:
        return AUTO_CHUNK["forward"]
    return AUTO_CHUNK["forward_mode" if isinstance(adjoint, diffrax.ForwardMode) else "reverse_mode"]


def _chunked_vmap(fn, inputs, n: int, chunk: int | None):
    """``jax.vmap(fn)(*inputs)`` over the leading axis n, run as ``lax.map`` over chunks of at most
    ``chunk`` cases when ``chunk < n``: as few chunks as that allows, of equal size, so that the
    padding (copies of the last case, outputs dropped) is less than one case per chunk (n = 20 in
    chunks of at most 16: two of 10, not 16 + 4 padded to 32)."""
    if chunk is None or chunk >= n:
        return jax.vmap(fn)(*inputs)
    n_chunks = -(-n // chunk)
    chunk = -(-n // n_chunks)
    pad = n_chunks * chunk - n

    def split(v):
        v = jnp.concatenate([v, jnp.repeat(v[-1:], pad, axis=0)]) if pad else v
        return v.reshape((n_chunks, chunk) + v.shape[1:])

    out = jax.lax.map(lambda args: jax.vmap(fn)(*args), jax.tree_util.tree_map(split, inputs))
    return jax.tree_util.tree_map(lambda v: v.reshape((n_chunks * chunk,) + v.shape[2:])[:n], out)


def _batch(problem: DesignProblem, x, adjoint):
    # one scene per case; the batch is a vmap over the cases (physics handles one case), in chunks
    # of DesignProblem.chunk cases
    n, chunk = problem.n_cases, _chunk_size(problem, adjoint)
    if problem.phase == "full":
        fn = lambda c, w: _one_two_phase_case(problem, c, w, x, adjoint)  # noqa: E731
        return _chunked_vmap(fn, (problem.captures, problem.conditions), n, chunk)
    if problem.scenes is not None:  # ale/full: meshed on the host by design_problem; swap the design in
        buffer = _buffer(problem, x)
        return _chunked_vmap(lambda sc: _one_case(problem, _with_buffer(sc, buffer), adjoint), (problem.scenes,), n, chunk)
    return _chunked_vmap(lambda c: _one_case(problem, _scene(problem, c, x), adjoint), (problem.captures,), n, chunk)


def _adjoint(problem):
    if problem.gradient == "forward":
        return diffrax.ForwardMode()
    n = REVERSE_CHECKPOINTS if problem.checkpoints is None else problem.checkpoints
    return diffrax.RecursiveCheckpointAdjoint(checkpoints=n)


def _limits(problem):
    lim = problem.limits
    return jnp.array([lim.z_max_m, lim.a_max_g, lim.sigma_max_mpa])


def _normalised(problem, criteria):
    """(n, c) normalised criteria ``r`` (met when r < 1) from a dict of (n,) arrays: the passive
    three divided by their limits (c = 3); for phase full also ``1 - capture margin / reference``
    and ``tracking error / tolerance`` (c = 5, ``problem.criteria_names``' order)."""
    r = jnp.stack([criteria[k] for k in CRITERIA], axis=1) / _limits(problem)
    if problem.phase != "full":
        return r
    capture = 1.0 - criteria["capture_margin_m"] / problem.capture_reference_m
    tracking = criteria["tracking_error_m"] / problem.tracking_tolerance_m
    return jnp.concatenate([r, capture[:, None], tracking[:, None]], axis=1)


def objective_terms(problem: DesignProblem, x, smooth) -> dict:
    """The objective's terms from the smooth criteria ``smooth`` (dict of (n,) arrays) at design
    ``x`` (k,): ``expected``, ``tail``, ``penalty``, ``design_cost`` and their weighted ``total``.
    For phase full the tracking-phase criteria enter the expected cost and the penalties with the
    weights ``capture_criteria`` and ``capture_penalty``."""
    w = problem.weights
    r = _normalised(problem, smooth)  # (n, c)
    full = problem.phase == "full"
    criteria_w = jnp.concatenate([w.criteria, w.capture_criteria]) if full else w.criteria
    penalty_w = jnp.concatenate([w.penalty, w.capture_penalty]) if full else w.penalty
    expected = jnp.mean(r @ criteria_w)
    if w.tail_criterion == "worst":
        tail_values = jnp.max(r, axis=1)
    else:  # TAIL_CRITERIA minus "worst" follows the column order of r
        tail_values = r[:, [c for c in TAIL_CRITERIA if c != "worst"].index(w.tail_criterion)]
    if w.tail_form == "smooth":
        tail = smooth_cvar(tail_values, w.alpha, w.tail_width)
    else:
        tail = cvar(tail_values, w.alpha)
    violation = jnp.maximum(r - 1.0 + w.margin, 0.0)
    penalty = jnp.sum(penalty_w * jnp.mean(violation**2, axis=0))
    if w.design_cost is None:
        design_cost = jnp.zeros(())
    else:
        design_cost = jnp.sum(w.design_cost * x / problem.space.upper)
    total = w.expected * expected + w.tail * tail + penalty + design_cost
    return dict(total=total, expected=expected, tail=tail, penalty=penalty, design_cost=design_cost)


def objective(problem: DesignProblem, u, adjoint=None):
    """The objective at unconstrained ``u`` (k,): ``(J, aux)``; ``aux`` holds ``x``, the terms, the
    per-case ``smooth`` and ``hard`` criteria (dicts of (n,) arrays), ``status`` and ``num_steps``.
    Pure (no jit): :func:`objective_value` and :func:`objective_and_grad` are the jitted forms."""
    x = problem.space.to_physical(u)
    out = _batch(problem, x, adjoint)
    terms = objective_terms(problem, x, out["smooth"])
    aux = dict(x=x, terms=terms, **out)
    return terms["total"], aux


@eqx.filter_jit
def objective_value(problem: DesignProblem, u):
    """Jitted forward objective: ``(J, aux)`` at unconstrained ``u`` (k,) (see :func:`objective`)."""
    return objective(problem, u)


@eqx.filter_jit
def objective_and_grad(problem: DesignProblem, u):
    """Jitted objective and gradient w.r.t. ``u``: ``(J, dJ/du (k,), aux)``.

    ``problem.gradient == "forward"``: ``jax.jacfwd`` with ``diffrax.ForwardMode`` (one solve
    carries the k tangents); ``"reverse"``: ``jax.grad`` with ``RecursiveCheckpointAdjoint``.
    ``dJ/dx = dJ/du / (dx/du)`` with ``dx/du = (x - lo)(hi - x) / (hi - lo)``."""
    adjoint = _adjoint(problem)
    return value_and_grad_by_mode(lambda u_: objective(problem, u_, adjoint), u, problem.gradient)


def value_and_grad_by_mode(fn, u, gradient: str):
    """``(J, dJ/du, aux)`` of ``fn(u) -> (J, aux)``: ``jax.jacfwd`` for ``gradient == "forward"``
    (the solves inside ``fn`` must use ``diffrax.ForwardMode``), else ``jax.grad``."""

    def f(u_):
        j, aux = fn(u_)
        return j, (j, aux)

    if gradient == "forward":
        grad, (j, aux) = jax.jacfwd(f, has_aux=True)(u)
    else:
        grad, (j, aux) = jax.grad(f, has_aux=True)(u)
    return j, grad, aux


@eqx.filter_jit
def batch_criteria(problem: DesignProblem, x):
    """Forward only, at a physical design ``x`` (k,): per-case ``smooth`` and ``hard`` criteria
    (dicts of (n,) arrays), ``status`` and ``num_steps`` (n,)."""
    return _batch(problem, jnp.asarray(x, dtype=float), None)


def _hard_ok(problem, aux):
    """(n, c) bool: each case's hard criteria met (``problem.criteria_names``' order)."""
    r = np.asarray(_normalised(problem, {k: np.asarray(v) for k, v in aux["hard"].items()}))
    return r < 1.0


def _worst(name, values):
    # the capture margin is a margin (larger is better): its worst case is the minimum
    return float(np.min(values)) if name == "capture_margin_m" else float(np.max(values))


def _limit_of(problem, name):
    lim = problem.limits
    return dict(
        z_max_m=lim.z_max_m, a_max_g=lim.a_max_g, sigma_max_mpa=lim.sigma_max_mpa,
        capture_margin_m=0.0, tracking_error_m=float(problem.tracking_tolerance_m),
    )[name]  # fmt: skip


def criteria_summary(problem: DesignProblem, aux) -> dict:
    """JSON-able summary of one batch evaluation (an ``aux`` of :func:`objective` or the output of
    :func:`batch_criteria`): for ``hard`` and ``smooth`` criteria the worst case and the mean, the
    worst margin (``1 - c / limit``; for the capture margin the smallest margin itself [m]);
    per-criterion and overall success rates (hard criteria); solver failures."""
    out = {}
    for kind in ("hard", "smooth"):
        d = {}
        for k in problem.criteria_names:
            v = np.asarray(aux[kind][k], dtype=float)
            worst = _worst(k, v)
            margin = worst if k == "capture_margin_m" else 1.0 - worst / _limit_of(problem, k)
            d[k] = dict(worst=worst, mean=float(np.mean(v)), margin=float(margin))
        out[kind] = d
    ok = _hard_ok(problem, aux)
    out["success_rate"] = float(np.mean(np.all(ok, axis=1)))
    out["success_rate_per_criterion"] = {k: float(np.mean(ok[:, i])) for i, k in enumerate(problem.criteria_names)}
    status = np.asarray(aux["status"])
    out["solver_failures"] = int(np.sum(status != 0))
    out["max_solver_steps"] = int(np.max(np.asarray(aux["num_steps"])))
    return out


# ------------------------------------------------------------------------------------------------
# Optimisers
# ------------------------------------------------------------------------------------------------


class DesignHistory(eqx.Module):
    """Record of an optimisation. Row ``i`` is the ``i``-th objective evaluation (adam: one per step
    plus the final point; Nelder-Mead: every function call). Arrays are NumPy."""

    method: str = eqx.field(static=True)
    names: tuple = eqx.field(static=True)
    x: np.ndarray
    """design at each evaluation, in the variables' units, shape (m, k)"""
    objective: np.ndarray
    """objective J, shape (m,)"""
    grad_norm: np.ndarray
    """|dJ/du| (NaN for derivative-free methods), shape (m,)"""
    worst_hard: np.ndarray
    """the problem's record of each evaluation, shape (m, c), columns ``criteria_names``: for the
    buffer design the worst case over the batch of the hard criteria (z_max [m], a_max [g],
    sigma_max [MPa]; phase full adds the smallest capture margin [m] and the largest tracking
    error [m]); for the line-throwing design its outputs (:mod:`jaxcable.throw.design`)"""
    success_rate: np.ndarray
    """fraction of cases meeting every hard criterion (1 or 0 for a single-case problem), shape (m,)"""
    wall_s: np.ndarray
    """wall time since the start at the end of each evaluation [s] (includes compiling if the
    jitted function was not warm), shape (m,)"""
    criteria_names: tuple = eqx.field(static=True, default=CRITERIA)
    """names of the columns of ``worst_hard``"""

    @property
    def best(self) -> int:
        """Row of the lowest objective."""
        return int(np.argmin(self.objective))

    def evaluations_to_reach(self, target: float):
        """``(evaluations, wall_s)`` when the objective first reached ``<= target``; ``None`` if never."""
        hit = np.nonzero(self.objective <= target)[0]
        if hit.size == 0:
            return None
        i = int(hit[0])
        return i + 1, float(self.wall_s[i])

    def as_json(self) -> dict:
        return dict(
            method=self.method,
            names=list(self.names),
            criteria_names=list(self.criteria_names),
            x=self.x.tolist(),
            objective=self.objective.tolist(),
            grad_norm=[None if not np.isfinite(g) else float(g) for g in self.grad_norm],
            worst_hard=self.worst_hard.tolist(),
            success_rate=self.success_rate.tolist(),
            wall_s=self.wall_s.tolist(),
        )


def _record(problem):
    """``aux -> (worst hard criteria (c,), success rate)`` of a buffer design problem."""

    def record(aux):
        worst = [_worst(k, np.asarray(aux["hard"][k])) for k in problem.criteria_names]
        return worst, float(np.mean(np.all(_hard_ok(problem, aux), axis=1)))

    return record


def _check_count(name, value, minimum, what=""):
    """``value`` must be an integer (not a bool) >= ``minimum`` (0 or 1); the error names ``name``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < minimum:
        kind = "positive" if minimum == 1 else "non-negative"
        raise ValueError(f"{name} must be a {kind} integer{what}, got {value!r}")


class _Rows:
    """The rows of a :class:`DesignHistory` as the optimisers evaluate: one :meth:`add` per
    objective evaluation (wall time since construction), :meth:`history` at the end."""

    def __init__(self, record, criteria_names):
        self.record, self.criteria_names = record, tuple(criteria_names)
        self.cols = dict(x=[], objective=[], grad_norm=[], worst_hard=[], success_rate=[], wall_s=[])
        self.t0 = time.perf_counter()

    def __len__(self):
        return len(self.cols["objective"])

    def add(self, j: float, grad_norm: float, aux):
        worst, success = self.record(aux) if self.record is not None else ([np.nan] * len(self.criteria_names), np.nan)
        if "contact_tangent_exact" in aux and not bool(np.all(np.asarray(aux["contact_tangent_exact"]))):
            warnings.warn(
                "more hook-cable contact pairs touched than AleCables.contact_tangent_pairs carries "
                "tangents for, in some case of this evaluation: its gradient misses those pairs; "
                "rebuild the scenes with a larger contact_tangent_pairs (or None)",
                RuntimeWarning,
                stacklevel=2,
            )
        self.cols["x"].append(np.asarray(aux["x"]))
        self.cols["objective"].append(j)
        self.cols["grad_norm"].append(grad_norm)
        self.cols["worst_hard"].append(worst)
        self.cols["success_rate"].append(success)
        self.cols["wall_s"].append(time.perf_counter() - self.t0)

    def history(self, method: str, space: DesignSpace) -> "DesignHistory":
        return DesignHistory(
            method=method,
            names=space.names,
            criteria_names=self.criteria_names,
            **{k: np.asarray(v, dtype=float) for k, v in self.cols.items()},
        )


def _check_steps(steps):
    _check_count("steps", steps, 0)


def optax_minimise(
    space: DesignSpace,
    value_and_grad,
    x0,
    steps: int = 50,
    optimizer=None,
    learning_rate: float = 0.1,
    callback=None,
    record=None,
    criteria_names: tuple = CRITERIA,
) -> DesignHistory:
    """The optax loop on the unconstrained variables of ``space``, for any objective.

    ``value_and_grad(u) -> (J, dJ/du, aux)`` (jitted; ``aux["x"]`` the physical design);
    ``record(aux) -> (criteria (c,), success)`` fills the history's ``worst_hard`` and
    ``success_rate`` (None: NaN). Default optimizer ``optax.adam(learning_rate)``; the final point
    is evaluated too, so the history has ``steps + 1`` rows; ``callback(i, J, x, aux)`` after each."""
    import optax

    _check_steps(steps)
    check_positive("learning_rate", learning_rate)
    opt = optax.adam(learning_rate) if optimizer is None else optimizer
    u = space.to_unconstrained(x0)
    state = opt.init(u)
    rows = _Rows(record, criteria_names)
    for i in range(steps + 1):
        j, g, aux = value_and_grad(u)
        j = float(j)
        g_np = np.asarray(g)
        rows.add(j, float(np.linalg.norm(g_np)), aux)
        if callback is not None:
            callback(i, j, np.asarray(aux["x"]), aux)
        if i == steps:
            break
        if not np.all(np.isfinite(g_np)) or not np.isfinite(j):
            raise FloatingPointError(f"non-finite objective or gradient at step {i}: J = {j}, dJ/du = {g_np}")
        updates, state = opt.update(g, state, u)
        u = optax.apply_updates(u, updates)
    return rows.history("adam" if optimizer is None else "optax", space)


def lbfgs_minimise(
    space: DesignSpace,
    value_and_grad,
    x0,
    max_evaluations: int = 50,
    memory_size: int = 10,
    callback=None,
    record=None,
    criteria_names: tuple = CRITERIA,
    sufficient_decrease: float = 1e-4,
) -> DesignHistory:
    """L-BFGS on the unconstrained variables of ``space``: optax's ``scale_by_lbfgs`` direction with
    a backtracking (Armijo) line search on the host, for any objective.

    Suited to the design objectives, which are smooth and deterministic (a fixed batch): where adam
    takes fixed-size, momentum-driven steps and overshoots (``experiments/results/
    bench_design_profile.md``), L-BFGS builds curvature from the gradients and steps along it. The
    line search runs on the host so that each trial is one call of the jitted ``value_and_grad``
    (an accepted trial's gradient is the next iteration's): no second compilation of the objective
    inside optax's traced line search. A direction that is not a descent direction (curvature pairs
    from a non-convex stretch) resets the memory to a gradient step. Every evaluation, accepted or
    not, is a row of the history (``max_evaluations`` rows at most), so evaluation counts compare
    with Nelder-Mead's; ``callback(i, J, x, aux)`` after each accepted point (``i`` = evaluation)."""
    import optax

    _check_count("max_evaluations", max_evaluations, 1)
    _check_count("memory_size", memory_size, 1)
    opt = optax.scale_by_lbfgs(memory_size=memory_size)
    u = space.to_unconstrained(x0)
    state = opt.init(u)
    rows = _Rows(record, criteria_names)

    def evaluate(u_):
        j, g, aux = value_and_grad(u_)
        j = float(j)
        rows.add(j, float(np.linalg.norm(np.asarray(g))), aux)
        return j, g, aux

    j, g, aux = evaluate(u)
    if not np.isfinite(j) or not np.all(np.isfinite(np.asarray(g))):
        raise FloatingPointError(f"non-finite objective or gradient at the start: J = {j}, dJ/du = {np.asarray(g)}")
    if callback is not None:
        callback(0, j, np.asarray(aux["x"]), aux)
    while len(rows) < max_evaluations:
        d, new_state = opt.update(g, state, u)
        slope = float(jnp.vdot(g, d))
        if not slope > 0.0:  # not a descent direction: restart the memory from here
            state = opt.init(u)
            d, new_state = opt.update(g, state, u)
            slope = float(jnp.vdot(g, d))
        step, accepted = 1.0, False
        while len(rows) < max_evaluations:
            u_try = u - step * d
            j_try, g_try, aux_try = evaluate(u_try)
            finite = np.isfinite(j_try) and np.all(np.isfinite(np.asarray(g_try)))
            if finite and j_try <= j - sufficient_decrease * step * slope:
                accepted = True
                break
            step *= 0.5
        if not accepted:
            break
        u, j, g, aux, state = u_try, j_try, g_try, aux_try, new_state
        if callback is not None:
            callback(len(rows) - 1, j, np.asarray(aux["x"]), aux)
    return rows.history("lbfgs", space)


def nelder_mead_minimise(
    space: DesignSpace,
    value,
    x0,
    max_evaluations: int = 100,
    initial_step: float = 0.5,
    target: float | None = None,
    record=None,
    criteria_names: tuple = CRITERIA,
) -> DesignHistory:
    """Derivative-free baseline for any objective: scipy's Nelder-Mead on the unconstrained
    variables of ``space``. ``value(u) -> (J, aux)`` (jitted forward); ``record`` as in
    :func:`optax_minimise`. The initial simplex steps each ``u`` by ``initial_step`` (scipy's
    default 5 % of ``u`` is degenerate where ``u`` = 0, the middle of the bounds). Stops after
    ``max_evaluations`` calls, or as soon as ``J <= target`` if given."""
    from scipy.optimize import minimize

    check_positive("initial_step", initial_step)
    u0 = np.asarray(space.to_unconstrained(x0))
    k = u0.shape[0]
    simplex = np.vstack([u0] + [u0 + initial_step * np.eye(k)[i] for i in range(k)])
    rows = _Rows(record, criteria_names)

    class _Reached(Exception):
        pass

    def f(u):
        if len(rows) >= max_evaluations:
            raise _Reached
        j, aux = value(jnp.asarray(u))
        j = float(j)
        rows.add(j, np.nan, aux)
        if target is not None and j <= target:
            raise _Reached
        # a failed solve gives NaN: Nelder-Mead treats +inf as "worse than every vertex"
        return j if np.isfinite(j) else np.inf

    try:
        minimize(
            f,
            u0,
            method="Nelder-Mead",
            options=dict(initial_simplex=simplex, maxfev=max_evaluations, xatol=1e-4, fatol=1e-7),
        )
    except _Reached:
        pass
    return rows.history("nelder-mead", space)


def optimise(
    problem: DesignProblem,
    x0,
    steps: int = 50,
    optimizer=None,
    learning_rate: float = 0.1,
    callback=None,
) -> DesignHistory:
    """Gradient descent with optax on the unconstrained variables, from design ``x0`` (k,).

    ``optimizer``: an ``optax.GradientTransformation`` (default ``optax.adam(learning_rate)``; a
    learning rate of 0.1 in ``u`` moves a variable near the middle of its bounds by about 2.5 % of
    its range per step). The batch is fixed (the problem's), so the run is deterministic. Each step
    evaluates ``J`` and ``dJ/du`` once (:func:`objective_and_grad`); the final point is evaluated
    too, so the history has ``steps + 1`` rows. ``callback(i, J, x, aux)`` is called after each."""
    return optax_minimise(
        problem.space, lambda u: objective_and_grad(problem, u), x0, steps=steps, optimizer=optimizer,
        learning_rate=learning_rate, callback=callback, record=_record(problem),
        criteria_names=problem.criteria_names,
    )  # fmt: skip


def lbfgs(problem: DesignProblem, x0, max_evaluations: int = 50, memory_size: int = 10, callback=None) -> DesignHistory:
    """L-BFGS with a backtracking line search (:func:`lbfgs_minimise`) on :func:`objective_and_grad`,
    from design ``x0`` (k,): each evaluation is a value and a gradient."""
    return lbfgs_minimise(
        problem.space, lambda u: objective_and_grad(problem, u), x0, max_evaluations=max_evaluations,
        memory_size=memory_size, callback=callback, record=_record(problem), criteria_names=problem.criteria_names,
    )  # fmt: skip


def nelder_mead(
    problem: DesignProblem,
    x0,
    max_evaluations: int = 100,
    initial_step: float = 0.5,
    target: float | None = None,
) -> DesignHistory:
    """Derivative-free baseline: scipy's Nelder-Mead on the same unconstrained variables and the
    same objective (:func:`objective_value`, jitted forward); see :func:`nelder_mead_minimise`."""
    return nelder_mead_minimise(
        problem.space, lambda u: objective_value(problem, u), x0, max_evaluations=max_evaluations,
        initial_step=initial_step, target=target, record=_record(problem), criteria_names=problem.criteria_names,
    )  # fmt: skip


# ------------------------------------------------------------------------------------------------
# Command line: jaxcable design
# ------------------------------------------------------------------------------------------------


def _parse_values(text, what, catalogue=DESIGN_VARIABLES):
    """``"m_w=1000,F_f=3e5"`` -> dict; ``"m_w=300:5000"`` -> dict of (lo, hi) when ``what`` is bounds."""
    out = {}
    if not text:
        return out
    for item in text.split(","):
        if "=" not in item:
            raise ValueError(f"{what}: expected name=value items separated by commas, got {item!r}")
        name, value = (s.strip() for s in item.split("=", 1))
        check_choice(f"design variable in {what}", name, catalogue)
        if what == "--bounds":
            if ":" not in value:
                raise ValueError(f"--bounds: expected name=lower:upper, got {item!r}")
            lo, hi = value.split(":", 1)
            out[name] = (float(lo), float(hi))
        else:
            out[name] = float(value)
    return out


def _evaluation_report(problem, x, j, aux):
    terms = {k: float(v) for k, v in aux["terms"].items()}
    return dict(design=problem.space.as_dict(x), objective=float(j), terms=terms, criteria=criteria_summary(problem, aux))


def _print_report(title, rep):
    print(title)
    print("  design     " + ", ".join(f"{k} = {v:.6g}" for k, v in rep["design"].items()))
    t = rep["terms"]
    print(
        f"  objective  {rep['objective']:.5f}  (expected {t['expected']:.4f}, tail {t['tail']:.4f}, "
        f"penalty {t['penalty']:.4f}, design cost {t['design_cost']:.4f})"
    )
    c = rep["criteria"]
    units = dict(z_max_m="m", a_max_g="g", sigma_max_mpa="MPa", capture_margin_m="m", tracking_error_m="m")
    for k in c["hard"]:
        h, s = c["hard"][k], c["smooth"][k]
        print(
            f"  {k:14s} hard worst {h['worst']:8.3f} mean {h['mean']:8.3f} | smooth worst {s['worst']:8.3f} "
            f"mean {s['mean']:8.3f} {units[k]:3s} (hard success {c['success_rate_per_criterion'][k]:.0%})"
        )
    print(f"  success rate (all criteria, hard) {c['success_rate']:.1%}; solver failures {c['solver_failures']}")


def _parse_chunk(text: str):
    """``--chunk``: ``auto``, ``none`` or a positive integer (checked by :class:`DesignProblem`)."""
    low = text.strip().lower()
    if low in ("auto", "none"):
        return None if low == "none" else "auto"
    try:
        return int(low)
    except ValueError:
        raise ValueError(f"--chunk must be auto, none or a positive integer, got {text!r}") from None


def design_main(argv: list[str] | None = None) -> int:
    """``jaxcable design``: optimise the buffer design over a QMC batch and report before/after.

    Prints the design, the objective and the criteria (hard and smooth; worst case and mean over
    the batch; success rate) at the start and at the best design found; ``--json`` prints one
    object instead. Returns 0, or 2 on bad input."""
    parser = argparse.ArgumentParser(prog="jaxcable design", description=design_main.__doc__.splitlines()[0])
    parser.add_argument("--scene", choices=["arresting", "throw"], default="arresting", help="arresting (buffer design over a QMC batch, default) or throw (line-throwing launch: range under a landing-speed and rope-pull limit)")
    parser.add_argument("--vars", default=None, help="design variables, comma-separated: m_w, F_f, a_p, b0 .. b15 or profile:K (the K factors of a brake profile F_f(w) = F_f phi(w)) (default m_w,F_f); with --scene throw: angle_deg, rope_diameter_m, rope_linear_density_kg_per_m (default angle_deg,rope_diameter_m)")
    parser.add_argument("--n", type=int, default=64, help="captures in the QMC batch (default 64)")
    parser.add_argument("--steps", type=int, default=50, help="optimiser steps (default 50)")
    parser.add_argument("--scenario", choices=["I", "II", "III"], default="I", help="Table 4 scenario (default I)")
    parser.add_argument("--fidelity", choices=["rigid", "ale", "full"], default="rigid", help="model level (default rigid; ale/full are slow)")
    parser.add_argument("--phase", choices=list(PHASES), default=None, help="passive (Table 8 captures, passive scene) or full (Table 3 terminal-guidance states, tracking + capture + passive phase, level rigid); default: full when a_p is a variable, else passive")
    parser.add_argument("--seed", type=int, default=0, help="seed of the scrambled Halton batch (default 0)")
    parser.add_argument("--optimizer", choices=["adam", "lbfgs"], default="adam", help="adam (optax, --steps steps at --lr) or lbfgs (optax's L-BFGS direction with a backtracking line search; --steps + 1 evaluations in all, trials included); default adam")
    parser.add_argument("--lr", type=float, default=0.1, help="adam learning rate in the unconstrained variables (default 0.1)")
    parser.add_argument("--t-end", type=float, default=1.2, help="time simulated after capture [s] (default 1.2)")
    parser.add_argument(
        "--cable-damping", type=float, default=DEFAULT_CABLE_DAMPING_S,
        help=f"cable stiffness-proportional damping beta [s] (default {DEFAULT_CABLE_DAMPING_S:g}; the paper gives none, a_max depends on it)",
    )  # fmt: skip
    parser.add_argument("--margin", type=float, default=0.0, help="fractional margin the penalties demand below each limit (default 0; 0.02: criteria < 98%% of their limits)")
    parser.add_argument("--tail-criterion", choices=list(TAIL_CRITERIA), default="a_max", help="criterion whose CVaR is the tail risk (default a_max; worst: each case's largest normalised criterion, for designs that must meet every criterion)")
    parser.add_argument("--alpha", type=float, default=0.75, help="CVaR level: the tail is the worst (1 - alpha) of the batch (default 0.75)")
    parser.add_argument("--expected", type=float, default=1.0, help="weight of the expected cost (default 1; 0 with --tail-criterion worst: minimise the batch's worst criteria)")
    parser.add_argument("--start", default="paper", help="'paper' (section II.B: m_t = 2, eq 19, and Table 4's a_p; --scene throw: the flight-tested 30 deg and the calibrated 10 mm rope) or name=value,... replacing the paper design's values (default paper)")
    parser.add_argument("--bounds", default="", help="name=lower:upper,... overriding the default bounds")
    parser.add_argument("--rtol", type=float, default=None, help="relative = absolute solver tolerance (default per level: rigid 1e-6, ale/full 1e-5)")
    parser.add_argument("--gradient", choices=list(GRADIENT_MODES), default="forward", help="forward or reverse mode (default forward)")
    parser.add_argument("--chunk", default="auto", help="cases per vmapped call inside the objective: auto (on the CPU 32, 16 for forward-mode gradients; elsewhere the whole batch), none (the whole batch) or a positive integer (default auto)")
    parser.add_argument("--landing-speed", type=float, default=None, help="--scene throw: landing-speed limit [m/s] (default 60)")
    parser.add_argument("--max-tension", type=float, default=None, help="--scene throw: limit of the rope's pull on the rocket [N] (default 4000)")
    parser.add_argument("--segment-length", type=float, default=10.0, help="--scene throw: rope segment length [m] (default 10)")
    parser.add_argument("--rope-length", type=float, default=1000.0, help="--scene throw: rope in the box [m] (default 1000)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args(argv)
    from jaxcable.core.config import enable_x64

    enable_x64()
    if args.scene == "throw":
        return _throw_design_main(args)
    args.vars = "m_w,F_f" if args.vars is None else args.vars
    try:
        if args.steps < 0:
            raise ValueError(f"--steps must be >= 0, got {args.steps}")
        tol = {} if args.rtol is None else dict(rtol=args.rtol, atol=args.rtol)
        problem = design_problem(
            args.vars,
            n=args.n,
            scenario=args.scenario,
            fidelity=args.fidelity,
            seed=args.seed,
            phase=args.phase,
            bounds=_parse_values(args.bounds, "--bounds"),
            t_end_s=args.t_end,
            gradient=args.gradient,
            chunk=_parse_chunk(args.chunk),
            cable_damping_s=args.cable_damping,
            weights=ObjectiveWeights(
                margin=args.margin, tail_criterion=args.tail_criterion, alpha=args.alpha, expected=args.expected
            ),
            **tol,
        )
        x0 = paper_start(problem)
        if args.start != "paper":  # given values replace the paper design's
            x0 = problem.space.from_dict({**problem.space.as_dict(x0), **_parse_values(args.start, "--start")})
    except (ValueError, NotImplementedError) as err:
        print(f"jaxcable design: error: {err}", file=sys.stderr)
        return 2

    kept = {}
    record = _record(problem)

    def progress(i, j, x, aux):
        # keep the start's and the best point's batch results for the report (no re-evaluation)
        # "best": the lowest objective among the designs with the highest success rate on the
        # batch (the objective alone may prefer a design that trades a small violation for lower
        # mean criteria: experiments/results/design_feasibility.md)
        success = record(aux)[1]
        if i == 0:
            kept["start"] = (x, j, aux)
        if "best" not in kept or (success, -j) > (kept["best"]["success"], -kept["best"]["j"]):
            kept["best"] = dict(x=x, j=j, aux=aux, success=success, step=i)
        if not args.json:
            print(f"  step {i:3d}  J = {j:.5f}  " + ", ".join(f"{k} = {v:.6g}" for k, v in problem.space.as_dict(x).items()), flush=True)

    t0 = time.perf_counter()
    if args.optimizer == "lbfgs":
        hist = lbfgs(problem, x0, max_evaluations=args.steps + 1, callback=progress)
    else:
        hist = optimise(problem, x0, steps=args.steps, learning_rate=args.lr, callback=progress)
    wall = time.perf_counter() - t0
    before = _evaluation_report(problem, *kept["start"])
    best = kept["best"]
    after = _evaluation_report(problem, best["x"], best["j"], best["aux"])
    out = dict(
        variables=list(problem.space.names),
        bounds={n: [float(lo), float(hi)] for n, lo, hi in zip(problem.space.names, np.asarray(problem.space.lower), np.asarray(problem.space.upper))},
        n=problem.n_cases,
        scenario=args.scenario,
        fidelity=args.fidelity,
        seed=args.seed,
        steps=args.steps,
        optimizer=args.optimizer,
        t_end_s=args.t_end,
        rtol=problem.rtol,
        gradient=args.gradient,
        before=before,
        after=after,
        best_step=best["step"],
        # what the optimiser itself reached (it minimises the objective, not the success rate)
        lowest_objective=dict(
            step=hist.best, objective=float(hist.objective[hist.best]), success_rate=float(hist.success_rate[hist.best]),
            design=problem.space.as_dict(hist.x[hist.best]),
        ),
        history=dict(objective=hist.objective.tolist(), success_rate=hist.success_rate.tolist()),
        wall_s=wall,
        phase=problem.phase,
        limits={k: _limit_of(problem, k) for k in problem.criteria_names},
    )
    if problem.phase == "full":
        out["capture_reference_m"] = float(problem.capture_reference_m)
    if args.json:
        print(json.dumps(out))
    else:
        _print_report("before (start design)", before)
        what = f"{args.steps} adam steps" if args.optimizer == "adam" else f"{len(hist.objective)} L-BFGS evaluations"
        _print_report(f"after (best of {what}: step {best['step']}, the lowest objective among the highest success rate)", after)
        low = out["lowest_objective"]
        if low["step"] != best["step"]:
            print(
                f"  the lowest objective, J = {low['objective']:.5f}, came at step {low['step']} with success rate "
                f"{100 * low['success_rate']:.1f}%: " + ", ".join(f"{k} = {v:.6g}" for k, v in low["design"].items())
            )
        print(f"  wall time {wall:.1f} s (includes compiling)")
    return 0


def _throw_design_main(args) -> int:
    """``jaxcable design --scene throw``: adam on :mod:`jaxcable.throw.design` from the flight-tested
    design (``--start paper``: 30 deg, the calibrated 10 mm rope)."""
    from jaxcable.throw.design import THROW_VARIABLES, ThrowLimits, calibrated_start, optimise_throw, throw_problem, throw_report

    try:
        if args.steps < 0:
            raise ValueError(f"--steps must be >= 0, got {args.steps}")
        limits = {}
        if args.landing_speed is not None:
            limits["landing_speed_mps"] = args.landing_speed
        if args.max_tension is not None:
            limits["max_tension_N"] = args.max_tension
        settings = {} if args.rtol is None else dict(rtol=args.rtol, atol=args.rtol)
        problem = throw_problem(
            "angle_deg,rope_diameter_m" if args.vars is None else args.vars,
            segment_length_m=args.segment_length,
            rope_length_m=args.rope_length,
            bounds=_parse_values(args.bounds, "--bounds", THROW_VARIABLES),
            limits=ThrowLimits(**limits),
            gradient=args.gradient,
            **settings,
        )
        x0 = calibrated_start(problem)
        if args.start != "paper":
            x0 = problem.space.from_dict({**problem.space.as_dict(x0), **_parse_values(args.start, "--start", THROW_VARIABLES)})
    except ValueError as err:
        print(f"jaxcable design: error: {err}", file=sys.stderr)
        return 2
    kept = {}

    def progress(i, j, x, aux):
        if i == 0:
            kept["start"] = aux
        if "best" not in kept or j < float(kept["best"]["terms"]["total"]):
            kept["best"] = aux
        if not args.json:
            print(f"  step {i:3d}  J = {j:+.5f}  " + ", ".join(f"{k} = {v:.6g}" for k, v in problem.space.as_dict(x).items())
                  + f"  range {float(aux['range_m']):.1f} m, landing {float(aux['impact_speed_mps']):.2f} m/s, "
                  f"pull {float(aux['max_tension_N']):.0f} N", flush=True)  # fmt: skip

    t0 = time.perf_counter()
    hist = optimise_throw(problem, x0, steps=args.steps, learning_rate=args.lr, callback=progress)
    wall = time.perf_counter() - t0
    before, after = throw_report(problem, kept["start"]), throw_report(problem, kept["best"])
    out = dict(
        scene="throw",
        variables=list(problem.space.names),
        bounds={n: [float(lo), float(hi)] for n, lo, hi in zip(problem.space.names, np.asarray(problem.space.lower), np.asarray(problem.space.upper))},
        limits=dict(landing_speed_mps=float(problem.limits.landing_speed_mps), max_tension_N=float(problem.limits.max_tension_N)),
        segment_length_m=args.segment_length,
        rope_length_m=float(problem.scene.rope.length_m),
        steps=args.steps,
        rtol=problem.rtol,
        gradient=args.gradient,
        before=before,
        after=after,
        best_step=hist.best,
        history=dict(objective=hist.objective.tolist()),
        wall_s=wall,
    )
    if args.json:
        print(json.dumps(out))
    else:
        for title, rep in (("before (flight-tested design)", before), (f"after (best of {args.steps} adam steps: step {hist.best})", after)):
            print(title)
            print("  design     " + ", ".join(f"{k} = {v:.6g}" for k, v in rep["design"].items()))
            print(f"  objective  {rep['objective']:+.5f}  range {rep['range_m']:.1f} m, landing speed "
                  f"{rep['impact_speed_mps']:.2f} m/s, max rope pull {rep['max_tension_N']:.0f} N, within limits {rep['within_limits']}")  # fmt: skip
        print(f"  wall time {wall:.1f} s (includes compiling)")
    return 0
