r"""Design of a line-throwing rocket's launch: range under a landing-speed (and a rope-tension) limit.

Line-throwing paper (Lu et al. 2016), section 4: the range grows with the launch angle up to an
optimum (about 35 deg with the calibrated model) and then falls, while "with the angle increases,
the time of the rocket flying in the air increases, and landing velocity of the rocket also
increased". A rocket that must land its line on a ship's deck without harm has a landing-speed
limit, so the longest admissible throw is a trade-off. This module poses it on the system-agnostic
kit of :mod:`jaxcable.studies.optimise` (the scaled-logistic
:class:`~jaxcable.studies.optimise.DesignSpace`, the optax loop
:func:`~jaxcable.studies.optimise.optax_minimise` and the Nelder-Mead baseline
:func:`~jaxcable.studies.optimise.nelder_mead_minimise`) with gradients through the diffrax solve and
the differentiable impact event; the problem is registered as ``"throw"`` for ``jaxcable design
--scene throw``.

Design variables (``THROW_VARIABLES``; choose any subset):

* ``angle_deg``: launch elevation [deg].
* ``rope_diameter_m``: rope diameter [m]. The rope stays of the calibrated material: its linear
  density scales as ``d^2`` from the scene's (0.0693 kg/m at 10 mm, ``CALIBRATION`` of
  :mod:`jaxcable.throw.scene`), its drag area ``d l`` as ``d``, at the calibrated drag
  coefficient.
* ``rope_linear_density_kg_per_m``: the linear density itself [kg/m]; when chosen, it overrides the
  ``d^2`` scaling (a different material).

Objective (pure, :func:`throw_objective`)::

    J(x) = - range / range_reference
           + w_speed   * max(0, v_impact / v_limit - 1 + margin)^2
           + w_tension * max(0, T_soft / T_limit - 1 + margin)^2

with ``range`` the rocket's downrange distance at ground impact [m] and ``v_impact`` its speed
there [m/s] (both at the impact event, which diffrax locates by a root find: smooth in the design),
and ``T_soft`` a soft maximum (``width * logsumexp(T / width)``, an upper bound of the maximum) over
the saved history of the rope's pull on the rocket [N]: the tension at the rope's rocket end, its
largest in flight (the rope behind is pulled from rest, so its tension falls toward the box).

Readings and choices, written down:

* The paper states no landing-speed or tension limit; ``ThrowLimits`` defaults (landing speed
  60 m/s, rope pull 4 kN) are illustrative, chosen so that both bind near the calibrated design:
  the calibrated 30 deg flight (10 mm rope, 10 m segments) lands at 58.7 m/s and pulls up to
  4.45 kN (during the burn: the momentum flux ``rho v^2`` of rope pulled from rest at ~200 m/s plus
  its drag). A thinner rope pulls less and flies further but lands faster (less rope drag), and a
  flatter launch lands slower: the optimum trades angle against diameter on both limits
  (``experiments/results/design_throw.md``).
* The default model is coarse (10 m segments, 1000 m of rope, tsit5 at rtol 1e-6) for cost: the
  README's segment study moves the range by 0.1 % from 1 m to 5 m segments; the experiment re-checks
  the designs at 2 m segments.
* Calibration (the fit of unknown drag coefficients and density to the 30 deg flight test) is the
  other use of the same gradients; it lives in :mod:`jaxcable.throw.calibration` and is not repeated here.
* **Measured** (``python experiments/design_throw.py --steps 60 --lr 0.2 --nm-evals 80``, 2 busy
  cores): from the flight-tested design (30 deg, 10 mm: 618.6 m, 58.7 m/s, 4446 N: over the pull
  limit) both optimisers reach 22.2-22.3 deg and a 7.2 mm rope: 715.5 m (+16 %), landing at
  59.8 m/s, pulling 2.86 kN (re-flown with 2 m segments: 716.5-716.8 m, 59.7 m/s). The optimum is
  interior: a thinner rope flies further but lands faster, and the flatter launch that keeps the
  landing speed shortens the throw. Nelder-Mead got within 1e-3 of adam's best objective in 21
  evaluations (12.6 s) against adam's 50 value-and-gradient evaluations (107 s): on this
  two-variable problem with a penalty wall, the derivative-free baseline wins.
"""

from __future__ import annotations

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from jaxcable.core.simulate import simulate
from jaxcable.core.validation import check_choice, check_positive, float_array
from jaxcable.studies.optimise import (
    GRADIENT_MODES,
    DesignEntry,
    DesignSpace,
    nelder_mead_minimise,
    optax_minimise,
    value_and_grad_by_mode,
)
from jaxcable.studies.registry import register_design_problem
from jaxcable.throw.scene import LineThrowingScene, line_throwing_scene

__all__ = [
    "THROW_BOUNDS",
    "THROW_CRITERIA",
    "THROW_VARIABLES",
    "ThrowDesignProblem",
    "ThrowLimits",
    "ThrowWeights",
    "calibrated_start",
    "nelder_mead_throw",
    "optimise_throw",
    "throw_design_scene",
    "throw_objective",
    "throw_objective_and_grad",
    "throw_objective_value",
    "throw_outputs",
    "throw_problem",
    "throw_record",
    "throw_report",
]

THROW_VARIABLES = {
    "angle_deg": "launch elevation [deg]",
    "rope_diameter_m": "rope diameter [m] (linear density ~ d^2, drag area ~ d, calibrated material)",
    "rope_linear_density_kg_per_m": "rope linear density [kg/m] (overrides the d^2 scaling)",
}
"""The launch and rope variables one may choose."""

THROW_BOUNDS = {
    "angle_deg": (10.0, 70.0),  # the paper flies 25-65 deg
    "rope_diameter_m": (0.004, 0.016),  # 4-16 mm lines; 10 mm calibrated
    "rope_linear_density_kg_per_m": (0.02, 0.3),  # printed 0.43, calibrated 0.069
}
"""Default bounds ``(lower, upper)`` per variable."""

THROW_CRITERIA = ("range_m", "impact_speed_mps", "max_tension_N")
"""Columns of the histories' record (:attr:`~jaxcable.studies.optimise.DesignHistory.worst_hard`): the range [m], the landing
speed [m/s] and the largest rope pull on the rocket [N] (hard values)."""


class ThrowLimits(eqx.Module):
    """The admissible landing speed and rope pull (illustrative defaults: module docstring)."""

    landing_speed_mps: jax.Array = eqx.field(converter=float_array, default=60.0)
    """largest admissible speed at ground impact [m/s], shape ()"""
    max_tension_N: jax.Array = eqx.field(converter=float_array, default=4000.0)
    """largest admissible pull of the rope on the rocket [N], shape ()"""

    def __check_init__(self):
        check_positive("landing_speed_mps", self.landing_speed_mps)
        check_positive("max_tension_N", self.max_tension_N)


class ThrowWeights(eqx.Module):
    """Weights and widths of the objective (module docstring). Arrays: sweepable."""

    range_reference_m: jax.Array = eqx.field(converter=float_array, default=600.0)
    """the range that counts as 1 in the objective [m] (the calibrated 30 deg range), shape ()"""
    speed_penalty: jax.Array = eqx.field(converter=float_array, default=100.0)
    """weight of the squared landing-speed violation [-], shape (): 100 makes a 10 % excess cost
    as much as 100 % of the reference range; the range's pull still pushes the optimum 0.7-1.5 %
    past the penalty's onset (measured, margin 0: 60.4-60.9 m/s for a 60 m/s limit), hence ``margin``"""
    tension_penalty: jax.Array = eqx.field(converter=float_array, default=100.0)
    """weight of the squared rope-pull violation [-], shape (); 0 switches the tension limit off"""
    margin: jax.Array = eqx.field(converter=float_array, default=0.02)
    """fractional margin the penalties demand below each limit [-], shape (): the penalty starts at
    98 % of a limit, so the penalised optimum (which overshoots the onset by ~1 %) meets the limit"""
    tension_width_N: jax.Array = eqx.field(converter=float_array, default=10.0)
    """width of the soft maximum of the rope pull [N], shape (): its bias is at most
    ``width log(n_saved)`` (~70 N for ~1000 samples of 0.01 s) and measured 5e-6 N at 30 deg / 9 mm
    (the pull's peak is sharp: one sample lies within a width of it)"""

    def __check_init__(self):
        check_positive("range_reference_m", self.range_reference_m)
        check_positive("speed_penalty", self.speed_penalty, allow_zero=True)
        check_positive("tension_penalty", self.tension_penalty, allow_zero=True)
        check_positive("margin", self.margin, allow_zero=True)
        check_positive("tension_width_N", self.tension_width_N)


class ThrowDesignProblem(eqx.Module):
    """The variables and bounds, the base scene (every field not designed), the limits, weights and
    solver settings. Build one with :func:`throw_problem`."""

    space: DesignSpace
    scene: LineThrowingScene
    """base scene: its rope's density and diameter are the reference of the d^2 scaling"""
    limits: ThrowLimits = eqx.field(default_factory=ThrowLimits)
    weights: ThrowWeights = eqx.field(default_factory=ThrowWeights)
    t_max_s: float = eqx.field(static=True, default=40.0)
    """end of the simulation if the rocket has not landed [s]"""
    solver: str = eqx.field(static=True, default="tsit5")
    rtol: float = eqx.field(static=True, default=1e-6)
    atol: float = eqx.field(static=True, default=1e-6)
    max_steps: int = eqx.field(static=True, default=100_000)
    gradient: str = eqx.field(static=True, default="forward")
    """``forward`` (ForwardMode + jacfwd: cheaper for a few variables) or ``reverse``
    (RecursiveCheckpointAdjoint + grad)"""

    def __check_init__(self):
        for name in self.space.names:
            check_choice("design variable", name, THROW_VARIABLES)
        check_choice("gradient", self.gradient, GRADIENT_MODES)
        check_positive("t_max_s", self.t_max_s)
        check_positive("rtol", self.rtol)
        check_positive("atol", self.atol)


def throw_problem(
    variables="angle_deg,rope_diameter_m",
    *,
    segment_length_m: float = 10.0,
    rope_length_m: float = 1000.0,
    bounds: dict | None = None,
    limits: ThrowLimits | None = None,
    weights: ThrowWeights | None = None,
    scene: LineThrowingScene | None = None,
    **settings,
) -> ThrowDesignProblem:
    """A launch design problem on the calibrated scene (``line_throwing_scene`` defaults) with
    ``segment_length_m`` segments and ``rope_length_m`` of rope in the box (enough for the longest
    throw inside the bounds); ``scene`` replaces that base scene. ``settings`` go to
    :class:`ThrowDesignProblem` (``rtol``, ``gradient``, ...)."""
    space = DesignSpace.from_names(variables, bounds, variables=THROW_VARIABLES, default_bounds=THROW_BOUNDS)
    if scene is None:
        scene = line_throwing_scene(30.0, segment_length_m=segment_length_m, rope_length_m=rope_length_m)
    return ThrowDesignProblem(
        space=space,
        scene=scene,
        limits=ThrowLimits() if limits is None else limits,
        weights=ThrowWeights() if weights is None else weights,
        **settings,
    )


def calibrated_start(problem: ThrowDesignProblem, angle_deg: float = 30.0) -> jax.Array:
    """The flight-tested design as a point of ``problem.space``: ``angle_deg`` (the 30 deg test) and
    the base scene's rope (10 mm, 0.0693 kg/m)."""
    rope = problem.scene.rope
    known = dict(
        angle_deg=angle_deg,
        rope_diameter_m=float(rope.diameter_m),
        rope_linear_density_kg_per_m=float(rope.linear_density_kg_per_m),
    )
    return problem.space.from_dict({n: known[n] for n in problem.space.names})


def throw_design_scene(problem: ThrowDesignProblem, x) -> LineThrowingScene:
    """The base scene with the design ``x`` (k,) applied (pure; works under vmap and AD)."""
    names = problem.space.names
    value = {n: x[i] for i, n in enumerate(names)}
    scene = problem.scene
    rope = scene.rope
    if "angle_deg" in value:
        scene = eqx.tree_at(lambda s: s.launch.angle_rad, scene, jnp.deg2rad(value["angle_deg"]))
    density = rope.linear_density_kg_per_m
    if "rope_diameter_m" in value:
        d = value["rope_diameter_m"]
        density = density * (d / rope.diameter_m) ** 2  # same material: mass ~ cross-section
        scene = eqx.tree_at(lambda s: s.rope.diameter_m, scene, d)  # drag area d l ~ d
    if "rope_linear_density_kg_per_m" in value:
        density = value["rope_linear_density_kg_per_m"]
    if "rope_diameter_m" in value or "rope_linear_density_kg_per_m" in value:
        scene = eqx.tree_at(lambda s: s.rope.linear_density_kg_per_m, scene, density)
    return scene


def throw_outputs(problem: ThrowDesignProblem, x, adjoint=None) -> dict:
    """One flight at design ``x`` (k,): ``range_m``, ``impact_speed_mps``, ``max_tension_N`` (hard)
    and ``smooth_max_tension_N`` (soft maximum), ``flight_time_s``, ``deployed_rope_m``, ``landed``
    (the impact event occurred), ``status`` and ``num_steps``. Pure."""
    res = simulate(
        throw_design_scene(problem, x), problem.t_max_s, solver=problem.solver, rtol=problem.rtol,
        atol=problem.atol, max_steps=problem.max_steps, adjoint=adjoint,
    )  # fmt: skip
    valid = res.ts <= res.t_final
    pull = jnp.where(valid, res.probes.rope_pull, -jnp.inf)
    width = problem.weights.tension_width_N
    landed = res.status == int(diffrax.RESULTS.event_occurred._value)
    return dict(
        range_m=res.outputs["range_m"],
        impact_speed_mps=res.outputs["impact_speed_mps"],
        max_tension_N=jnp.max(pull),
        smooth_max_tension_N=width * jax.scipy.special.logsumexp(pull / width),
        flight_time_s=res.t_final,
        deployed_rope_m=res.outputs["deployed_rope_m"],
        landed=landed,
        status=res.status,
        num_steps=res.num_steps,
    )


def throw_objective(problem: ThrowDesignProblem, u, adjoint=None):
    """The objective at unconstrained ``u`` (k,): ``(J, aux)``, ``aux`` = the outputs of
    :func:`throw_outputs`, ``x`` and the terms ``range``, ``speed_penalty``, ``tension_penalty``."""
    x = problem.space.to_physical(u)
    out = throw_outputs(problem, x, adjoint)
    w, lim = problem.weights, problem.limits
    gain = out["range_m"] / w.range_reference_m
    speed = w.speed_penalty * jnp.maximum(out["impact_speed_mps"] / lim.landing_speed_mps - 1.0 + w.margin, 0.0) ** 2
    tension = w.tension_penalty * jnp.maximum(out["smooth_max_tension_N"] / lim.max_tension_N - 1.0 + w.margin, 0.0) ** 2
    total = -gain + speed + tension
    aux = dict(out, x=x, terms=dict(total=total, range=-gain, speed_penalty=speed, tension_penalty=tension))
    return total, aux


@eqx.filter_jit
def throw_objective_value(problem: ThrowDesignProblem, u):
    """Jitted forward objective: ``(J, aux)`` (see :func:`throw_objective`)."""
    return throw_objective(problem, u)


@eqx.filter_jit
def throw_objective_and_grad(problem: ThrowDesignProblem, u):
    """Jitted objective and gradient w.r.t. ``u``: ``(J, dJ/du (k,), aux)``; forward mode
    (``diffrax.ForwardMode`` + ``jax.jacfwd``) or reverse mode (``RecursiveCheckpointAdjoint`` +
    ``jax.grad``) by ``problem.gradient``."""
    if problem.gradient == "forward":
        adjoint = diffrax.ForwardMode()
    else:
        adjoint = diffrax.RecursiveCheckpointAdjoint()

    return value_and_grad_by_mode(lambda u_: throw_objective(problem, u_, adjoint), u, problem.gradient)


def throw_record(problem: ThrowDesignProblem):
    """``aux -> (THROW_CRITERIA values (3,), 1.0 if landed within the limits else 0.0)``: the record
    an optimiser's history keeps of each evaluation."""
    lim = problem.limits

    def record(aux):
        values = [float(aux[k]) for k in THROW_CRITERIA]
        ok = (
            bool(aux["landed"])
            and values[1] <= float(lim.landing_speed_mps)
            and (float(problem.weights.tension_penalty) == 0.0 or values[2] <= float(lim.max_tension_N))
        )
        return values, float(ok)

    return record


def optimise_throw(problem: ThrowDesignProblem, x0, steps: int = 30, learning_rate: float = 0.1, optimizer=None, callback=None):
    """Adam (optax) on the unconstrained variables from ``x0``: a
    :class:`~jaxcable.studies.optimise.DesignHistory` whose ``worst_hard`` columns are ``THROW_CRITERIA`` and
    whose ``success_rate`` is 1 where the flight landed within the limits."""
    return optax_minimise(
        problem.space, lambda u: throw_objective_and_grad(problem, u), x0, steps=steps, optimizer=optimizer,
        learning_rate=learning_rate, callback=callback, record=throw_record(problem), criteria_names=THROW_CRITERIA,
    )  # fmt: skip


def nelder_mead_throw(problem: ThrowDesignProblem, x0, max_evaluations: int = 60, initial_step: float = 0.5, target=None):
    """The derivative-free baseline (scipy Nelder-Mead) on the same reparametrisation and objective."""
    return nelder_mead_minimise(
        problem.space, lambda u: throw_objective_value(problem, u), x0, max_evaluations=max_evaluations,
        initial_step=initial_step, target=target, record=throw_record(problem), criteria_names=THROW_CRITERIA,
    )  # fmt: skip


def throw_report(problem: ThrowDesignProblem, aux) -> dict:
    """JSON-able summary of one evaluation (an ``aux`` of :func:`throw_objective`)."""
    out = dict(design=problem.space.as_dict(np.asarray(aux["x"])))
    out["objective"] = float(aux["terms"]["total"])
    out["terms"] = {k: float(v) for k, v in aux["terms"].items()}
    for k in ("range_m", "impact_speed_mps", "max_tension_N", "smooth_max_tension_N", "flight_time_s", "deployed_rope_m"):
        out[k] = float(aux[k])
    out["landed"] = bool(aux["landed"])
    out["num_steps"] = int(aux["num_steps"])
    out["within_limits"] = bool(throw_record(problem)(aux)[1])
    return out


register_design_problem(
    "throw",
    DesignEntry(
        build=throw_problem,
        start=calibrated_start,
        optimise=optimise_throw,
        report=throw_report,
        variables=THROW_VARIABLES,
        default_variables="angle_deg,rope_diameter_m",
        record=throw_record,
    ),
)
