"""diffrax glue: one entry point, :func:`simulate`, with solver, tolerances, adjoint and saved
times as arguments, and a :class:`Result` PyTree of time histories plus scalar outputs.

Solver names map to diffrax solvers. Explicit Tsit5 is the default for the line-throwing rocket:
its stiffest time scale (the shortest, lightest links under tension) is resolved by the accuracy
the outputs need anyway, so implicit solvers buy nothing there (see ``experiments/`` benchmarks).
"""

from __future__ import annotations

import contextlib
import threading

import equinox as eqx
import equinox._errors as _eqx_errors
import jax
import jax.numpy as jnp
import numpy as np
import diffrax
import optimistix as optx
from jaxtyping import Array, PyTree

from jaxcable.core.explicit_rk import RK4, FastTsit5
from jaxcable.core.rosenbrock import RosenbrockW
from jaxcable.core.validation import check_bool, check_choice, check_int, check_positive, check_range, real

SOLVERS = {
    "euler": diffrax.Euler,
    "heun": diffrax.Heun,
    "bosh3": diffrax.Bosh3,
    "tsit5": diffrax.Tsit5,
    "fast_tsit5": FastTsit5,
    "rk4": RK4,
    "dopri5": diffrax.Dopri5,
    "dopri8": diffrax.Dopri8,
    "kvaerno3": diffrax.Kvaerno3,
    "kvaerno4": diffrax.Kvaerno4,
    "kvaerno5": diffrax.Kvaerno5,
    "rosw": RosenbrockW,
}

_STATUS = {
    int(diffrax.RESULTS.successful._value): "successful",
    int(diffrax.RESULTS.event_occurred._value): "event_occurred",
    int(diffrax.RESULTS.max_steps_reached._value): "max_steps_reached",
}


def status_message(code) -> str:
    """Human-readable solver status from a diffrax result code."""
    code = int(code)
    if code in _STATUS:
        return _STATUS[code]
    try:
        return str(diffrax.RESULTS._index_to_message[code])  # noqa: SLF001
    except Exception:  # pragma: no cover - depends on the diffrax version
        return f"solver_error_{code}"


MAX_RTOL = 0.1
"""Loosest relative tolerance accepted: a step-size controller allowed 10 % local error per step
gives no solution worth reporting (the runs here use 1e-4 to 1e-12)."""

MAX_STEPS_LIMIT = 10**9
"""Largest step budget accepted (the runs here use 5e4 to 1e6)."""


def check_solver_arguments(*, solver=None, rtol=None, atol=None, max_steps=None, dt0=None, t1=None):
    """Checks of :func:`simulate`'s solver arguments (``None``: not given, nothing to check), for
    entry points that take them and must reject bad ones before building or compiling anything:
    ``solver`` a name in ``SOLVERS`` or a diffrax solver, ``0 < rtol <= MAX_RTOL``, ``atol``
    positive and finite, ``max_steps`` an integer in ``[1, MAX_STEPS_LIMIT]``, ``dt0`` positive,
    finite and at most ``t1``, ``t1`` positive and finite."""
    if solver is not None:
        if isinstance(solver, str):
            check_choice("solver", solver.lower(), SOLVERS)
        elif not isinstance(solver, diffrax.AbstractSolver):
            raise ValueError(f"unknown solver {solver!r}; choose one of {sorted(SOLVERS)} or a diffrax solver")
    if rtol is not None:
        check_positive("rtol", rtol)
        check_range("rtol", rtol, 0.0, MAX_RTOL, high_inclusive=True, why="a looser tolerance solves nothing")
    if atol is not None:
        check_positive("atol", atol)
    if max_steps is not None:
        check_int("max_steps", max_steps, 1, MAX_STEPS_LIMIT)
    if t1 is not None:
        check_positive("t1", t1)
    if dt0 is not None:
        check_positive("dt0", dt0)
        t1_ = None if t1 is None else real("t1", t1)
        dt0_ = real("dt0", dt0)
        if t1_ is not None and dt0_ is not None and np.any(dt0_ > t1_):
            raise ValueError(f"dt0 must be at most t1 = {float(np.max(t1_)):g} s, got {dt0!r}")


def _check_times(name, ts, t1):
    """Saved times: a finite, non-decreasing 1-D array inside ``[0, t1]`` (when concrete)."""
    v = real(name, ts)
    t1_ = real("t1", t1)
    if v is None:
        return
    if v.ndim != 1:
        raise ValueError(f"{name} must be a 1-D array of times [s], got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be finite, got {ts!r}")
    if v.size and np.any(np.diff(v) < 0):
        raise ValueError(f"{name} must be non-decreasing, got {ts!r}")
    if t1_ is not None and t1_.shape == () and v.size and (v[0] < 0.0 or v[-1] > float(t1_)):
        raise ValueError(f"{name} must lie in [0, t1 = {float(t1_):g}] s, got [{v[0]:g}, {v[-1]:g}]")


def make_solver(solver):
    """A diffrax solver from a name (see ``SOLVERS``) or an instance."""
    if isinstance(solver, str):
        check_choice("solver", solver.lower(), SOLVERS)
        return SOLVERS[solver.lower()]()
    if isinstance(solver, diffrax.AbstractSolver):
        return solver
    raise ValueError(f"unknown solver {solver!r}; choose one of {sorted(SOLVERS)} or a diffrax solver")


class Result(eqx.Module):
    """Outcome of :func:`simulate`.

    Attributes:
        ts: saved times [s], (n_save,); entries after the run ended are ``inf``.
        probes: PyTree of time histories on ``ts``.
        snapshot_ts: snapshot times [s]; ``snapshots``: PyTree saved at those times.
        final_state: state at the final time; ``t_final``: final time [s].
        status: diffrax result code (0 success; see :func:`status_message`).
        num_steps: accepted steps; ``num_rejected``: rejected steps.
        outputs: dict of scalar outputs (the scene's ``summarize``).
    """

    ts: Array
    probes: PyTree
    snapshot_ts: Array
    snapshots: PyTree
    final_state: PyTree
    t_final: Array
    status: Array
    num_steps: Array
    num_rejected: Array
    outputs: dict

    @property
    def status_message(self) -> str:
        return status_message(self.status)

    @property
    def ok(self):
        return (self.status == 0) | (self.status == int(diffrax.RESULTS.event_occurred._value))


def _size(tree) -> int:
    return sum(int(np.prod(leaf.shape)) for leaf in jax.tree_util.tree_leaves(tree))


def probes_after_solve(scene) -> bool:
    """Whether :func:`simulate` saves the *state* on the output grid and evaluates the scene's
    probe on all saved states after the solve (one batched call), instead of calling the probe
    inside the solver's loop at each saved time: chosen when the state is no larger than the
    probe's output, so the saved buffer does not grow.

    The two give the same histories (the probe of the same interpolated state; round-off apart).
    Measured side by side (2-core AMD EPYC, JAX 0.10.2 CPU, float64;
    ``docs/notes/design_call_cost.md``): on the rigid landing level, whose
    25-number state is smaller than its 29-number probe, the design batch (1201 saved samples)
    runs 1.14x faster forward, 1.16-1.33x in forward mode and 1.07-1.09x in reverse mode
    (n = 8, 32), with the same results to 1e-13: the probe (a vector-field evaluation plus the
    energies) runs as one vectorised call over the saved samples instead of once per sample inside
    the loop. Scenes with large states (ALE cables: 468 numbers, the rope: 1505) keep the probe
    inside the loop, where the saved buffer is the smaller one."""
    y0 = jax.eval_shape(scene.initial_state)
    probe = jax.eval_shape(scene.probe, 0.0, y0)
    return _size(y0) <= _size(probe)


def _probe_saved_states(scene, ts, ys, t_final, final_state):
    """The scene's probe on each saved state; saved times the run never reached (``ts = inf``: it
    ended at an event or failed) are probed at the final state and then set to ``inf``, as diffrax
    fills them, without letting an ``inf`` state into the probe (whose gradient would be NaN)."""
    reached = jnp.isfinite(ts)

    def where_reached(values, otherwise):
        return jnp.where(reached.reshape(reached.shape + (1,) * (values.ndim - 1)), values, otherwise)

    ys = jax.tree_util.tree_map(lambda saved, final: where_reached(saved, final[None]), ys, final_state)
    probes = jax.vmap(scene.probe)(jnp.where(reached, ts, t_final), ys)
    return jax.tree_util.tree_map(
        lambda p: where_reached(p, jnp.inf) if jnp.issubdtype(p.dtype, jnp.inexact) else p, probes
    )


_ON_ERROR_LOCK = threading.Lock()


@contextlib.contextmanager
def _grid_checks_without_callbacks():
    """Trace diffrax's checks of the save grids (increasing, inside [t0, t1]) as NaN-on-failure
    instead of host callbacks.

    Why: ``eqx.error_if`` on a traced value becomes a ``jax.pure_callback`` in the compiled program,
    and JAX never writes a program holding a host callback to its persistent compilation cache, so
    every process compiled the whole solve again (experiments/results/bench_startup.md). diffrax
    multiplies the grid by the traced integration direction before checking it, so the checks are
    traced whatever the grid. :func:`simulate` checks every grid it is given on the host
    first (``_check_times``), and the scenes' default grids are increasing inside [0, t1] by
    construction, so these checks can never fire for a concrete grid. With ``diffeqsolve(...,
    throw=False)`` (as here) the solve's own failures are reported through ``Result.status``
    either way. equinox reads this mode from a module global, so it is set under a lock."""
    with _ON_ERROR_LOCK:
        previous = _eqx_errors.EQX_ON_ERROR
        _eqx_errors.EQX_ON_ERROR = "nan"
        try:
            yield
        finally:
            _eqx_errors.EQX_ON_ERROR = previous


def _solve(scene, t1, save_ts, snapshot_ts, solver, controller, adjoint, max_steps, dt0, progress_meter, probes_after):
    if isinstance(solver, RosenbrockW) and solver.linearise is None and hasattr(scene, "stiff_linearisation"):
        # the scene's structured linear solve (the traced scene, so derivatives flow through it)
        solver = RosenbrockW(linearise=scene.stiff_linearisation, jacobian_every=solver.jacobian_every)
    term = diffrax.ODETerm(lambda t, y, args: scene.vector_field(t, y))
    after = probes_after_solve(scene) if probes_after is None else probes_after
    save_fn = (lambda t, y, args: y) if after else (lambda t, y, args: scene.probe(t, y))
    subs = [
        diffrax.SubSaveAt(ts=save_ts, fn=save_fn),
        diffrax.SubSaveAt(ts=snapshot_ts, fn=lambda t, y, args: scene.snapshot(t, y)),
        diffrax.SubSaveAt(t1=True),
    ]
    event = None
    if scene.has_terminal_event:
        # the event time's tolerance: 1e-9 in float64; float32 cannot resolve it, so there it is
        # scaled to the precision (a float32 run otherwise reports a failed root find although its
        # outputs are right: docs/work_precision.md)
        tol = max(1e-9, 100.0 * float(jnp.finfo(jnp.asarray(save_ts).dtype).eps))
        event = diffrax.Event(
            lambda t, y, args, **kw: scene.terminal_event(t, y),
            root_finder=optx.Newton(rtol=tol, atol=tol),
        )
    with _grid_checks_without_callbacks():
        sol = diffrax.diffeqsolve(
            term,
            solver,
            t0=0.0,
            t1=t1,
            dt0=dt0,
            y0=scene.initial_state(),
            saveat=diffrax.SaveAt(subs=subs),
            stepsize_controller=controller,
            adjoint=adjoint,
            event=event,
            max_steps=max_steps,
            throw=False,
            progress_meter=progress_meter,
        )
    probes, snaps, final = sol.ys
    t_final = sol.ts[2][0]
    final_state = jax.tree_util.tree_map(lambda x: x[0], final)
    if after:
        probes = _probe_saved_states(scene, sol.ts[0], probes, t_final, final_state)
    res = Result(
        ts=sol.ts[0],
        probes=probes,
        snapshot_ts=sol.ts[1],
        snapshots=snaps,
        final_state=final_state,
        t_final=t_final,
        status=sol.result._value,
        num_steps=sol.stats["num_accepted_steps"],
        num_rejected=sol.stats["num_rejected_steps"],
        outputs={},
    )
    return eqx.tree_at(lambda r: r.outputs, res, scene.summarize(res))


_solve_jit = eqx.filter_jit(_solve)


DENSE_JACOBIAN_MAX_STATE = 200
"""Largest state (numbers) that ``solver="rosw"`` integrates with a dense Jacobian when the scene
gives no ``stiff_linearisation``: the dense one costs a JVP per state number and an O(n^3) LU per
step."""


def _check_linearisation(scene, solver):
    if not isinstance(solver, RosenbrockW) or solver.linearise is not None or hasattr(scene, "stiff_linearisation"):
        return
    n = _size(jax.eval_shape(scene.initial_state))
    if n > DENSE_JACOBIAN_MAX_STATE:
        raise ValueError(
            f"solver 'rosw' needs the scene's structured linearisation (stiff_linearisation), which "
            f"{type(scene).__name__} does not have; a dense Jacobian of its {n}-number state would cost {n} "
            f"JVPs and an LU per step (limit {DENSE_JACOBIAN_MAX_STATE}); choose an explicit solver (e.g. 'tsit5')"
        )


def simulate(
    scene,
    t1: float = 30.0,
    *,
    solver="tsit5",
    rtol: float = 1e-6,
    atol: float = 1e-6,
    dt0=None,
    save_ts=None,
    snapshot_ts=None,
    adjoint=None,
    max_steps: int = 100_000,
    progress: bool = False,
    jit: bool = True,
    pcoeff: float = 0.0,
    icoeff: float = 1.0,
    probes_after: bool | None = None,
) -> Result:
    """Integrate a scene from t = 0 to ``t1`` [s] (or to its terminal event).

    Args:
        scene: an :class:`~jaxcable.core.scene.AbstractScene`.
        t1: final time [s] if no event ends the run first.
        solver: a name in ``SOLVERS`` or a diffrax solver instance.
        rtol, atol: tolerances of the PID step-size controller (mixed, on the state).
        dt0: initial step [s]; ``None`` lets diffrax choose. A solver without an error estimate
            (``"euler"``, ``"rk4"``) steps at the constant ``dt0``, which it then needs.
        save_ts: times for the probe histories [s] (default: the scene's ``default_save_ts``).
        snapshot_ts: times for snapshots [s] (default: the scene's ``default_snapshot_ts``).
        adjoint: a diffrax adjoint (default ``RecursiveCheckpointAdjoint``: exact reverse-mode).
        max_steps: step budget; a run that exhausts it reports ``max_steps_reached``.
        progress: show a tqdm progress bar (outside ``vmap``).
        jit: compile the solve (one ``filter_jit`` boundary); ``False`` for debugging only.
        pcoeff, icoeff: coefficients of diffrax's PID step-size controller (default 0, 1: the
            classic I controller). A PI controller (e.g. 0.4, 0.3) rejects fewer steps where an
            explicit solver runs at its stability limit (docs/arresting_design.md).
        probes_after: evaluate the scene's probe on saved states after the solve (``True``) or
            inside the solver's loop (``False``); ``None`` (default) chooses by size
            (:func:`probes_after_solve`). The histories agree to round-off either way.
    """
    if probes_after is not None and not isinstance(probes_after, bool):
        raise ValueError(f"probes_after must be True, False or None, got {probes_after!r}")
    check_solver_arguments(solver=solver, rtol=rtol, atol=atol, max_steps=max_steps, dt0=dt0, t1=t1)
    if solver is None:
        raise ValueError(f"unknown solver None; choose one of {sorted(SOLVERS)} or a diffrax solver")
    check_positive("icoeff", icoeff)
    check_positive("pcoeff", pcoeff, allow_zero=True)
    check_bool("progress", progress)
    check_bool("jit", jit)
    if save_ts is not None:
        _check_times("save_ts", save_ts, t1)
    if snapshot_ts is not None:
        _check_times("snapshot_ts", snapshot_ts, t1)
    solver_ = make_solver(solver)
    _check_linearisation(scene, solver_)
    if isinstance(solver_, diffrax.AbstractAdaptiveSolver):
        controller = diffrax.PIDController(rtol=rtol, atol=atol, pcoeff=pcoeff, icoeff=icoeff)
    else:
        if dt0 is None:
            raise ValueError(f"solver {solver!r} has no error estimate: give its constant step dt0 [s]")
        controller = diffrax.ConstantStepSize()
    jumps = scene.jump_times()
    if jumps is not None:
        controller = diffrax.ClipStepSizeController(controller, jump_ts=jumps)
    if save_ts is None:
        save_ts = scene.default_save_ts(t1)
    if snapshot_ts is None:
        snapshot_ts = scene.default_snapshot_ts(t1)
    save_ts = jnp.asarray(save_ts, dtype=float)
    snapshot_ts = jnp.asarray(snapshot_ts, dtype=float)
    if adjoint is None:
        adjoint = diffrax.RecursiveCheckpointAdjoint()
    meter = diffrax.TqdmProgressMeter() if progress else diffrax.NoProgressMeter()
    fn = _solve_jit if jit else _solve
    return fn(scene, t1, save_ts, snapshot_ts, solver_, controller, adjoint, max_steps, dt0, meter, probes_after)
