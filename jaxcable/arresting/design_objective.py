r"""The objective of the arresting buffer design over a batch of captures, its gradients, and the
summaries of an evaluation (arresting-cable paper, section IV.A's success criteria; the problem is
built by :mod:`jaxcable.arresting.design_setup`).

Per capture ``j`` the smooth criteria ``c_ij`` (``i`` = z, a, sigma) are the soft maxima over the
saved history of :func:`jaxcable.arresting.passive.smooth_landing_outputs`; normalised by their
limits ``L_i`` (10 m, 5 g, 800 MPa), ``r_ij = c_ij / L_i`` (``r < 1``: criterion met; the *margin*
is ``1 - r``). With the weights ``w`` of :class:`~jaxcable.arresting.design_setup.ObjectiveWeights`::

    J(x) = w_expected * E_j[ sum_i w_criteria_i r_ij ]                  expected cost
         + w_tail     * CVaR_alpha( r_tail,j )                           tail risk
         + sum_i w_penalty_i * E_j[ max(0, r_ij - 1 + margin)^2 ]        violation penalties
         + sum_k w_design_k * x_k / upper_k                              design cost (default 0)

* expected cost: the batch mean of a weighted mix of the normalised criteria (default equal
  thirds); it rewards margin on every criterion;
* tail risk: the CVaR (:func:`~jaxcable.studies.optimise.smooth_cvar` by default,
  :func:`~jaxcable.studies.optimise.cvar` with ``tail_form="exact"``) of one normalised criterion
  (default ``a_max``) or of each case's largest (``"worst"``): to meet every criterion over the
  batch, weigh the worst case (``ObjectiveWeights(expected=0, tail_criterion="worst", alpha=0.9)``);
* penalties: squared hinges (C^1) on the batch mean, so every violating case pulls;
* design cost: linear in the variables relative to their upper bounds (off by default).

``phase="full"`` adds two normalised criteria per landing (``CAPTURE_CRITERIA``), weighted by
``capture_criteria`` and ``capture_penalty``::

    r_capture  = 1 - m / m_ref     m: soft minimum of the four hooks' capture margins [m]
                                   (width 0.02 m); m_ref: the margin of a centred vertical capture
                                   (capture_reference); r < 1 <=> captured
    r_tracking = e / e_tol         e: true tracking error at capture [m]; e_tol = 1 m

Gradients differentiate through ``diffrax.diffeqsolve``: ``gradient="forward"`` (default;
``diffrax.ForwardMode`` + ``jax.jacfwd``, the k tangents carried along the same adaptive solve) or
``"reverse"`` (``RecursiveCheckpointAdjoint`` with ``REVERSE_CHECKPOINTS`` + ``jax.grad``). They are
the gradients of the discrete adaptive solve. Measurements (cost, bias of the soft maxima,
feasibility): ``docs/notes/arresting_design_measurements.md``.
"""

from __future__ import annotations

import warnings

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from jaxcable.core.simulate import simulate
from jaxcable.studies.batching import chunk_size, chunked_vmap
from jaxcable.studies.optimise import cvar, smooth_cvar, value_and_grad_by_mode
from jaxcable.arresting.buffer import BufferDevice
from jaxcable.arresting.cable_sets import AleCables
from jaxcable.arresting.control import target_point
from jaxcable.arresting.design_setup import (
    CRITERIA,
    REVERSE_CHECKPOINTS,
    TAIL_CRITERIA,
    DesignProblem,
    design_buffer,
    design_gain,
    design_scene,
)
from jaxcable.arresting.landing import LEVEL_STEP_CONTROL, batched_solver, level_solver_settings
from jaxcable.arresting.passive import landing_outputs, smooth_landing_outputs
from jaxcable.arresting.two_phase import TwoPhaseCaseFunction, event_occurred, two_phase_outputs
from jaxcable.arresting.uncertainty import UNCERTAIN_PARAMETERS

__all__ = [
    "batch_criteria",
    "case_solver",
    "criteria_summary",
    "criterion_limit",
    "design_adjoint",
    "evaluation_report",
    "history_record",
    "objective",
    "objective_and_grad",
    "objective_terms",
    "objective_value",
]


# ------------------------------------------------------------------------------------------------
# Simulation of the batch
# ------------------------------------------------------------------------------------------------


def _with_buffer(scene, buffer: BufferDevice):
    """``scene`` with ``buffer`` in its cables: the massless cables hold one buffer, the ALE cables'
    four subsystems a stacked one (leading axis 4). The mesh does not depend on the buffer."""
    if isinstance(scene.cables, AleCables):
        stacked = jax.tree_util.tree_map(lambda v: jnp.broadcast_to(v, (4,) + jnp.shape(v)), buffer)
        return eqx.tree_at(lambda s: s.cables.subsystems.buffer, scene, stacked)
    return eqx.tree_at(lambda s: s.cables.buffer, scene, buffer)


def case_solver(problem: DesignProblem):
    """The solver of the problem's cases: the level's for its cable damping and its scenes' hook
    model (:func:`.landing.level_solver_settings`), as a vmapped batch runs it (the W-method relinearised
    at every step, :func:`.landing.batched_solver`)."""
    hook_contact = getattr(getattr(problem.scenes, "cables", None), "hook_contact", None)
    return batched_solver(level_solver_settings(problem.fidelity, problem.cable_damping_s, hook_contact)[0])


def _one_case(problem: DesignProblem, scene, adjoint):
    """One built scene: smooth and hard criteria, solver status and steps (scalars), with the
    solver of :func:`case_solver` and the level's step-size control (``LEVEL_STEP_CONTROL``)."""
    pcoeff, icoeff = LEVEL_STEP_CONTROL[problem.fidelity]
    res = simulate(
        scene,
        problem.t_end_s,
        solver=case_solver(problem),
        rtol=problem.rtol,
        atol=problem.atol,
        max_steps=problem.max_steps,
        adjoint=adjoint,
        pcoeff=pcoeff,
        icoeff=icoeff,
    )
    smooth = smooth_landing_outputs(res.ts, res.probes, problem.widths, problem.limits.filter_cfc_hz)
    # the scene summarises with the default criteria; the problem's may filter at another class
    outputs = landing_outputs(res.ts, res.probes, res.status, problem.limits)
    hard = {k: outputs[k] for k in CRITERIA}
    # a case cut short (solver failure, or not stopped by t_end) does not land, whatever its maxima
    completed = outputs["solve_ok"] & outputs["stopped"]
    out = dict(smooth=smooth, hard=hard, completed=completed, status=res.status, num_steps=res.num_steps)
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
    buffer = design_buffer(problem, x)
    case_fn = TwoPhaseCaseFunction(
        buffer=buffer, layout=problem.layout, gain_per_s=design_gain(problem, x), scenario=problem.scenario,
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
    error = jnp.linalg.norm(scene.frame_centre(final) - target_point(x_true[0], x_true[1]))
    smooth = dict(smooth_landing_outputs(land.ts, land.probes, problem.widths, problem.limits.filter_cfc_hz))
    smooth["capture_margin_m"] = out["smooth_capture_margin_m"]
    smooth["tracking_error_m"] = error
    hard = {k: out[k] for k in CRITERIA}
    hard["capture_margin_m"] = out["capture_margin_m"]
    hard["tracking_error_m"] = error
    status = jnp.where(event_occurred(out["tracking_status"]), out["passive_status"], out["tracking_status"])
    completed = event_occurred(out["tracking_status"]) & out["solve_ok"] & out["stopped"]
    return dict(smooth=smooth, hard=hard, completed=completed, status=status,
                num_steps=out["tracking_steps"] + out["passive_steps"])  # fmt: skip


def _batch(problem: DesignProblem, x, adjoint):
    # one scene per case; the batch is a vmap over the cases (physics handles one case), in chunks
    # of DesignProblem.chunk cases
    n, chunk = problem.n_cases, chunk_size(problem.chunk, adjoint)
    if problem.phase == "full":
        fn = lambda c, w: _one_two_phase_case(problem, c, w, x, adjoint)  # noqa: E731
        return chunked_vmap(fn, (problem.captures, problem.conditions), n, chunk)
    if problem.scenes is not None:  # ale/full: meshed on the host by design_problem; swap the design in
        buffer = design_buffer(problem, x)
        return chunked_vmap(lambda sc: _one_case(problem, _with_buffer(sc, buffer), adjoint), (problem.scenes,), n, chunk)
    return chunked_vmap(lambda c: _one_case(problem, design_scene(problem, c, x), adjoint), (problem.captures,), n, chunk)


def design_adjoint(problem: DesignProblem):
    """The adjoint of ``problem.gradient``: ``diffrax.ForwardMode`` or ``RecursiveCheckpointAdjoint``
    with ``problem.checkpoints`` (default ``REVERSE_CHECKPOINTS``)."""
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
    adjoint = design_adjoint(problem)
    return value_and_grad_by_mode(lambda u_: objective(problem, u_, adjoint), u, problem.gradient)


@eqx.filter_jit
def batch_criteria(problem: DesignProblem, x):
    """Forward only, at a physical design ``x`` (k,): per-case ``smooth`` and ``hard`` criteria
    (dicts of (n,) arrays), ``status`` and ``num_steps`` (n,)."""
    return _batch(problem, jnp.asarray(x, dtype=float), None)


def _hard_ok(problem, aux):
    """(n, c) bool: each case's hard criteria met (``problem.criteria_names``' order)."""
    r = np.asarray(_normalised(problem, {k: np.asarray(v) for k, v in aux["hard"].items()}))
    return r < 1.0


def _landed(problem, aux):
    """(n,) bool: each case meets every hard criterion and ran to completion (the solves succeeded
    and the rocket stopped, ``aux["completed"]``): the landing success of
    :func:`jaxcable.arresting.passive.landing_outputs`."""
    done = np.asarray(aux["completed"], dtype=bool) if "completed" in aux else True
    return np.all(_hard_ok(problem, aux), axis=1) & done


def _worst(name, values):
    # the capture margin is a margin (larger is better): its worst case is the minimum
    return float(np.min(values)) if name == "capture_margin_m" else float(np.max(values))


def criterion_limit(problem: DesignProblem, name: str) -> float:
    """The limit of criterion ``name`` (``problem.criteria_names``): 10 m, 5 g, 800 MPa by default,
    0 for the capture margin, the tracking tolerance for the tracking error."""
    lim = problem.limits
    return dict(
        z_max_m=lim.z_max_m, a_max_g=lim.a_max_g, sigma_max_mpa=lim.sigma_max_mpa,
        capture_margin_m=0.0, tracking_error_m=float(problem.tracking_tolerance_m),
    )[name]  # fmt: skip


def criteria_summary(problem: DesignProblem, aux) -> dict:
    """JSON-able summary of one batch evaluation (an ``aux`` of :func:`objective` or the output of
    :func:`batch_criteria`): for ``hard`` and ``smooth`` criteria the worst case and the mean, the
    worst margin (``1 - c / limit``; for the capture margin the smallest margin itself [m]);
    per-criterion success rates (hard criteria) and the overall one (every hard criterion met, the
    solves succeeded and the rocket stopped); solver failures."""
    out = {}
    for kind in ("hard", "smooth"):
        d = {}
        for k in problem.criteria_names:
            v = np.asarray(aux[kind][k], dtype=float)
            worst = _worst(k, v)
            margin = worst if k == "capture_margin_m" else 1.0 - worst / criterion_limit(problem, k)
            d[k] = dict(worst=worst, mean=float(np.mean(v)), margin=float(margin))
        out[kind] = d
    ok = _hard_ok(problem, aux)
    out["success_rate"] = float(np.mean(_landed(problem, aux)))
    out["success_rate_per_criterion"] = {k: float(np.mean(ok[:, i])) for i, k in enumerate(problem.criteria_names)}
    status = np.asarray(aux["status"])
    out["solver_failures"] = int(np.sum(status != 0))
    out["max_solver_steps"] = int(np.max(np.asarray(aux["num_steps"])))
    return out


def evaluation_report(problem: DesignProblem, aux) -> dict:
    """JSON-able report of one evaluation (an ``aux`` of :func:`objective`): the design
    ``{name: value}``, the objective, its terms and :func:`criteria_summary`."""
    terms = {k: float(v) for k, v in aux["terms"].items()}
    return dict(
        design=problem.space.as_dict(np.asarray(aux["x"])), objective=terms["total"], terms=terms,
        criteria=criteria_summary(problem, aux),
    )  # fmt: skip


def history_record(problem: DesignProblem):
    """``aux -> (worst hard criteria (c,), success rate)``: the record an optimiser's
    :class:`~jaxcable.studies.optimise.DesignHistory` keeps of each evaluation. At levels ale and
    full it warns (``RuntimeWarning``) when more hook-cable contact pairs touched in some case than
    ``AleCables.contact_tangent_pairs`` carries tangents for: that gradient misses those pairs."""

    def record(aux):
        if "contact_tangent_exact" in aux and not bool(np.all(np.asarray(aux["contact_tangent_exact"]))):
            warnings.warn(
                "more hook-cable contact pairs touched than AleCables.contact_tangent_pairs carries "
                "tangents for, in some case of this evaluation: its gradient misses those pairs; "
                "rebuild the scenes with a larger contact_tangent_pairs (or None)",
                RuntimeWarning,
                stacklevel=3,
            )
        worst = [_worst(k, np.asarray(aux["hard"][k])) for k in problem.criteria_names]
        return worst, float(np.mean(_landed(problem, aux)))

    return record
