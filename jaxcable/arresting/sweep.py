r"""The quasi-Monte Carlo robustness sweep of the arresting-cable landing: case functions, summaries.

Arresting-cable paper, section IV: 100 Halton cases per wind scenario (Tables 2, 3, 4, 8), the
success criteria of section IV.A (z_max < 10 m, a_max < 5 g, sigma_max < 800 MPa), the statistics of
Tables 5, 6, 7 and 9. The points come from :mod:`jaxcable.arresting.uncertainty`; the runner
(batched, sharded over devices, resumable CSV) is :func:`jaxcable.studies.sweep.run_sweep`; the
plots (Figs 15-21) are in :mod:`jaxcable.arresting.sweep_plots`.

Case functions, registered by name in :mod:`jaxcable.studies.registry` (factories called as
``factory(fidelity, **kwargs)``; :func:`case_fn_for` looks them up by phase):

* ``"arresting.passive"``: :class:`PassiveCaseFunction` (:func:`passive_case_fn`), the
  passive-deceleration phase from capture;
* ``"arresting.full"``: the two-phase case function
  (:class:`jaxcable.arresting.two_phase.TwoPhaseCaseFunction`: tracking, capture and the passive
  phase at the case function's level), registered by :mod:`jaxcable.arresting.two_phase`.

Readings and choices, written down:

* The passive phase starts at capture (hooks engaged, Table 8 states, vz = -20 m/s). The sampled
  wind (angle, speed, gust intensity) is applied (``PassiveCaseFunction.wind``, default True): air
  loads on the free rocket and, at the ale/full levels, on the arresting spans (eqs 43-45); the gust
  is seeded from the sweep's seed and the case's inputs. Time delay and noise are 0 in the passive
  phase (Table 4).
* ``captured`` in the passive phase: every hook carries a nonzero cable force at some saved time (the
  paper's capture criterion, "contact forces ... nonzero", section IV.A). ``stopped``: the descent
  stopped within ``t_end_s``. ``solve_ok``: the solver reached ``t_end_s`` (diffrax ``successful``).
  ``criteria_met`` = solve_ok and stopped and all three criteria within their limits
  (:func:`jaxcable.arresting.passive.landing_outputs`); ``success`` = captured and criteria_met (the
  two-phase sweep: captured, tracking_ok and criteria_met). A case cut short (out of steps, or not
  stopped by ``t_end_s``) is never a success. The ``margin`` of a criterion is limit - value
  (positive when met), in the criterion's unit.
* The maxima are over saved samples 1 ms apart over ``[0, t_end_s]`` (t_end_s = 2 s by default;
  both chosen by measurement, see :func:`passive_case_fn`); a_max and sigma_max after the SAE J211
  CFC 60 filter (:mod:`jaxcable.arresting.passive`), their unfiltered maxima in ``a_max_raw_g`` and
  ``sigma_max_raw_mpa``.
* The sweep's default fidelity is ``rigid`` (rigid 6-DOF rocket, massless elastic cables) because of
  cost: a 2 s case takes ~0.1 s once compiled (batch 8-32, one CPU core), against ~3.6 s per 0.3 s
  simulated for ``ale`` (~17k steps per simulated second; ``experiments/bench_sweep.py``).
"""

from __future__ import annotations

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from jaxcable.arresting.buffer import BufferDevice
from jaxcable.arresting.layout import ArrestingLayout, CaptureState
from jaxcable.arresting.landing import LEVEL_STEP_CONTROL, batched_solver, level_solver_settings
from jaxcable.arresting.passive import (
    DEFAULT_CABLE_DAMPING_S,
    G_CRITERIA,
    SAVE_SPACING_S,
    LandingCriteria,
    ale_model_identity,
    ale_model_kwargs,
    cable_mesh_at,
    check_cable_mesh,
    check_hook_contact,
    check_rocket_bodies,
    landing_outputs,
    passive_landing_scene,
)
from jaxcable.arresting.uncertainty import (
    CAPTURE_VZ_M_S,
    PHASES,
    SCENARIOS,
    UNCERTAIN_PARAMETERS,
    halton_samples,
    scenario_ranges,
)
from jaxcable.components.wind import WindField
from jaxcable.core.simulate import simulate
from jaxcable.core.validation import check_choice, check_positive
from jaxcable.studies import registry
from jaxcable.studies.sweep import AbstractCaseFunction, process_indices, read_sidecar, run_sweep, update_sidecar

__all__ = [
    "CAPTURED_PREFIX",
    "CRITERIA",
    "AbstractLandingCaseFunction",
    "PassiveCaseFunction",
    "SAVE_SPACING_S",
    "SWEEP_FIDELITIES",
    "case_fn_for",
    "case_key",
    "criteria_columns",
    "passive_case_fn",
    "passive_histories",
    "qmc_case_fn",
    "run_qmc_sweep",
    "summarize_sweep",
    "summary_markdown",
    "sweep_identity",
]

SWEEP_FIDELITIES = ("rigid", "ale", "full")
"""Fidelity levels a sweep runs (the 1-DOF level models the central vertical landing only)."""

CRITERIA = (
    ("z_max_m", "z_ok", "z_margin_m", "z_max_m", "m"),
    ("a_max_g", "a_ok", "a_margin_g", "a_max_g", "g"),
    ("sigma_max_mpa", "sigma_ok", "sigma_margin_mpa", "sigma_max_mpa", "MPa"),
)
"""Per criterion: (output, its ok flag, its margin, the LandingCriteria field, unit)."""

CAPTURED_PREFIX = "captured_"
"""Prefix of a two-phase sweep's captured-state columns (``captured_x_m`` ... ``captured_omega_z_deg_s``:
the state of O when the hook throats reach the capture plane, the fields of ``CaptureState``)."""

CASE_FUNCTIONS = {"passive": "arresting.passive", "full": "arresting.full"}
"""Registry name of each phase's case function (:mod:`jaxcable.studies.registry`)."""

_COLUMN_ORDER = (
    "success", "captured", "stopped", "solve_ok", "criteria_met",
    "z_ok", "a_ok", "sigma_ok", "z_max_m", "a_max_g", "sigma_max_mpa",
    "z_margin_m", "a_margin_g", "sigma_margin_mpa", "a_max_raw_g", "sigma_max_raw_mpa", "stop_time_s",
)  # fmt: skip


# ------------------------------------------------------------------------------------------------
# Case functions
# ------------------------------------------------------------------------------------------------


def case_key(seed: int, params) -> jax.Array:
    """PRNG key of one case's noise and gusts: the sweep's ``seed`` with the case's inputs folded in
    (x, y, theta_z), so a case draws the same realisation wherever it sits in a batch."""
    bits = jnp.asarray(params["x_m"] * 1e6 + params["y_m"] * 1e3 + params["theta_z_deg"], jnp.float32)
    return jax.random.fold_in(jax.random.PRNGKey(seed), jax.lax.bitcast_convert_type(bits, jnp.uint32))


def criteria_columns(outputs, criteria: LandingCriteria) -> dict:
    """The passive-phase columns shared by every case function: ``solve_ok``, ``criteria_met``
    (solve_ok, stopped and the three criteria met), each criterion's flag and margin (limit - value,
    positive when met), the three maxima (a_max and sigma_max filtered, CFC 60), the unfiltered
    ``a_max_raw_g`` and ``sigma_max_raw_mpa``, stop time and energy-budget error."""
    o, c = outputs, criteria
    return dict(
        solve_ok=o["solve_ok"],
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
        a_max_raw_g=o["a_max_raw_g"],
        sigma_max_raw_mpa=o["sigma_max_raw_mpa"],
        stop_time_s=o["stop_time_s"],
        energy_budget_error=o["energy_budget_error"],
    )


class AbstractLandingCaseFunction(AbstractCaseFunction):
    """A landing case function: its CSV columns start with the success flags and the criteria in a
    reading order, and a case that did not stop within ``t_end_s`` has no stop time (NaN
    ``stop_time_s`` with ``stopped`` False is not a numerical failure; it is not a success either)."""

    @property
    def column_order(self) -> tuple[str, ...]:
        return _COLUMN_ORDER

    @property
    def allowed_nonfinite(self) -> dict[str, str]:
        return {"stop_time_s": "stopped"}


class PassiveCaseFunction(AbstractLandingCaseFunction):
    """The passive-deceleration phase of one case at a fidelity level (section IV.C).

    ``params``: the capture states of ``UNCERTAIN_PARAMETERS`` (x_m ... omega_z_deg_s; scalars) and,
    with ``wind``, the wind angle, speed and gust intensity; delay and noise are ignored (see the
    module docstring). Outputs (scalars):
    ``captured``, ``stopped``, ``solve_ok``, ``success`` (captured and ``criteria_met``),
    ``criteria_met`` (solve_ok, stopped, three criteria met), per criterion its flag and margin,
    ``z_max_m`` [m], ``a_max_g`` [g of 9.80 m/s^2] and ``sigma_max_mpa`` [MPa] (CFC 60 filtered),
    ``a_max_raw_g``, ``sigma_max_raw_mpa`` (unfiltered), ``stop_time_s`` [s] (NaN when not stopped),
    ``energy_budget_error`` [-], ``status_code`` (diffrax), ``num_steps``.

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
    hook_contact: str | None = eqx.field(static=True, default=None)
    """How a hook holds its cable at the ``ale``/``full`` levels: ``"node"`` (the hook as a sliding
    node, :class:`~jaxcable.arresting.cable_sets.AleCables`) or ``"capsule"``; None: the level's
    default (:func:`~jaxcable.arresting.passive.hook_contact_at`)."""
    n_span_elements: int | None = eqx.field(static=True, default=None)
    """ALE elements per arresting span (``ale``/``full``)."""
    n_fine: int | None = eqx.field(static=True, default=None)
    """Of those, fine elements next to each hook (``ale``/``full``)."""
    n_rocket_bodies: int | None = eqx.field(static=True, default=None)
    """Rigid bodies of the flexible rocket in a ``full`` passive phase (None: 5; 1: a rigid rocket
    with the sprung hooks, :data:`~jaxcable.arresting.passive.DEFAULT_ROCKET_BODIES`)."""

    def __check_init__(self):
        check_choice("fidelity", self.fidelity, SWEEP_FIDELITIES)
        check_hook_contact(self.hook_contact, self.fidelity)
        check_cable_mesh(*cable_mesh_at(self.fidelity, self.n_span_elements, self.n_fine))
        check_rocket_bodies(self.n_rocket_bodies, self.fidelity)
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
        capture = CaptureState(
            **{k: params[k] for k in UNCERTAIN_PARAMETERS[:10]}, vz_m_s=self.vz_m_s
        )
        air = {}
        if self.wind:
            air["wind"] = WindField(
                speed_m_s=params["wind_speed_m_s"], angle_deg=params["wind_angle_deg"],
                gust_intensity=params["gust_intensity"], key=case_key(self.seed, params),
            )  # fmt: skip
        return passive_landing_scene(
            self.fidelity, capture, self.layout, self.buffer, t_end_s=self.t_end_s,
            cable_damping_s=self.cable_damping_s, **air,
            **ale_model_kwargs(self.fidelity, self.hook_contact, self.n_span_elements, self.n_fine, self.n_rocket_bodies),
        )  # fmt: skip

    def _simulate(self, scene):
        pcoeff, icoeff = LEVEL_STEP_CONTROL[self.fidelity]
        return simulate(
            scene,
            self.t_end_s,
            # the cases run vmapped (run_sweep): the W-method relinearises at every step there
            solver=batched_solver(self.solver),
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
        r = self._simulate(scene)
        o = landing_outputs(r.ts, r.probes, r.status, self.criteria)
        finite = jnp.isfinite(r.ts)[:, None]
        hook_force = jnp.where(finite, r.probes["hook_normal_force_N"], 0.0)
        captured = jnp.all(jnp.max(hook_force, axis=0) > 0.0)
        out = dict(
            captured=captured,
            stopped=o["stopped"],
            success=captured & o["criteria_met"],
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
            **ale_model_identity(self.fidelity, self.hook_contact, self.n_span_elements, self.n_fine, self.n_rocket_bodies),
        )


def passive_histories(result) -> dict:
    """Figs 18-20 from a passive scene's :class:`~jaxcable.core.simulate.Result`: ``ts`` (time since
    capture [s]), ``drop_m`` [m], ``acceleration_g`` (|a| of the centre of mass [g]),
    ``stress_max_mpa`` [MPa] on the saved grid (n_save,); NaN after a failed run ended. Unfiltered:
    their maxima are ``a_max_raw_g`` and ``sigma_max_raw_mpa`` (the criteria a_max and sigma_max are
    taken after the CFC 60 filter)."""
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
    hook_contact: str | None = None,
    n_span_elements: int | None = None,
    n_fine: int | None = None,
    n_rocket_bodies: int | None = None,
) -> PassiveCaseFunction:
    """The passive-phase case function with Table 1 defaults and the level's solver settings
    (:func:`jaxcable.arresting.landing.level_solver_settings` of the level and ``cable_damping_s``
    where an argument is ``None``).

    Defaults chosen by measurement (rigid level, scenario III, /tmp scripts of the sweep's author):

    * ``t_end_s`` = 2 s (as ``jaxcable land``). The descent stops at 0.62-0.87 s, but the drop
      keeps growing after the stop: the rocket swings toward the centre on weakly damped cables and
      reaches its largest drop at ~1.3-1.5 s. z_max over [0, 1.2 s] was up to 1.3 % below z_max
      over [0, 1.6 s]; z_max over [0, 2 s] is up to 1.8 % below z_max over [0, 4 s] (19 of 100
      cases differ by more than 0.1 %, the success count is the same). The criteria are maxima over
      ``[0, t_end_s]``; a case not stopped by then is reported with ``stopped=False``: not a
      numerical failure, and not a success.
    * ``n_save`` = one sample per ``SAVE_SPACING_S`` = 1 ms (2001 at 2 s), the rule of the passive
      scene's own default grid (:data:`jaxcable.arresting.passive.SAVE_SPACING_S`, measurements
      there): the maxima are taken over the saved samples; against 0.25 ms sampling, 5 ms (401
      samples over 2 s, the scene's old default) misses a_max by up to 0.13 %,
      2.5 ms by 0.03 %, 1 ms by 4e-5 (40 rigid cases, unfiltered maxima), at no measurable extra
      run time. 1 ms is also what the criteria's CFC 60 filter needs (J211: 10 samples per period
      of its 100 Hz 3 dB frequency).
    """
    check_choice("fidelity", fidelity, SWEEP_FIDELITIES)
    # the level's settings for this damping and hook model: rosw with the node at any damping, with
    # the capsule from STIFF_DAMPING_S on (Bosh3 would run at its stability limit there, ~2 million
    # steps per case at the calibrated damping)
    d_solver, d_rtol, d_atol, d_steps = level_solver_settings(fidelity, float(cable_damping_s), hook_contact)
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
        hook_contact=hook_contact,
        n_span_elements=None if n_span_elements is None else int(n_span_elements),
        n_fine=None if n_fine is None else int(n_fine),
        n_rocket_bodies=None if n_rocket_bodies is None else int(n_rocket_bodies),
    )


def case_fn_for(phase: str, fidelity: str = "rigid", **kwargs) -> AbstractCaseFunction:
    """The case function of a phase (``passive`` or ``full``) at a fidelity level: the factory
    registered as ``CASE_FUNCTIONS[phase]``, called as ``factory(fidelity, **kwargs)``."""
    check_choice("phase", phase, PHASES)
    return registry.case_function(CASE_FUNCTIONS[phase])(fidelity, **kwargs)


registry.register_case_function(CASE_FUNCTIONS["passive"], passive_case_fn)


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


def default_batch_size(fidelity: str, devices=None) -> int:
    """Cases per compiled call of a sweep at ``fidelity`` on ``devices`` (default: the local ones).

    * rigid: 32 (on one CPU device 8-32 cases ran 3.5-5x the cases per second of one case,
      docs/sweeps.md);
    * ale, full on a CPU: 1 per device. Measured with ``jaxcable sweep --phase full --fidelity
      full --n 4`` (scenario I, 2 s after capture, compiled programs read from the cache; 2-core
      Intel Xeon, JAX 0.10.2, float64; the whole command): one device, batches of 1: 309 s; one
      device, batches of 4: 356 s; two devices (``--cpu-devices 2``), 1 case each: 225 s; two
      devices, 2 cases each: 382 s. A vmapped batch steps until its slowest case ends, and one
      device's batch already keeps part of the second core busy;
    * ale, full on a GPU: 24 per device (one H200 ran batches of 22 and 25 two-phase cases at 4.5 s
      a case, docs/benchmarks.md)."""
    check_choice("fidelity", fidelity, SWEEP_FIDELITIES)
    devices = jax.local_devices() if devices is None else list(devices)
    if fidelity == "rigid":
        return 32
    per_device = 1 if devices[0].platform == "cpu" else 24
    return per_device * len(devices)


def check_batch_size(batch_size: int, fidelity: str, devices=None) -> None:
    """Refuse a batch that may hang a sweep on several CPU devices: at level ``full`` more than one
    case a device batches the flexible rocket's 34 x 34 LAPACK Cholesky and its triangular solves.

    On XLA's CPU backend a batched LAPACK call splits its batch over the process's intra-op pool and
    blocks its pool thread until the parts finish; the CPU devices of one process share that pool
    (one thread a core), so two devices in such a call at once can each wait for work queued behind
    the other. A toy with this Cholesky vmapped over 32 cases a device hung on two devices (JAX 0.10.2,
    ``docs/sweeps.md``). Batching gains nothing there anyway: two devices with 2 cases each ran
    slower than with 1 (:func:`default_batch_size`). One device, or a GPU, is not affected."""
    devices = jax.local_devices() if devices is None else list(devices)
    n_dev = len(devices)
    if fidelity == "full" and n_dev > 1 and devices[0].platform == "cpu" and batch_size > n_dev:
        raise ValueError(
            f"batch_size = {batch_size} puts {-(-batch_size // n_dev)} cases on each of {n_dev} CPU devices at "
            "fidelity 'full': the batched LAPACK Cholesky of the flexible rocket can hang several CPU devices "
            f"sharing one thread pool. Use batch_size 'auto' (one case a device, {n_dev} here) or one CPU "
            "device (jaxcable sweep --cpu-devices 1) for larger batches"
        )


def sweep_identity(scenario: str, phase: str, seed: int = 0, process_index: int = 0, process_count: int = 1) -> dict:
    """The identity a section IV sweep stores in its sidecar (and a resume or a confirmation checks):
    scenario, phase, seed and this process's slice."""
    return dict(
        scenario=scenario, phase=phase, seed=int(seed), process_index=int(process_index), process_count=int(process_count)
    )


def run_qmc_sweep(
    scenario: str = "I",
    n: int = 100,
    *,
    phase: str = "passive",
    fidelity: str = "rigid",
    out="sweep.csv",
    seed: int = 0,
    batch_size: int | str = "auto",
    process_index: int = 0,
    process_count: int = 1,
    devices=None,
    progress: bool = True,
    on_chunk=None,
    cases=None,
    stream: bool = True,
    **case_kwargs,
) -> dict:
    """Section IV's sweep: ``n`` Halton cases of ``scenario`` for ``phase`` at ``fidelity``, this
    process's share of them (:func:`process_indices`) written to ``out``. Returns the columns.
    ``cases``: only these case indices (of the ``n``), e.g. the cases of a screening sweep to confirm
    (:mod:`jaxcable.arresting.screening`); default all.

    The sidecar identity holds scenario, phase, seed, process slice and the case function; ``n`` may
    grow on resume (the Halton prefix property keeps the earlier cases), not shrink.

    ``batch_size``: cases per compiled call, or ``"auto"`` (:func:`default_batch_size`); ``stream``
    as :func:`jaxcable.studies.sweep.run_sweep`'s."""
    if batch_size == "auto":
        batch_size = default_batch_size(fidelity, devices)
    check_batch_size(batch_size, fidelity, devices)
    case_fn = qmc_case_fn(scenario, phase, fidelity, seed, **case_kwargs)
    samples = halton_samples(n, scenario, phase, seed)
    identity = sweep_identity(scenario, phase, seed, process_index, process_count)
    stored_n = (read_sidecar(out) or {}).get("n")
    if stored_n is not None and n < stored_n:
        raise ValueError(f"{out} holds a sweep of n = {stored_n}; resuming with n = {n} < {stored_n} is refused")

    def record_n(chunk=None):
        # after every chunk, so that a run killed midway leaves its n for the next resume's check
        # (n >= the stored n: checked above)
        update_sidecar(out, n=int(n))
        if chunk is not None and on_chunk is not None:
            on_chunk(chunk)

    indices = process_indices(n, process_index, process_count)
    if cases is not None:
        cases = np.asarray(cases, dtype=int)
        if cases.size and (cases.min() < 0 or cases.max() >= n):
            raise ValueError(f"cases must be in [0, {n}), got {cases.min()}..{cases.max()}")
        indices = indices[np.isin(indices, cases)]
    result = run_sweep(
        case_fn,
        samples,
        out,
        indices=indices,
        batch_size=batch_size,
        identity=identity,
        devices=devices,
        progress=progress,
        on_chunk=record_n,
        stream=stream,
    )
    record_n()
    return result


# ------------------------------------------------------------------------------------------------
# Summaries (Tables 5, 6, 7, 9)
# ------------------------------------------------------------------------------------------------


def summarize_sweep(table: dict, criteria: LandingCriteria = LandingCriteria()) -> dict:
    """Statistics of a sweep's columns: ``n_cases``, ``n_failed`` (numerically), ``n_captured``,
    ``n_stopped``, ``n_success``, ``success_rate`` (0..1, successes over all cases: a failed or
    unstopped case is not a success), and per criterion ``{min, max, mean, limit, n_ok, unit}`` over
    the cases that did not fail."""
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


def _captured_state_ranges(table: dict, good: np.ndarray) -> dict | None:
    """Like Table 5: min, max and mean of each captured-state column over the captured cases that did
    not fail, beside Table 8's range of that state (the paper's passive-phase sweep is said to
    cover the captured states: section IV.C), or ``None`` for a sweep without such columns."""
    order = [CAPTURED_PREFIX + f for f in CaptureState.__dataclass_fields__]  # Table 3's order
    names = sorted((k for k in table if k.startswith(CAPTURED_PREFIX)), key=lambda k: order.index(k) if k in order else len(order))
    if not names:
        return None
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
