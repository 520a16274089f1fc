r"""Gradient-based design of the buffer devices over a quasi-Monte Carlo batch of captures.

Arresting-cable paper, section II.B (the 1-DOF design: counterweight mass ``m_w`` and brake friction
``F_f`` through the groups ``m_t_bar``, ``F_t_bar`` of eqs 15-24) and section IV (success criteria
``z_max < 10 m``, ``a_max < 5 g``, ``sigma_max < 800 MPa``; Table 8 captured-state ranges). The paper
picks ``m_w`` and ``F_f`` from the 1-DOF model and checks them by Monte Carlo; here they, the PD
gain ``a_p`` (section II.A, eq 4; Table 4) and a brake profile are optimised directly on the
criteria of a batch of deviated landings, with gradients through the diffrax solve.
``phase="passive"`` simulates Table 8 captured states in the passive scene (level ``rigid`` by
default; ``ale`` and ``full`` mesh each case's cables on the host); ``phase="full"`` simulates Table 3
terminal-guidance states under Table 4 wind, gust, motor delay and noise through both phases of
:mod:`jaxcable.arresting.two_phase`, so the capture margin and the tracking error join the criteria.

This module is the public face; the pieces are

* :mod:`jaxcable.arresting.design_setup`: the variables (``DESIGN_VARIABLES``, ``DEFAULT_BOUNDS``),
  the criteria, :class:`ObjectiveWeights`, :class:`DesignProblem` and :func:`design_problem`,
  :func:`paper_start` and how a design enters the scene;
* :mod:`jaxcable.arresting.design_objective`: the objective (its formula is there), its jitted
  forms :func:`objective_value`, :func:`objective_and_grad`, :func:`batch_criteria`, and the
  summaries :func:`criteria_summary`, :func:`evaluation_report`;
* here: the optimisers on a problem, :func:`optimise` (adam), :func:`lbfgs` and
  :func:`nelder_mead`, on the system-agnostic loops of :mod:`jaxcable.studies.optimise`; the problem
  is registered as ``"arresting"`` for ``jaxcable design --scene arresting``.

Measurements (gradient cost, soft-maximum bias, feasibility of the criteria, the ``a_p`` design):
``docs/notes/arresting_design_measurements.md``.

Glossary: ``x`` the design in its variables' units (k,), ``u`` its unconstrained coordinates
(``x = lo + (hi - lo) sigmoid(u)``), ``J`` the objective, ``r`` a criterion divided by its limit
(met when ``r < 1``), ``m_w`` counterweight mass [kg], ``F_f`` brake friction [N], ``a_p`` PD gain
[1/s], ``b0 .. b{K-1}`` brake-profile factors [-], ``alpha`` the CVaR level, ``n`` the batch size.
"""

from __future__ import annotations

from jaxcable.studies.optimise import DesignEntry, DesignHistory, lbfgs_minimise, nelder_mead_minimise, optax_minimise
from jaxcable.studies.registry import register_design_problem
from jaxcable.arresting.design_objective import (
    batch_criteria,
    criteria_summary,
    criterion_limit,
    design_adjoint,
    evaluation_report,
    history_record,
    objective,
    objective_and_grad,
    objective_terms,
    objective_value,
)
from jaxcable.arresting.design_setup import (
    CAPTURE_CRITERIA,
    CONDITIONS,
    CRITERIA,
    DEFAULT_BOUNDS,
    DESIGN_VARIABLES,
    MAX_PROFILE_KNOTS,
    PHASES,
    REVERSE_CHECKPOINTS,
    TAIL_CRITERIA,
    DesignProblem,
    ObjectiveWeights,
    capture_reference,
    default_phase,
    design_buffer,
    design_gain,
    design_problem,
    design_scene,
    design_space,
    host_built_scenes,
    paper_start,
    profile_names,
)

__all__ = [
    "CAPTURE_CRITERIA",
    "CONDITIONS",
    "CRITERIA",
    "DEFAULT_BOUNDS",
    "DESIGN_VARIABLES",
    "MAX_PROFILE_KNOTS",
    "PHASES",
    "REVERSE_CHECKPOINTS",
    "TAIL_CRITERIA",
    "DesignProblem",
    "ObjectiveWeights",
    "batch_criteria",
    "capture_reference",
    "criteria_summary",
    "criterion_limit",
    "default_phase",
    "design_adjoint",
    "design_buffer",
    "design_gain",
    "design_problem",
    "design_scene",
    "design_space",
    "evaluation_report",
    "history_record",
    "host_built_scenes",
    "lbfgs",
    "nelder_mead",
    "objective",
    "objective_and_grad",
    "objective_terms",
    "objective_value",
    "optimise",
    "paper_start",
    "profile_names",
]


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
        learning_rate=learning_rate, callback=callback, record=history_record(problem),
        criteria_names=problem.criteria_names,
    )  # fmt: skip


def lbfgs(problem: DesignProblem, x0, max_evaluations: int = 50, memory_size: int = 10, callback=None) -> DesignHistory:
    """L-BFGS with a backtracking line search (:func:`~jaxcable.studies.optimise.lbfgs_minimise`) on
    :func:`objective_and_grad`, from design ``x0`` (k,): each evaluation is a value and a gradient."""
    return lbfgs_minimise(
        problem.space, lambda u: objective_and_grad(problem, u), x0, max_evaluations=max_evaluations,
        memory_size=memory_size, callback=callback, record=history_record(problem),
        criteria_names=problem.criteria_names,
    )  # fmt: skip


def nelder_mead(
    problem: DesignProblem,
    x0,
    max_evaluations: int = 100,
    initial_step: float = 0.5,
    target: float | None = None,
) -> DesignHistory:
    """Derivative-free baseline: scipy's Nelder-Mead on the same unconstrained variables and the
    same objective (:func:`objective_value`, jitted forward); see
    :func:`~jaxcable.studies.optimise.nelder_mead_minimise`."""
    return nelder_mead_minimise(
        problem.space, lambda u: objective_value(problem, u), x0, max_evaluations=max_evaluations,
        initial_step=initial_step, target=target, record=history_record(problem),
        criteria_names=problem.criteria_names,
    )  # fmt: skip


register_design_problem(
    "arresting",
    DesignEntry(
        build=design_problem,
        start=paper_start,
        optimise=optimise,
        report=evaluation_report,
        variables=DESIGN_VARIABLES,
        default_variables="m_w,F_f",
        lbfgs=lbfgs,
        record=history_record,
    ),
)
