r"""Quasi-Monte Carlo robustness sweeps: batched, sharded over devices, resumable, summarised.

Arresting-cable paper, section IV: 100 Halton cases per wind scenario (Tables 2, 3, 4, 8), the
success criteria of section IV.A (z_max < 10 m, a_max < 5 g, sigma_max < 800 MPa), the statistics of
Tables 5, 6, 7 and 9, the trajectories and tracking errors of Figs 15-17 (two-phase sweeps), the
time histories of Figs 18-20 and the criteria over the landing plane of Fig 21. The points come
from :mod:`jaxcable.arresting.uncertainty`.

How a sweep is built (physics stays single-case, STYLE.md 3):

* A **case function** maps one case's parameters to its scalar outputs,
  ``case_fn(params: dict[str, scalar]) -> dict[str, scalar]``. It is an ``eqx.Module`` (its array
  fields, e.g. the buffer device, are parameters too). :class:`PassiveCaseFunction` runs the
  passive-deceleration phase; the two-phase case function
  (:class:`jaxcable.arresting.two_phase.TwoPhaseCaseFunction`: tracking, capture and the passive
  phase at the case function's level) registers itself for ``phase="full"`` with
  :func:`register_case_fn`.
* :func:`run_sweep` lifts it with ``jax.vmap`` over chunks of ``batch_size`` cases; each chunk is
  sharded over the local devices (a 1-D ``Mesh``, ``NamedSharding`` on the case axis, the chunk
  padded to a multiple of the device count) and run under ``jax.shard_map``, so each device
  integrates its own cases in its own ``while`` loop (no cross-device step synchronisation). A
  case function that cannot run under ``shard_map`` (``per_device_loops`` False: the two-phase
  one) gets one vmapped call per device on its slice instead, each from its own thread.
* Rows are appended to a tidy CSV as each chunk finishes (whole lines, flush, fsync) with a sidecar
  JSON holding the sweep's identity; a restarted sweep drops a trailing partial line, skips the cases
  already written, and refuses to resume when its arguments differ. A case whose solver did not
  succeed, or whose outputs are not finite, is a row with ``failed=True`` and its solver status.

Readings and choices, written down:

* The passive phase starts at capture (hooks engaged, Table 8 states, vz = -20 m/s). The sampled
  wind (angle, speed, gust intensity) is applied (``PassiveCaseFunction.wind``, default True): air
  loads on the free rocket and, at the ale/full levels, on the arresting spans (eqs 43-45); the gust
  is seeded from the sweep's seed and the case's inputs. Time delay and noise are 0 in the passive
  phase (Table 4).
* ``captured`` in the passive phase: every hook carries a nonzero cable force at some saved time (the
  paper's capture criterion, "contact forces ... nonzero", section IV.A). ``stopped``: the descent
  stopped within ``t_end_s``. ``success`` = captured and stopped and all three criteria met. The
  ``margin`` of a criterion is limit - value (positive when met), in the criterion's unit.
* The maxima are over saved samples 1 ms apart over ``[0, t_end_s]`` (t_end_s = 2 s by default;
  both chosen by measurement, see :func:`passive_case_fn`).
* The sweep's default fidelity is ``rigid`` (rigid 6-DOF rocket, massless elastic cables) because of
  cost: a 2 s case takes ~0.1 s once compiled (batch 8-32, one CPU core), against ~3.6 s per 0.3 s
  simulated for ``ale`` (~17k steps per simulated second; ``experiments/bench_sweep.py``).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from jaxcable.core.validation import check_choice, check_positive
from jaxcable.studies.sharding import device_mesh, evaluate, round_up, stack_cases
from jaxcable.arresting.buffer import BufferDevice
from jaxcable.arresting.layout import ArrestingLayout, CaptureState
from jaxcable.arresting.passive import DEFAULT_CABLE_DAMPING_S, G_CRITERIA, SAVE_SPACING_S, LandingCriteria
from jaxcable.arresting.uncertainty import (
    CAPTURE_VZ_M_S,
    PHASES,
    SCENARIOS,
    UNCERTAIN_PARAMETERS,
    halton_samples,
)

__all__ = [
    "AbstractCaseFunction",
    "CRITERIA",
    "PassiveCaseFunction",
    "SAVE_SPACING_S",
    "SWEEP_FIDELITIES",
    "case_fn_for",
    "merge_sweep_csvs",
    "passive_case_fn",
    "passive_histories",
    "plot_histories",
    "plot_landing_plane",
    "plot_tracking",
    "process_indices",
    "qmc_case_fn",
    "read_sweep_csv",
    "register_case_fn",
    "run_histories",
    "run_qmc_sweep",
    "run_sweep",
    "summarize_sweep",
    "summary_markdown",
    "sweep_main",
]

SWEEP_FIDELITIES = ("rigid", "ale", "full")
"""Fidelity levels a sweep runs (the 1-DOF level models the central vertical landing only)."""

CRITERIA = (
    ("z_max_m", "z_ok", "z_margin_m", "z_max_m", "m"),
    ("a_max_g", "a_ok", "a_margin_g", "a_max_g", "g"),
    ("sigma_max_mpa", "sigma_ok", "sigma_margin_mpa", "sigma_max_mpa", "MPa"),
)
"""Per criterion: (output, its ok flag, its margin, the LandingCriteria field, unit)."""

ALLOWED_NONFINITE = {"stop_time_s": "stopped"}
"""Outputs that may be non-finite without marking the case failed, with the flag that explains it
(a case that did not stop within ``t_end_s`` has no stop time)."""

_OK_STATUS = tuple(int(r._value) for r in (diffrax.RESULTS.successful, diffrax.RESULTS.event_occurred))


# ------------------------------------------------------------------------------------------------
# Case functions
# ------------------------------------------------------------------------------------------------


def case_key(seed: int, params) -> jax.Array:
    """PRNG key of one case's noise and gusts: the sweep's ``seed`` with the case's inputs folded in
    (x, y, theta_z), so a case draws the same realisation wherever it sits in a batch."""
    bits = jnp.asarray(params["x_m"] * 1e6 + params["y_m"] * 1e3 + params["theta_z_deg"], jnp.float32)
    return jax.random.fold_in(jax.random.PRNGKey(seed), jax.lax.bitcast_convert_type(bits, jnp.uint32))


def criteria_columns(outputs, criteria: LandingCriteria) -> dict:
    """The passive-phase columns shared by every case function: each criterion's flag and margin
    (limit - value, positive when met), the three maxima, stop time and energy-budget error."""
    o, c = outputs, criteria
    return dict(
        criteria_met=o["criteria_met"],
        z_ok=o["z_ok"],
        z_margin_m=c.z_max_m - o["z_max_m"],
        a_ok=o["a_ok"],
        a_margin_g=c.a_max_g - o["a_max_g"],
        sigma_ok=o["sigma_ok"],
        sigma_margin_mpa=c.sigma_max_mpa - o["sigma_max_mpa"],
        z_max_m=o["z_max_m"],
        a_max_g=o["a_max_g"],
        sigma_max_mpa=o["sigma_max_mpa"],
        stop_time_s=o["stop_time_s"],
        energy_budget_error=o["energy_budget_error"],
    )


class AbstractCaseFunction(eqx.Module):
    """One case: ``__call__(params) -> dict`` of scalar outputs (``status_code`` and ``num_steps``
    among them); optionally ``histories(params) -> dict`` of time histories for plots.

    A case function whose set-up needs concrete numbers (e.g. a mesh built with NumPy) splits into
    ``build(params) -> case`` (host, concrete scalars) and ``solve(case)`` /
    ``solve_histories(case)`` (traced), and says so with ``host_build = True``: the sweep then builds
    every case of a chunk on the host, stacks them (their static structure must agree) and vmaps
    ``solve`` over the stack. ``__call__`` stays the single-case entry point either way."""

    @property
    def host_build(self) -> bool:
        return False

    @property
    def per_device_loops(self) -> bool:
        """On several devices: True runs each device's share under ``shard_map`` (its own solver
        loop); False (a solve that does not trace under ``shard_map``) one call per device on its
        share, each from its own thread."""
        return True

    def __call__(self, params: dict) -> dict:
        raise NotImplementedError

    def histories(self, params: dict) -> dict:
        raise NotImplementedError(f"{type(self).__name__} keeps no time histories")

    def describe(self) -> dict:
        """JSON-able identity of the case function (stored with a sweep; resume checks it)."""
        leaves = jax.tree_util.tree_leaves_with_path(self)
        return {
            "type": type(self).__name__,
            **{jax.tree_util.keystr(p): np.asarray(v).tolist() for p, v in leaves},
        }


class PassiveCaseFunction(AbstractCaseFunction):
    """The passive-deceleration phase of one case at a fidelity level (section IV.C).

    ``params``: the capture states of ``UNCERTAIN_PARAMETERS`` (x_m ... omega_z_deg_s; scalars) and,
    with ``wind``, the wind angle, speed and gust intensity; delay and noise are ignored (see the
    module docstring). Outputs (scalars):
    ``captured``, ``stopped``, ``success``, ``criteria_met``, per criterion its flag and margin,
    ``z_max_m`` [m], ``a_max_g`` [g of 9.80 m/s^2], ``sigma_max_mpa`` [MPa], ``stop_time_s`` [s]
    (NaN when not stopped), ``energy_budget_error`` [-], ``status_code`` (diffrax), ``num_steps``.

    The ``rigid`` level builds its scene inside the traced function (vmapped over the captures;
    differentiable in them). The ``ale`` and ``full`` levels mesh their cables with NumPy from the
    concrete capture (:meth:`AleCables.build`), so they build each case on the host
    (``host_build``) and vmap only the solve.
    """

    buffer: BufferDevice
    layout: ArrestingLayout
    vz_m_s: jax.Array = eqx.field(converter=jnp.asarray)
    """Vertical velocity of O at capture [m/s], z up (section IV: -20)."""
    criteria: LandingCriteria = eqx.field(static=True)
    fidelity: str = eqx.field(static=True)
    t_end_s: float = eqx.field(static=True)
    solver: str = eqx.field(static=True)
    rtol: float = eqx.field(static=True)
    atol: float = eqx.field(static=True)
    max_steps: int = eqx.field(static=True)
    n_save: int = eqx.field(static=True, default=2001)
    """Samples of the saved histories over [0, t_end_s]; the maxima are taken over them."""
    wind: bool = eqx.field(static=True, default=True)
    """Apply the sampled wind (False: still air, no aerodynamic loads at all)."""
    seed: int = eqx.field(static=True, default=0)
    """Seed of the gusts (each case's key folds in its inputs, so a case reproduces anywhere)."""
    cable_damping_s: float = eqx.field(static=True, default=DEFAULT_CABLE_DAMPING_S)
    """The cables' stiffness-proportional damping beta [s] (not in the paper; a_max depends on it)."""

    def __check_init__(self):
        check_choice("fidelity", self.fidelity, SWEEP_FIDELITIES)
        check_positive("cable_damping_s", self.cable_damping_s, allow_zero=True)
        check_positive("t_end_s", self.t_end_s)
        check_positive("rtol", self.rtol)
        check_positive("atol", self.atol)
        check_positive("max_steps", self.max_steps)
        if self.n_save < 2:
            raise ValueError(f"n_save must be at least 2, got {self.n_save}")

    @property
    def host_build(self) -> bool:
        return self.fidelity != "rigid"

    def build(self, params):
        """The passive scene of one case (a :class:`PassiveLandingScene`)."""
        from jaxcable.arresting.passive import passive_landing_scene

        capture = CaptureState(
            **{k: params[k] for k in UNCERTAIN_PARAMETERS[:10]}, vz_m_s=self.vz_m_s
        )
        air = {}
        if self.wind:
            from jaxcable.components.wind import WindField

            air["wind"] = WindField(
                speed_m_s=params["wind_speed_m_s"], angle_deg=params["wind_angle_deg"],
                gust_intensity=params["gust_intensity"], key=case_key(self.seed, params),
            )  # fmt: skip
        return passive_landing_scene(
            self.fidelity, capture, self.layout, self.buffer, t_end_s=self.t_end_s,
            cable_damping_s=self.cable_damping_s, **air,
        )  # fmt: skip

    def _simulate(self, scene):
        import diffrax

        from jaxcable.arresting.landing import LEVEL_STEP_CONTROL
        from jaxcable.core.simulate import simulate

        pcoeff, icoeff = LEVEL_STEP_CONTROL[self.fidelity]
        return simulate(
            scene,
            self.t_end_s,
            solver=self.solver,
            rtol=self.rtol,
            atol=self.atol,
            max_steps=self.max_steps,
            save_ts=jnp.linspace(0.0, self.t_end_s, self.n_save),
            # a sweep is not differentiated: the plain while loop (see run_landing)
            adjoint=diffrax.ForwardMode(),
            pcoeff=pcoeff,
            icoeff=icoeff,
        )

    def __call__(self, params):
        return self.solve(self.build(params))

    def histories(self, params):
        return self.solve_histories(self.build(params))

    def solve(self, scene):
        """Scalar outputs of one built case (see the class docstring)."""
        from jaxcable.arresting.passive import landing_outputs

        r = self._simulate(scene)
        o = landing_outputs(r.ts, r.probes, r.status, self.criteria)
        finite = jnp.isfinite(r.ts)[:, None]
        hook_force = jnp.where(finite, r.probes["hook_normal_force_N"], 0.0)
        captured = jnp.all(jnp.max(hook_force, axis=0) > 0.0)
        out = dict(
            captured=captured,
            stopped=o["stopped"],
            success=captured & o["stopped"] & o["criteria_met"],
            **criteria_columns(o, self.criteria),
            status_code=r.status,
            num_steps=r.num_steps,
        )
        return {k: jnp.asarray(v) for k, v in out.items()}

    def solve_histories(self, scene):
        """Figs 18-20 (:func:`passive_histories`) of one built case."""
        return passive_histories(self._simulate(scene))

    def describe(self):
        return dict(
            type=type(self).__name__,
            fidelity=self.fidelity,
            t_end_s=self.t_end_s,
            solver=self.solver,
            rtol=self.rtol,
            atol=self.atol,
            max_steps=self.max_steps,
            n_save=self.n_save,
            vz_m_s=float(self.vz_m_s),
            criteria=dict(z_max_m=self.criteria.z_max_m, a_max_g=self.criteria.a_max_g, sigma_max_mpa=self.criteria.sigma_max_mpa),
            buffer={k: np.asarray(getattr(self.buffer, k)).tolist() for k in self.buffer.__dataclass_fields__},
            layout={k: np.asarray(getattr(self.layout, k)).tolist() for k in self.layout.__dataclass_fields__},
            # only when changed, so that sweeps written before the field existed still resume
            **({} if self.cable_damping_s == DEFAULT_CABLE_DAMPING_S else dict(cable_damping_s=self.cable_damping_s)),
        )


def passive_histories(result) -> dict:
    """Figs 18-20 from a passive scene's :class:`~jaxcable.core.simulate.Result`: ``ts`` (time since
    capture [s]), ``drop_m`` [m], ``acceleration_g`` (|a| of the centre of mass [g]),
    ``stress_max_mpa`` [MPa] on the saved grid (n_save,); NaN after a failed run ended."""
    finite = jnp.isfinite(result.ts)
    acc = jnp.linalg.norm(result.probes["acceleration_m_s2"], axis=1) / G_CRITERIA
    mask = lambda v: jnp.where(finite, v, jnp.nan)  # noqa: E731
    return dict(
        ts=mask(result.ts),
        drop_m=mask(result.probes["drop_m"]),
        acceleration_g=mask(acc),
        stress_max_mpa=mask(result.probes["stress_max_pa"] / 1e6),
    )


def passive_case_fn(
    fidelity: str = "rigid",
    buffer: BufferDevice | None = None,
    layout: ArrestingLayout | None = None,
    *,
    t_end_s: float = 2.0,
    solver: str | None = None,
    rtol: float | None = None,
    atol: float | None = None,
    max_steps: int | None = None,
    n_save: int | None = None,
    vz_m_s: float = CAPTURE_VZ_M_S,
    criteria: LandingCriteria = LandingCriteria(),
    wind: bool = True,
    seed: int = 0,
    cable_damping_s: float = DEFAULT_CABLE_DAMPING_S,
) -> PassiveCaseFunction:
    """The passive-phase case function with Table 1 defaults and the level's solver settings
    (``LEVEL_DEFAULTS`` of :mod:`jaxcable.arresting.landing` where an argument is ``None``).

    Defaults chosen by measurement (rigid level, scenario III, /tmp scripts of the sweep's author):

    * ``t_end_s`` = 2 s (as ``jaxcable land``). The descent stops at 0.62-0.87 s, but the drop
      keeps growing after the stop: the rocket swings toward the centre on weakly damped cables and
      reaches its largest drop at ~1.3-1.5 s. z_max over [0, 1.2 s] was up to 1.3 % below z_max
      over [0, 1.6 s]; z_max over [0, 2 s] is up to 1.8 % below z_max over [0, 4 s] (19 of 100
      cases differ by more than 0.1 %, the success count is the same). The criteria are maxima over
      ``[0, t_end_s]``; a case not stopped by then is reported with ``stopped=False``, not failed.
    * ``n_save`` = one sample per ``SAVE_SPACING_S`` = 1 ms (2001 at 2 s), the rule of the passive
      scene's own default grid (:data:`jaxcable.arresting.passive.SAVE_SPACING_S`, measurements
      there): the maxima are taken over the saved samples; against 0.25 ms sampling, 5 ms (401
      samples over 2 s, the scene's old default) misses a_max by up to 0.13 %,
      2.5 ms by 0.03 %, 1 ms by 4e-5 (40 rigid cases), at no measurable extra run time.
    """
    from jaxcable.arresting.landing import LEVEL_DEFAULTS

    check_choice("fidelity", fidelity, SWEEP_FIDELITIES)
    d_solver, d_rtol, d_atol, d_steps = LEVEL_DEFAULTS[fidelity]
    return PassiveCaseFunction(
        buffer=BufferDevice() if buffer is None else buffer,
        layout=ArrestingLayout() if layout is None else layout,
        vz_m_s=vz_m_s,
        criteria=criteria,
        fidelity=fidelity,
        t_end_s=float(t_end_s),
        solver=solver or d_solver,
        rtol=float(rtol or d_rtol),
        atol=float(atol or rtol or d_atol),
        max_steps=int(max_steps or d_steps),
        n_save=int(n_save or round(t_end_s / SAVE_SPACING_S) + 1),
        wind=bool(wind),
        seed=int(seed),
        cable_damping_s=float(cable_damping_s),
    )


_CASE_FACTORIES: dict[str, Callable[..., AbstractCaseFunction]] = {"passive": passive_case_fn}


def register_case_fn(phase: str, factory: Callable[..., AbstractCaseFunction]) -> None:
    """Register the factory of a phase's case function, called as ``factory(fidelity, **kwargs)``
    (e.g. the two-phase one for ``phase="full"``)."""
    check_choice("phase", phase, PHASES)
    _CASE_FACTORIES[phase] = factory


def case_fn_for(phase: str, fidelity: str = "rigid", **kwargs) -> AbstractCaseFunction:
    """The case function of a phase (``passive`` or ``full``) at a fidelity level."""
    check_choice("phase", phase, PHASES)
    if phase == "full" and phase not in _CASE_FACTORIES:
        from jaxcable.arresting import two_phase  # noqa: F401  (registers the two-phase case function)
    if phase not in _CASE_FACTORIES:
        raise ValueError(
            f"phase {phase!r}: no case function is available yet (the two-phase simulation, active "
            "tracking then passive deceleration, is not implemented); register one with "
            "jaxcable.studies.sweep.register_case_fn, or use phase 'passive'"
        )
    return _CASE_FACTORIES[phase](fidelity, **kwargs)


_stack_cases = stack_cases  # the name arresting/design.py imports


# ------------------------------------------------------------------------------------------------
# CSV rows, sidecar, resume
# ------------------------------------------------------------------------------------------------


def _fmt(v) -> str:
    if isinstance(v, (bool, np.bool_)):
        return "True" if v else "False"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    return repr(float(v))  # shortest repr that round-trips a float64 exactly


def _parse(text: str):
    if text in ("True", "False"):
        return text == "True"
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text


def _sidecar_path(out_csv) -> Path:
    return Path(str(out_csv) + ".json")


def _read_rows(path: Path, repair: bool) -> tuple[list[str] | None, list[list[str]]]:
    """Header and complete rows of a sweep CSV. With ``repair``, a trailing partial line (a chunk
    cut by a kill) is truncated off the file."""
    if not path.exists():
        return None, []
    data = path.read_bytes()
    end = data.rfind(b"\n") + 1
    if end < len(data) and repair:
        with open(path, "r+b") as f:
            f.truncate(end)
            f.flush()
            os.fsync(f.fileno())
    lines = data[:end].decode().splitlines()
    if not lines:
        return None, []
    return lines[0].split(","), [line.split(",") for line in lines[1:] if line]


def _append_lines(path: Path, lines: list[str]):
    """Append whole lines and make them durable before the next chunk starts: a kill can cut
    only the last, unfinished write, which the next start truncates."""
    with open(path, "a", encoding="utf-8") as f:
        f.write("".join(line + "\n" for line in lines))
        f.flush()
        os.fsync(f.fileno())


def read_sweep_csv(path) -> dict:
    """A sweep CSV as columns ``{name: np.ndarray}`` sorted by case (complete lines only; a case
    written twice, which a sweep never does, keeps its first row)."""
    header, rows = _read_rows(Path(path), repair=False)
    if header is None:
        raise ValueError(f"{path}: not a sweep CSV (empty)")
    seen, kept = set(), []
    for row in rows:
        if len(row) != len(header):
            raise ValueError(f"{path}: a row has {len(row)} fields, the header {len(header)}")
        case = int(row[0])
        if case not in seen:
            seen.add(case)
            kept.append([_parse(x) for x in row])
    kept.sort(key=lambda r: r[0])
    cols = {}
    for j, name in enumerate(header):
        vals = [r[j] for r in kept]
        cols[name] = np.asarray(vals, dtype=object if name == "solver_status" else None)
        if name == "solver_status":
            cols[name] = cols[name].astype(str)
    if not kept:
        cols = {name: np.zeros(0) for name in header}
    return cols


def merge_sweep_csvs(paths: Sequence, out) -> dict:
    """Merge the CSVs of one sweep run on several hosts (same columns) into ``out``, one row per case,
    sorted; returns the merged columns."""
    header, merged = None, {}
    for p in paths:
        h, rows = _read_rows(Path(p), repair=False)
        if h is None:
            continue
        if header is not None and h != header:
            raise ValueError(f"{p}: columns differ from {paths[0]}")
        header = h
        for row in rows:
            merged.setdefault(int(row[0]), row)
    if header is None:
        raise ValueError("no rows to merge")
    tmp = Path(str(out) + ".tmp")
    tmp.write_text(",".join(header) + "\n" + "".join(",".join(merged[i]) + "\n" for i in sorted(merged)))
    os.replace(tmp, out)
    return read_sweep_csv(out)


def _status_text(code: int) -> str:
    from jaxcable.core.simulate import status_message

    return status_message(code).replace(",", ";").replace("\n", " ")


def _failed(outputs: dict, i: int) -> bool:
    if int(outputs["status_code"][i]) not in _OK_STATUS:
        return True
    for name, v in outputs.items():
        x = v[i]
        if np.issubdtype(np.asarray(x).dtype, np.floating) and not np.isfinite(x):
            flag = ALLOWED_NONFINITE.get(name)
            if flag is None or bool(outputs[flag][i]):
                return True
    return False


def process_indices(n: int, process_index: int = 0, process_count: int = 1) -> np.ndarray:
    """Case indices of one process of a multi-host sweep: ``process_index``, ``+ process_count``, ...
    (strided, so growing ``n`` keeps every earlier case on the same process)."""
    if not 0 <= process_index < process_count:
        raise ValueError(f"process_index must be in [0, {process_count}), got {process_index}")
    return np.arange(process_index, n, process_count)


def run_sweep(
    case_fn: AbstractCaseFunction,
    samples: dict,
    out_csv,
    *,
    indices=None,
    batch_size: int = 32,
    identity: dict | None = None,
    devices=None,
    progress: bool = True,
    on_chunk: Callable[[np.ndarray], None] | None = None,
) -> dict:
    """Run ``case_fn`` on the cases ``indices`` (default all) of ``samples`` ({name: (n,)}), append
    one CSV row per case to ``out_csv`` as each chunk finishes, and return all the file's rows as
    columns (:func:`read_sweep_csv`).

    Resumes: cases already in ``out_csv`` are skipped; the sidecar ``out_csv + ".json"`` stores
    ``identity`` (plus the case function's description and the input names) and a restart with a
    different one raises ``ValueError``. ``batch_size`` (cases per compiled call, padded up to a
    multiple of the device count), ``devices`` and ``progress`` change results only through
    roundoff and may differ on resume.
    ``on_chunk(case_indices)`` is called after each chunk is durable (logging, tests).
    """
    from jaxcable.core.provenance import __version__
    from jaxcable.core.config import enable_x64

    enable_x64()
    check_positive("batch_size", batch_size)
    names = list(samples)
    arrays = {k: np.asarray(samples[k], dtype=float) for k in names}
    n = len(arrays[names[0]])
    indices = np.arange(n) if indices is None else np.asarray(indices, dtype=int)
    if indices.size and (indices.min() < 0 or indices.max() >= n):
        raise ValueError(f"indices must be in [0, {n}), got {indices.min()}..{indices.max()}")
    mesh = device_mesh(devices)
    n_dev = mesh.devices.size
    out_csv = Path(out_csv)
    side = _sidecar_path(out_csv)
    meta = dict(identity=identity or {}, case_fn=case_fn.describe(), inputs=names)
    header, done = _check_resume(out_csv, side, meta, arrays, names)
    if header is None:
        # a new sweep (or one killed before its first chunk): sidecar first, then an empty CSV;
        # the header goes in with the first chunk, once the case function's outputs are known
        out_csv.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(str(side) + ".tmp")
        tmp.write_text(json.dumps(dict(meta, jaxcable=__version__), indent=1))
        os.replace(tmp, side)
        out_csv.write_text("")
    todo = np.array([i for i in indices if int(i) not in done], dtype=int)
    # one chunk shape per sweep (one compilation): the last chunk is padded up to it
    size = round_up(min(batch_size, max(len(todo), 1)), n_dev)
    bar = _progress_bar(len(indices), len(indices) - len(todo), progress)
    for start in range(0, len(todo), size):
        idx = todo[start : start + size]
        outputs = evaluate(case_fn, {k: arrays[k][idx] for k in names}, mesh, size)
        if "status_code" not in outputs:
            raise ValueError("a case function must return 'status_code' (the solver's result code)")
        out_keys = _ordered(outputs)
        columns = ["case", *names, *out_keys, "solver_status", "failed"]
        lines = []
        if header is None:
            header = columns
            lines.append(",".join(columns))
        elif header != columns:
            raise ValueError(f"{out_csv}: its columns differ from this case function's outputs; refusing to resume")
        for j, case in enumerate(idx):
            failed = _failed(outputs, j)
            row = [_fmt(int(case))] + [_fmt(arrays[k][case]) for k in names]
            row += [_fmt(outputs[k][j]) for k in out_keys]
            row += [_status_text(int(outputs["status_code"][j])), _fmt(failed)]
            lines.append(",".join(row))
        _append_lines(out_csv, lines)
        if bar is not None:
            bar.update(len(idx))
        if on_chunk is not None:
            on_chunk(idx)
    if bar is not None:
        bar.close()
    return read_sweep_csv(out_csv)


def _progress_bar(total, initial, show):
    if not show:
        return None
    from tqdm.auto import tqdm

    return tqdm(total=total, initial=initial, unit="case", desc="sweep", file=sys.stderr)


def _check_resume(out_csv: Path, side: Path, meta: dict, arrays: dict, names: list):
    """The CSV's header (``None`` if it has none yet) and the case indices already written; raises if
    the file belongs to a different sweep."""
    if not out_csv.exists():
        return None, set()
    if not side.exists():
        raise ValueError(
            f"{out_csv} exists without its sidecar {side.name}: not a sweep file (or its sidecar was "
            "deleted); move it away or choose another --out"
        )
    stored = json.loads(side.read_text())
    diffs = [
        f"{key}: stored {stored.get(key)!r}, now {meta[key]!r}"
        for key in meta
        if _jsonable(stored.get(key)) != _jsonable(meta[key])
    ]
    if diffs:
        raise ValueError(
            f"{out_csv} holds a different sweep; refusing to resume (use another --out, or delete "
            "the file and its sidecar to start again). Differences: " + "; ".join(diffs)
        )
    header, rows = _read_rows(out_csv, repair=True)
    if header is None:
        return None, set()
    if header[: 1 + len(names)] != ["case", *names]:
        raise ValueError(f"{out_csv}: its input columns differ from this sweep's; refusing to resume")
    done = set()
    for row in rows:
        if len(row) != len(header):
            raise ValueError(f"{out_csv}: a complete line has {len(row)} fields, the header {len(header)}")
        case = int(row[0])
        if case >= len(arrays[names[0]]):
            continue
        # the inputs written must be this sweep's inputs (guards against a changed sampler)
        written = np.array([float(x) for x in row[1 : 1 + len(names)]])
        expected = np.array([arrays[k][case] for k in names])
        if not np.array_equal(written, expected):
            raise ValueError(f"{out_csv}: the inputs of case {case} differ from this sweep's samples; refusing to resume")
        done.add(case)
    return header, done


_PREFERRED_ORDER = (
    "success", "captured", "stopped", "criteria_met",
    "z_ok", "a_ok", "sigma_ok", "z_max_m", "a_max_g", "sigma_max_mpa",
    "z_margin_m", "a_margin_g", "sigma_margin_mpa", "stop_time_s",
)  # fmt: skip


def _ordered(outputs: dict) -> list:
    """Output columns: the landing outputs in a reading order, then the rest alphabetically, with
    the solver's code and step count last."""
    last = ("status_code", "num_steps")
    first = [k for k in _PREFERRED_ORDER if k in outputs]
    rest = sorted(k for k in outputs if k not in first and k not in last)
    return first + rest + [k for k in last if k in outputs]


def _jsonable(x):
    return json.loads(json.dumps(x))


# ------------------------------------------------------------------------------------------------
# The quasi-Monte Carlo sweep of section IV
# ------------------------------------------------------------------------------------------------


def qmc_case_fn(scenario: str = "I", phase: str = "passive", fidelity: str = "rigid", seed: int = 0, **case_kwargs):
    """The case function of section IV's sweep of ``scenario`` and ``phase``: what
    :func:`run_qmc_sweep` runs, and what the time histories of its cases must be drawn from (the
    seed sets each case's gust, and in the two-phase sweep its measurement noise, too)."""
    check_choice("scenario", scenario, SCENARIOS)
    check_choice("phase", phase, PHASES)
    if phase == "full":
        case_kwargs = dict(case_kwargs, scenario=scenario)
    return case_fn_for(phase, fidelity, seed=int(seed), **case_kwargs)


def run_qmc_sweep(
    scenario: str = "I",
    n: int = 100,
    *,
    phase: str = "passive",
    fidelity: str = "rigid",
    out="sweep.csv",
    seed: int = 0,
    batch_size: int = 32,
    process_index: int = 0,
    process_count: int = 1,
    devices=None,
    progress: bool = True,
    on_chunk=None,
    **case_kwargs,
) -> dict:
    """Section IV's sweep: ``n`` Halton cases of ``scenario`` for ``phase`` at ``fidelity``, this
    process's share of them (:func:`process_indices`) written to ``out``. Returns the columns.

    The sidecar identity holds scenario, phase, seed, process slice and the case function; ``n`` may
    grow on resume (the Halton prefix property keeps the earlier cases), not shrink."""
    case_fn = qmc_case_fn(scenario, phase, fidelity, seed, **case_kwargs)
    samples = halton_samples(n, scenario, phase, seed)
    identity = dict(
        scenario=scenario, phase=phase, seed=int(seed), process_index=int(process_index), process_count=int(process_count)
    )
    side = _sidecar_path(out)
    if Path(out).exists() and side.exists():
        stored_n = json.loads(side.read_text()).get("n")
        if stored_n is not None and n < stored_n:
            raise ValueError(f"{out} holds a sweep of n = {stored_n}; resuming with n = {n} < {stored_n} is refused")
    result = run_sweep(
        case_fn,
        samples,
        out,
        indices=process_indices(n, process_index, process_count),
        batch_size=batch_size,
        identity=identity,
        devices=devices,
        progress=progress,
        on_chunk=on_chunk,
    )
    meta = json.loads(side.read_text())
    meta["n"] = max(int(n), int(meta.get("n") or 0))
    tmp = Path(str(side) + ".tmp")
    tmp.write_text(json.dumps(meta, indent=1))
    os.replace(tmp, side)
    return result


def run_histories(case_fn: AbstractCaseFunction, samples: dict, indices, *, devices=None) -> dict:
    """Time histories (``case_fn.histories``) of the cases ``indices`` in one batch: {name: (k, n_save)}."""
    from jaxcable.core.config import enable_x64

    enable_x64()
    indices = np.asarray(indices, dtype=int)
    mesh = device_mesh(devices)
    params = {k: np.asarray(v, dtype=float)[indices] for k, v in samples.items()}
    size = round_up(max(len(indices), 1), mesh.devices.size)
    return evaluate(case_fn, params, mesh, size, method="histories")


# ------------------------------------------------------------------------------------------------
# Summaries and plots (Tables 6, 7, 9; Figs 18-21)
# ------------------------------------------------------------------------------------------------


def summarize_sweep(table: dict, criteria: LandingCriteria = LandingCriteria()) -> dict:
    """Statistics of a sweep's columns: ``n_cases``, ``n_failed`` (numerically), ``n_captured``,
    ``n_stopped``, ``n_success``, ``success_rate`` (0..1, successes over all cases), and per
    criterion ``{min, max, mean, limit, n_ok, unit}`` over the cases that did not fail."""
    n = len(table["case"])
    failed = np.asarray(table["failed"], dtype=bool)
    good = ~failed

    def count(flag):
        return int(np.sum(np.asarray(table[flag], dtype=bool) & good)) if flag in table else None

    summary = dict(
        n_cases=n,
        n_failed=int(np.sum(failed)),
        n_captured=count("captured"),
        n_stopped=count("stopped"),
        n_success=count("success"),
    )
    summary["success_rate"] = (summary["n_success"] / n) if (n and summary["n_success"] is not None) else None
    crit = {}
    for name, flag, _, limit_field, unit in CRITERIA:
        if name not in table:
            continue
        v = np.asarray(table[name], dtype=float)[good]
        stats = dict(min=None, max=None, mean=None)
        if v.size:
            stats = dict(min=float(np.min(v)), max=float(np.max(v)), mean=float(np.mean(v)))
        crit[name] = dict(stats, limit=float(getattr(criteria, limit_field)), n_ok=count(flag), unit=unit)
    summary["criteria"] = crit
    captured_states = _captured_state_ranges(table, good)
    if captured_states is not None:
        summary["captured_states"] = captured_states
    if failed.any():
        statuses, counts = np.unique(np.asarray(table["solver_status"])[failed], return_counts=True)
        summary["failed_status"] = {str(s): int(c) for s, c in zip(statuses, counts)}
    return summary


CAPTURED_PREFIX = "captured_"
"""Prefix of a two-phase sweep's captured-state columns (``captured_x_m`` ... ``captured_omega_z_deg_s``:
the state of O when the hook throats reach the capture plane, the fields of ``CaptureState``)."""


def _captured_state_ranges(table: dict, good: np.ndarray) -> dict | None:
    """Like Table 5: min, max and mean of each captured-state column over the captured cases that did
    not fail, beside Table 8's range of that state (the paper's passive-phase sweep is said to
    cover the captured states: section IV.C), or ``None`` for a sweep without such columns."""
    order = [CAPTURED_PREFIX + f for f in CaptureState.__dataclass_fields__]  # Table 3's order
    names = sorted((k for k in table if k.startswith(CAPTURED_PREFIX)), key=lambda k: order.index(k) if k in order else len(order))
    if not names:
        return None
    from jaxcable.arresting.uncertainty import scenario_ranges

    table8 = scenario_ranges("I", "passive")  # the same captured-state ranges in every scenario
    use = good & np.asarray(table["captured"], dtype=bool)
    out = {}
    for name in names:
        state = name[len(CAPTURED_PREFIX) :]
        v = np.asarray(table[name], dtype=float)[use]
        stats = dict(min=float(v.min()), max=float(v.max()), mean=float(v.mean())) if v.size else dict(min=None, max=None, mean=None)
        lo_hi = table8.get(state) if state in UNCERTAIN_PARAMETERS[:10] else None
        out[state] = dict(stats, n=int(v.size), table8_range=None if lo_hi is None else [float(lo_hi[0]), float(lo_hi[1])])
        if v.size and lo_hi is not None:
            out[state]["within_table8"] = bool(lo_hi[0] <= v.min() and v.max() <= lo_hi[1])
    return out


def summary_markdown(summary: dict, title: str = "Sweep") -> str:
    """The summary as markdown: criteria like Tables 6/9, counts like Table 7."""

    def f(x, fmt="{:.3f}"):
        return "-" if x is None else fmt.format(x)

    lines = [f"### {title}", "", "| criterion | min | max | mean | limit | cases within limit |", "|---|---:|---:|---:|---:|---:|"]
    good = summary["n_cases"] - summary["n_failed"]
    for name, c in summary["criteria"].items():
        lines.append(
            f"| {name} [{c['unit']}] | {f(c['min'])} | {f(c['max'])} | {f(c['mean'])} | < {c['limit']:g} | {c['n_ok']}/{good} |"
        )
    rate = summary["success_rate"]
    lines += [
        "",
        "| simulation cases | failed numerically | captured | stopped | successful | success rate |",
        "|---:|---:|---:|---:|---:|---:|",
        f"| {summary['n_cases']} | {summary['n_failed']} | {summary['n_captured']} | {summary['n_stopped']} | "
        f"{summary['n_success']} | {f(None if rate is None else 100 * rate, '{:.1f}')} % |",
    ]
    states = summary.get("captured_states")
    if states:
        n_cap = next(iter(states.values()))["n"]
        lines += [
            "",
            f"Captured states (like Table 5; {n_cap} captured cases), beside Table 8's ranges:",
            "",
            "| state | min | max | mean | Table 8 range |",
            "|---|---:|---:|---:|---:|",
        ]
        for name, c in states.items():
            rng = c["table8_range"]
            rng = "-" if rng is None else f"{rng[0]:g} .. {rng[1]:g}" + ("" if c.get("within_table8", True) else " (exceeded)")
            lines.append(f"| {name} | {f(c['min'])} | {f(c['max'])} | {f(c['mean'])} | {rng} |")
    if summary.get("failed_status"):
        lines += ["", "Failed cases by solver status: " + ", ".join(f"{k}: {v}" for k, v in summary["failed_status"].items())]
    return "\n".join(lines) + "\n"


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_landing_plane(table: dict, path, title: str = "", criteria: LandingCriteria = LandingCriteria()):
    """Like Fig 21: (a) capture positions with lateral-velocity (red) and inclination (green) arrows;
    (b-d) z_max, a_max, sigma_max over the landing plane (x, y coloured by the criterion; failed
    cases as black crosses, cases whose hooks missed the cables ringed in red). The capture state is
    the sweep's input in a passive sweep and the state at capture (``captured_*`` columns) in a
    two-phase sweep."""
    plt = _plt()
    pre = CAPTURED_PREFIX if CAPTURED_PREFIX + "x_m" in table else ""
    col = lambda name: np.asarray(table[pre + name], float)  # noqa: E731
    x, y = col("x_m"), col("y_m")
    failed = np.asarray(table["failed"], bool)
    missed = ~np.asarray(table["captured"], bool) & ~failed
    fig, axes = plt.subplots(2, 2, figsize=(11, 9.5))
    ax = axes[0, 0]
    ax.scatter(x, y, s=10, c="k")
    ax.quiver(x, y, col("vx_m_s"), col("vy_m_s"), color="r", angles="xy", scale_units="xy", scale=0.5, width=0.003, label="v_xy (1 m/s = 2 m)")
    ax.quiver(x, y, col("theta_y_deg"), -col("theta_x_deg"), color="g", angles="xy", scale_units="xy", scale=4.0, width=0.003, label="tilt direction (4 deg = 1 m)")
    ax.set_title("a) states at capture", fontsize=10)
    ax.legend(fontsize=7, loc="upper right")
    for ax, letter, (name, _, _, limit_field, unit) in zip(axes.flat[1:], "bcd", CRITERIA):
        v = np.asarray(table[name], float)
        sc = ax.scatter(x[~failed], y[~failed], c=v[~failed], s=30, cmap="viridis")
        if failed.any():
            ax.scatter(x[failed], y[failed], marker="x", c="k", s=30, label="failed")
        if missed.any():
            ax.scatter(x[missed], y[missed], s=90, facecolors="none", edgecolors="r", label="hooks missed")
        if failed.any() or missed.any():
            ax.legend(fontsize=7)
        fig.colorbar(sc, ax=ax, label=f"{name} [{unit}] (limit {getattr(criteria, limit_field):g})")
        ax.set_title(f"{letter}) {name}", fontsize=10)
    for ax in axes.flat:
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_aspect("equal", adjustable="datalim")
    fig.suptitle(title or "criteria over the landing plane", fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return str(path)


def plot_histories(histories: dict, path, title: str = "", criteria: LandingCriteria = LandingCriteria()):
    """Like Figs 18-20: drop, acceleration and max cable stress against time, one line per case."""
    plt = _plt()
    ts = np.asarray(histories["ts"])
    fig, axes = plt.subplots(3, 1, figsize=(7, 9), sharex=True)
    panels = (
        ("drop_m", "buffering distance [m]", criteria.z_max_m),
        ("acceleration_g", "acceleration [g]", criteria.a_max_g),
        ("stress_max_mpa", "max cable stress [MPa]", criteria.sigma_max_mpa),
    )
    for ax, (key, label, limit) in zip(axes, panels):
        for t, v in zip(ts, np.asarray(histories[key])):
            ax.plot(t, v, lw=0.6, alpha=0.7)
        ax.axhline(limit, color="r", ls=":", lw=1)
        ax.set_ylabel(label)
    axes[-1].set_xlabel("time since capture [s]")
    fig.suptitle(title or f"{ts.shape[0]} cases", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return str(path)


def plot_tracking(histories: dict, path, title: str = "", tracking_time_s: float | None = None, tolerance_m: float = 1.0):
    """Like Figs 15-17 (two-phase sweeps, :meth:`TwoPhaseCaseFunction.histories`): (a) the
    trajectories of O from the terminal-guidance point (black) to capture (red; open red ring: the
    hooks missed the cables), (b) the tracking error |frame centre - measured target| against
    time, one line per case, with ``t_c / 2`` (when given) and the tracking tolerance."""
    plt = _plt()
    ts = np.asarray(histories["tracking_ts"], float)
    pos = np.asarray(histories["o_position_m"], float)
    cap = np.asarray(histories["captured_position_m"], float)
    captured = np.asarray(histories["captured"], bool)
    err = np.asarray(histories["tracking_error_m"], float)
    fig = plt.figure(figsize=(13, 5.8))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    for p in pos:
        ok = np.isfinite(p[:, 0])
        ax.plot(p[ok, 0], p[ok, 1], p[ok, 2], lw=0.6, alpha=0.6)
    ax.scatter(pos[:, 0, 0], pos[:, 0, 1], pos[:, 0, 2], c="k", s=8, label="terminal-guidance point")
    ax.scatter(cap[captured, 0], cap[captured, 1], cap[captured, 2], c="r", s=8, label="captured")
    if (~captured).any():
        ax.scatter(cap[~captured, 0], cap[~captured, 1], cap[~captured, 2], s=40, facecolors="none", edgecolors="r", label="hooks missed")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.set_title("a) trajectories of O to the capture plane", fontsize=10)
    ax.legend(fontsize=7, loc="upper left")
    ax = fig.add_subplot(1, 2, 2)
    for t, e in zip(ts, err):
        ok = np.isfinite(t) & (e > 0)
        ax.plot(t[ok], e[ok], lw=0.6, alpha=0.7)
    ax.set_yscale("log")
    if tracking_time_s is not None:
        ax.axvline(0.5 * tracking_time_s, color="k", ls="--", lw=1, label="t_c / 2")
    ax.axhline(tolerance_m, color="r", ls=":", lw=1, label=f"tracking tolerance {tolerance_m:g} m")
    ax.set_xlabel("time since terminal guidance [s]")
    ax.set_ylabel("tracking error |frame centre - target| [m]")
    ax.set_title("b) tracking errors", fontsize=10)
    ax.legend(fontsize=7)
    fig.suptitle(title or f"{ts.shape[0]} cases", fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return str(path)


# ------------------------------------------------------------------------------------------------
# Command line: jaxcable sweep
# ------------------------------------------------------------------------------------------------


def _build_parser() -> argparse.ArgumentParser:
    from jaxcable.core.simulate import SOLVERS

    def positive_int(name):
        def parse(text):
            value = int(text)
            if value <= 0:
                raise argparse.ArgumentTypeError(f"{name} must be a positive integer, got {text}")
            return value

        return parse

    def positive(name):
        def parse(text):
            value = float(text)
            if not value > 0:
                raise argparse.ArgumentTypeError(f"{name} must be positive, got {text}")
            return value

        return parse

    p = argparse.ArgumentParser(
        prog="jaxcable sweep",
        description="quasi-Monte Carlo robustness sweep of the arresting-cable landing (paper section IV)",
    )
    p.add_argument("--scenario", choices=SCENARIOS, default="I", help="wind scenario of Table 4 (default I)")
    p.add_argument("--n", type=positive_int("--n"), default=100, help="number of Halton cases (default 100, as the paper)")
    p.add_argument("--phase", choices=PHASES, default="passive", help="passive: from capture (Table 8 states); full: two-phase, tracking from the terminal-guidance point (Table 3 states), capture, passive phase at --fidelity")
    p.add_argument(
        "--fidelity",
        choices=SWEEP_FIDELITIES,
        default="rigid",
        help="model level (default rigid, for cost: ~0.1 s per 2 s case once compiled, ale ~1 min)",
    )
    p.add_argument("--out", default="sweep.csv", help="CSV of one row per case; resumed if it exists (default sweep.csv)")
    p.add_argument("--seed", type=int, default=0, help="Halton scrambling seed (default 0)")
    p.add_argument("--batch-size", type=positive_int("--batch-size"), default=32, help="cases per compiled call (default 32)")
    p.add_argument("--t-end", type=positive("--t-end"), default=2.0, help="time simulated after capture [s] (default 2)")
    p.add_argument("--solver", choices=sorted(SOLVERS), default=None, help="diffrax solver (default per level)")
    p.add_argument("--rtol", type=positive("--rtol"), default=None, help="relative = absolute tolerance (default per level)")
    p.add_argument("--max-steps", type=positive_int("--max-steps"), default=None, help="solver step budget per case (default per level)")
    p.add_argument("--cable-damping", type=float, default=DEFAULT_CABLE_DAMPING_S, help=f"cables' stiffness-proportional damping beta [s] (default {DEFAULT_CABLE_DAMPING_S:g}; the paper gives none, a_max depends on it)")
    p.add_argument("--plot", metavar="PREFIX", help="write PREFIX_plane.png (Fig 21), PREFIX_histories.png (Figs 18-20) and, with --phase full, PREFIX_tracking.png (Figs 15-17)")
    p.add_argument("--plot-cases", type=positive_int("--plot-cases"), default=32, help="cases in the histories and tracking plots (default 32)")
    p.add_argument("--process-index", type=int, default=None, help="this host's index in a multi-host sweep (default: jax.process_index())")
    p.add_argument("--process-count", type=int, default=None, help="hosts in a multi-host sweep (default: jax.process_count())")
    p.add_argument(
        "--distributed",
        action="store_true",
        help="call jax.distributed.initialize() first (multi-host; arguments auto-detected on Slurm, Open MPI, TPU)",
    )
    p.add_argument(
        "--coordinator",
        metavar="HOST:PORT",
        help="with --distributed off a managed cluster: the coordinator address (with --process-index/--process-count)",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print one JSON object (the summary)")
    return p


def sweep_main(argv: list[str] | None = None) -> int:
    """``jaxcable sweep``: run (or resume) a sweep, print its summary. Exit status 0 when every case
    ran (whatever the success rate), 1 when some failed numerically, 2 on bad arguments."""
    from jaxcable.core.config import enable_x64

    args = _build_parser().parse_args(argv)
    enable_x64()
    if args.distributed:
        try:
            if args.coordinator:
                jax.distributed.initialize(args.coordinator, num_processes=args.process_count, process_id=args.process_index)
            else:
                jax.distributed.initialize()
        except RuntimeError as err:
            # jax.distributed must start before JAX creates its backend; an import that builds an
            # array at import time (a default argument, a module constant) already did.
            print(
                f"jaxcable sweep: error: jax.distributed.initialize() failed: {err}\n"
                "Run each host with --process-index I --process-count N instead (the same slices, "
                "without jax.distributed).",
                file=sys.stderr,
            )
            return 2
    p_index = jax.process_index() if args.process_index is None else args.process_index
    p_count = jax.process_count() if args.process_count is None else args.process_count
    if p_count > 1:
        # one file per process (hosts may share a file system): results.p0of4.csv, ...
        path = Path(args.out)
        args.out = str(path.with_name(f"{path.stem}.p{p_index}of{p_count}{path.suffix}"))
    case_kwargs = dict(
        t_end_s=args.t_end, solver=args.solver, rtol=args.rtol, max_steps=args.max_steps, cable_damping_s=args.cable_damping
    )
    try:
        table = run_qmc_sweep(
            args.scenario,
            args.n,
            phase=args.phase,
            fidelity=args.fidelity,
            out=args.out,
            seed=args.seed,
            batch_size=args.batch_size,
            process_index=p_index,
            process_count=p_count,
            progress=not (args.no_progress or args.json),
            **case_kwargs,
        )
    except ValueError as err:
        print(f"jaxcable sweep: error: {err}", file=sys.stderr)
        return 2
    summary = summarize_sweep(table)
    summary.update(
        scenario=args.scenario,
        phase=args.phase,
        fidelity=args.fidelity,
        seed=args.seed,
        out=args.out,
        process_index=p_index,
        process_count=p_count,
    )
    summary["wind_applied"] = True
    if args.plot:
        title = f"scenario {args.scenario}, {args.phase} phase, fidelity {args.fidelity}"
        summary["plots"] = [plot_landing_plane(table, f"{args.plot}_plane.png", f"{title}, {summary['n_cases']} cases")]
        # the histories are recomputed for the first --plot-cases cases, from the sweep's own case function
        case_fn = qmc_case_fn(args.scenario, args.phase, args.fidelity, args.seed, **case_kwargs)
        samples = halton_samples(args.n, args.scenario, args.phase, args.seed)
        k = min(args.plot_cases, len(table["case"]))
        hist = run_histories(case_fn, samples, np.asarray(table["case"][:k], int))
        if args.phase == "full":
            from jaxcable.arresting.uncertainty import scenario_settings

            t_c = scenario_settings(args.scenario)["t_c_s"]
            summary["plots"].append(plot_tracking(hist, f"{args.plot}_tracking.png", f"{title}: tracking phase, first {k} cases", t_c))
        summary["plots"].append(plot_histories(hist, f"{args.plot}_histories.png", f"{title}: passive phase, first {k} cases"))
    if args.json:
        print(json.dumps(summary))
    else:
        print(summary_markdown(summary, f"scenario {args.scenario}, {args.phase} phase, fidelity {args.fidelity}"))
        print(f"rows in {args.out}")
        for path in summary.get("plots", []):
            print(f"plot written to {path}")
    return 1 if summary["n_failed"] else 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(sweep_main())
