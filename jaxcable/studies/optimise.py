r"""Design optimisation for any system: a bounded design space, tail risk, gradients by mode, and the
optimiser loops that record a :class:`DesignHistory`.

Nothing here knows a system: a design problem (the arresting buffer design of
:mod:`jaxcable.arresting.design`, the line-throwing launch of :mod:`jaxcable.throw.design`) supplies
its catalogue of variables and bounds, an objective ``u -> (J, aux)`` (``aux["x"]`` the physical
design) and optionally a ``record(aux) -> (criteria (c,), success)`` for the history, and registers
itself by name (:func:`jaxcable.studies.registry.register_design_problem`) as a :class:`DesignEntry`.

* :class:`DesignSpace`: chosen variables, their bounds and the scaled-logistic reparametrisation
  ``x = lo + (hi - lo) sigmoid(u)`` the optimisers work in (every ``u`` is a design inside the
  bounds; the bounds are reached only as ``|u| -> inf``).
* :func:`cvar` (exact, sort-based) and :func:`smooth_cvar` (sort-free, smooth): conditional value
  at risk of a batch of values, the mean of its worst ``(1 - alpha)`` fraction.
* :func:`value_and_grad_by_mode`: ``(J, dJ/du, aux)`` by forward mode (``jax.jacfwd``, with
  ``diffrax.ForwardMode`` in the solves) or reverse mode (``jax.grad``); ``GRADIENT_MODES``.
* :func:`optax_minimise` (adam by default), :func:`lbfgs_minimise` (optax's L-BFGS direction with a
  backtracking line search on the host) and :func:`nelder_mead_minimise` (scipy, derivative-free).

Glossary: ``x`` the design in its variables' units (k,), ``u`` its unconstrained coordinates (k,),
``J`` the objective, ``alpha`` the CVaR level.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Mapping

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optax

from jaxcable.core.validation import check_choice, check_finite, check_positive, check_range, concrete, float_array

__all__ = [
    "GRADIENT_MODES",
    "DesignEntry",
    "DesignHistory",
    "DesignSpace",
    "HistoryRows",
    "beats_kept",
    "check_alpha",
    "check_count",
    "cvar",
    "lbfgs_minimise",
    "nelder_mead_minimise",
    "optax_minimise",
    "smooth_cvar",
    "split_names",
    "value_and_grad_by_mode",
]

GRADIENT_MODES = ("forward", "reverse")
"""``forward``: ``jax.jacfwd`` with ``diffrax.ForwardMode`` (the k tangents carried along one
solve); ``reverse``: ``jax.grad`` with ``diffrax.RecursiveCheckpointAdjoint``."""


def beats_kept(kept, success, objective) -> bool:
    """Whether an evaluation with success rate ``success`` and objective ``objective`` replaces the
    design ``kept`` so far (a dict with ``"success"`` and ``"j"``, or None): the highest success rate
    on the batch, then the lowest objective among those (the objective alone may prefer a design
    that trades a small violation for lower mean criteria)."""
    return kept is None or (success, -objective) > (kept["success"], -kept["j"])


def check_count(name, value, minimum, what=""):
    """``value`` must be an integer (not a bool) >= ``minimum`` (0 or 1); the error names ``name``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < minimum:
        kind = "positive" if minimum == 1 else "non-negative"
        raise ValueError(f"{name} must be a {kind} integer{what}, got {value!r}")


def split_names(names) -> tuple:
    """A sequence of names, or a comma-separated string of them (``"m_w,F_f"``), as a tuple."""
    if isinstance(names, str):
        names = [n.strip() for n in names.split(",") if n.strip()]
    return tuple(names)


# ------------------------------------------------------------------------------------------------
# Design space and reparametrisation
# ------------------------------------------------------------------------------------------------


class DesignSpace(eqx.Module):
    """The chosen design variables, their bounds, and the scaled-logistic reparametrisation.

    ``x = lower + (upper - lower) * sigmoid(u)`` maps any ``u`` in R^k into the open box; the
    optimisers work in ``u``. Build one with :meth:`from_names`; ``catalogue`` names the variables
    one may choose (each design problem has its own). Every variable is a positive physical
    quantity: its lower bound must be positive, or zero for the names in ``zero_lower``.
    """

    names: tuple = eqx.field(static=True)
    """names of the variables, a subset of ``catalogue`` in the user's order"""
    lower: jax.Array = eqx.field(converter=float_array)
    """lower bound of each variable, in its unit (kg, N, 1/s, ...), shape (k,)"""
    upper: jax.Array = eqx.field(converter=float_array)
    """upper bound of each variable, in its unit, shape (k,)"""
    catalogue: tuple = eqx.field(static=True)
    """the names one may choose"""
    zero_lower: tuple = eqx.field(static=True, default=())
    """names whose lower bound may be zero (e.g. a brake force: the brake may be off)"""

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
        lo, hi = concrete(self.lower), concrete(self.upper)
        if lo is None or hi is None:
            return
        for i, name in enumerate(self.names):
            check_finite(f"lower bound of {name}", lo[i])
            check_finite(f"upper bound of {name}", hi[i])
            if not lo[i] < hi[i]:
                raise ValueError(
                    f"bounds of {name} are inverted or empty: lower = {lo[i]:g} must be < upper = {hi[i]:g}"
                )
            if name in self.zero_lower:
                check_positive(f"lower bound of {name}", lo[i], allow_zero=True)
            else:
                check_positive(f"lower bound of {name}", lo[i])

    @classmethod
    def from_names(cls, names, bounds: dict | None = None, *, variables, default_bounds, zero_lower=()) -> "DesignSpace":
        """``names``: a sequence or a comma-separated string (``"m_w,F_f"``); ``bounds``:
        ``{name: (lower, upper)}`` overriding ``default_bounds`` for some names; ``variables``: the
        catalogue (a mapping or sequence of the names one may choose)."""
        names = split_names(names)
        bounds = {} if bounds is None else dict(bounds)
        for name in bounds:
            check_choice("design variable in bounds", name, variables)
        for name in names:
            check_choice("design variable", name, variables)
        lo = [float(bounds.get(n, default_bounds[n])[0]) for n in names]
        hi = [float(bounds.get(n, default_bounds[n])[1]) for n in names]
        return cls(
            names=names, lower=np.array(lo), upper=np.array(hi), catalogue=tuple(variables), zero_lower=tuple(zero_lower)
        )

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
        xv, lo, hi = concrete(x), concrete(self.lower), concrete(self.upper)
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


def check_alpha(alpha):
    """A concrete CVaR level must lie in [0, 1)."""
    a = concrete(alpha)
    if a is not None and not (0.0 <= float(a) < 1.0):
        raise ValueError(f"alpha must be in [0, 1), got {alpha!r}")


def cvar(values, alpha) -> jax.Array:
    """Exact conditional value at risk of an empirical distribution (equal weights): the mean of
    the worst ``(1 - alpha)`` fraction of ``values`` (n,), with the boundary sample weighted by the
    fractional part of ``k = n (1 - alpha)``. ``alpha`` in [0, 1): 0 gives the mean, values near 1
    the maximum. Equal to Rockafellar-Uryasev's ``min_t t + E[(X - t)_+] / (1 - alpha)``.
    Continuous and piecewise linear in ``values`` (differentiable almost everywhere through the sort).
    """
    check_alpha(alpha)
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
    check_alpha(alpha)
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
# Gradients
# ------------------------------------------------------------------------------------------------


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


# ------------------------------------------------------------------------------------------------
# Histories and optimisers
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
    buffer design the worst case over the batch of the hard criteria; for the line-throwing design
    its outputs (NaN without a record)"""
    success_rate: np.ndarray
    """fraction of cases meeting every hard criterion (1 or 0 for a single-case problem), shape (m,)"""
    wall_s: np.ndarray
    """wall time since the start at the end of each evaluation [s] (includes compiling if the
    jitted function was not warm), shape (m,)"""
    criteria_names: tuple = eqx.field(static=True, default=())
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


class HistoryRows:
    """The rows of a :class:`DesignHistory` as an optimiser evaluates: one :meth:`add` per
    objective evaluation (wall time since construction), :meth:`history` at the end. ``record(aux)
    -> (criteria (c,), success)`` fills the criteria columns (None: NaN)."""

    def __init__(self, record, criteria_names):
        self.record, self.criteria_names = record, tuple(criteria_names)
        self.cols = dict(x=[], objective=[], grad_norm=[], worst_hard=[], success_rate=[], wall_s=[])
        self.t0 = time.perf_counter()

    def __len__(self):
        return len(self.cols["objective"])

    def add(self, j: float, grad_norm: float, aux):
        worst, success = self.record(aux) if self.record is not None else ([np.nan] * len(self.criteria_names), np.nan)
        self.cols["x"].append(np.asarray(aux["x"]))
        self.cols["objective"].append(j)
        self.cols["grad_norm"].append(grad_norm)
        self.cols["worst_hard"].append(worst)
        self.cols["success_rate"].append(success)
        self.cols["wall_s"].append(time.perf_counter() - self.t0)

    def history(self, method: str, space: DesignSpace) -> DesignHistory:
        return DesignHistory(
            method=method,
            names=space.names,
            criteria_names=self.criteria_names,
            **{k: np.asarray(v, dtype=float) for k, v in self.cols.items()},
        )


def optax_minimise(
    space: DesignSpace,
    value_and_grad,
    x0,
    steps: int = 50,
    optimizer=None,
    learning_rate: float = 0.1,
    callback=None,
    record=None,
    criteria_names: tuple = (),
) -> DesignHistory:
    """The optax loop on the unconstrained variables of ``space``, for any objective.

    ``value_and_grad(u) -> (J, dJ/du, aux)`` (jitted; ``aux["x"]`` the physical design);
    ``record(aux) -> (criteria (c,), success)`` fills the history's ``worst_hard`` and
    ``success_rate`` (None: NaN). Default optimizer ``optax.adam(learning_rate)``; the final point
    is evaluated too, so the history has ``steps + 1`` rows; ``callback(i, J, x, aux)`` after each."""
    check_count("steps", steps, 0)
    check_positive("learning_rate", learning_rate)
    opt = optax.adam(learning_rate) if optimizer is None else optimizer
    u = space.to_unconstrained(x0)
    state = opt.init(u)
    rows = HistoryRows(record, criteria_names)
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
    criteria_names: tuple = (),
    sufficient_decrease: float = 1e-4,
) -> DesignHistory:
    """L-BFGS on the unconstrained variables of ``space``: optax's ``scale_by_lbfgs`` direction with
    a backtracking (Armijo) line search on the host, for any objective.

    Suited to smooth, deterministic objectives (a fixed batch): where adam takes fixed-size,
    momentum-driven steps and overshoots, L-BFGS builds curvature from the gradients and steps along
    it. The line search runs on the host so that each trial is one call of the jitted
    ``value_and_grad`` (an accepted trial's gradient is the next iteration's): no second compilation
    of the objective inside optax's traced line search. A direction that is not a descent direction
    (curvature pairs from a non-convex stretch) resets the memory to a gradient step. Every
    evaluation, accepted or not, is a row of the history (``max_evaluations`` rows at most), so
    evaluation counts compare with Nelder-Mead's; ``callback(i, J, x, aux)`` after each accepted
    point (``i`` = evaluation)."""
    check_count("max_evaluations", max_evaluations, 1)
    check_count("memory_size", memory_size, 1)
    opt = optax.scale_by_lbfgs(memory_size=memory_size)
    u = space.to_unconstrained(x0)
    state = opt.init(u)
    rows = HistoryRows(record, criteria_names)

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
    criteria_names: tuple = (),
) -> DesignHistory:
    """Derivative-free baseline for any objective: scipy's Nelder-Mead on the unconstrained
    variables of ``space``. ``value(u) -> (J, aux)`` (jitted forward); ``record`` as in
    :func:`optax_minimise`. The initial simplex steps each ``u`` by ``initial_step`` (scipy's
    default 5 % of ``u`` is degenerate where ``u`` = 0, the middle of the bounds). Stops after
    ``max_evaluations`` calls, or as soon as ``J <= target`` if given."""
    from scipy.optimize import minimize  # 1.3 s to import, needed by this baseline only

    check_positive("initial_step", initial_step)
    u0 = np.asarray(space.to_unconstrained(x0))
    k = u0.shape[0]
    simplex = np.vstack([u0] + [u0 + initial_step * np.eye(k)[i] for i in range(k)])
    rows = HistoryRows(record, criteria_names)

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


# ------------------------------------------------------------------------------------------------
# What a system registers
# ------------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class DesignEntry:
    """A design problem as a system registers it (``register_design_problem(name, entry)``) and the
    ``jaxcable design --scene NAME`` command runs it: build a problem, take its start design, run
    an optimiser, summarise an evaluation."""

    build: Callable
    """``build(variables, *, bounds, **settings) -> problem`` (with a ``space``: :class:`DesignSpace`)"""
    start: Callable
    """``start(problem) -> x0`` (k,): the documented start design (e.g. the paper's)"""
    optimise: Callable
    """``optimise(problem, x0, steps=, learning_rate=, callback=) -> DesignHistory`` (adam)"""
    report: Callable
    """``report(problem, aux) -> dict``: JSON-able summary of one evaluation (its ``aux``)"""
    variables: Mapping
    """the catalogue: ``{name: description}`` of the variables one may choose"""
    default_variables: str
    """the variables optimised when none are named (comma-separated)"""
    lbfgs: Callable | None = None
    """``lbfgs(problem, x0, max_evaluations=, callback=) -> DesignHistory``, if offered"""
    record: Callable | None = None
    """``record(problem) -> (aux -> (criteria (c,), success))``, if offered"""
