"""The arresting buffer design problem: its variables and bounds, the criteria, the objective's
weights, :class:`DesignProblem` and its builder :func:`design_problem`, the paper's start design, and
how a design enters the scene (arresting-cable paper, sections II.B and IV; the objective is in
:mod:`jaxcable.arresting.design_objective`, the public names in :mod:`jaxcable.arresting.design`).
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from jaxcable.core.validation import check_choice, check_positive, float_array
from jaxcable.studies.optimise import GRADIENT_MODES, DesignSpace, check_alpha, check_count, split_names
from jaxcable.studies.sharding import stack_cases
from jaxcable.arresting.buffer import BufferDevice
from jaxcable.arresting.landing import LEVEL_DEFAULTS, level_solver_settings
from jaxcable.arresting.layout import ArrestingLayout, CaptureState
from jaxcable.arresting.one_dof import paper_design
from jaxcable.arresting.passive import (
    DEFAULT_CABLE_DAMPING_S,
    FIDELITY_LEVELS,
    LandingCriteria,
    SmoothingWidths,
    passive_landing_scene,
)
from jaxcable.arresting.two_phase import tracking_scene
from jaxcable.arresting.uncertainty import captures_from_samples, halton_samples, scenario_settings

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
    "capture_reference",
    "default_phase",
    "design_buffer",
    "design_gain",
    "design_problem",
    "design_scene",
    "design_space",
    "host_built_scenes",
    "paper_start",
    "profile_names",
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
    # m_w: lower bound by cost, not physics (steps ~ 1/m_w: docs/notes/arresting_design_measurements.md); upper 3.6x the paper
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
"""Default checkpoint count of reverse-mode design gradients: at least the solver steps of a
rigid-level landing (~1100), so every step is stored once and none recomputed
(docs/notes/arresting_design_measurements.md, "Gradients")."""
TAIL_CRITERIA = ("z_max", "a_max", "sigma_max", "worst", "capture_margin", "tracking_error")
"""What the tail risk may be taken of: one normalised criterion, or ``worst`` (each case's largest)."""
PHASES = ("passive", "full")
"""``passive``: Table 8 captured states in the passive scene; ``full``: Table 3 terminal-guidance
states through tracking, capture and the passive phase."""
# the five non-state uncertain parameters of Table 2 that a phase="full" case needs besides its
# terminal-guidance state (wind, gust, motor delay, measurement noise)
CONDITIONS = ("wind_angle_deg", "wind_speed_m_s", "gust_intensity", "motor_delay_s", "noise_rms_m")


def profile_names(knots: int) -> tuple:
    """The design variables ``("b0", ..., "b{knots-1}")`` of a brake profile with ``knots`` factors."""
    check_count("knots", knots, 2, f" (brake-profile knots, at most {MAX_PROFILE_KNOTS})")
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


def design_space(variables, bounds: dict | None = None) -> DesignSpace:
    """The :class:`~jaxcable.studies.optimise.DesignSpace` of ``variables`` (a sequence or a
    comma-separated string of names of ``DESIGN_VARIABLES``; ``profile:K`` stands for ``b0 ..
    b{K-1}``) with ``DEFAULT_BOUNDS`` unless ``bounds`` (``{name: (lower, upper)}``) says otherwise.
    The brake force's lower bound may be 0 (a brake that is off)."""
    names = tuple(_expand_profile_tokens(split_names(variables)))
    return DesignSpace.from_names(
        names, bounds, variables=DESIGN_VARIABLES, default_bounds=DEFAULT_BOUNDS, zero_lower=("F_f",)
    )


# ------------------------------------------------------------------------------------------------
# Objective weights and the problem
# ------------------------------------------------------------------------------------------------


class ObjectiveWeights(eqx.Module):
    """Weights and shape parameters of the objective (:mod:`jaxcable.arresting.design_objective`). Arrays: sweepable and
    differentiable. The (3,) arrays follow ``CRITERIA`` = (z_max, a_max, sigma_max)."""

    expected: jax.Array = eqx.field(converter=float_array, default=1.0)
    """weight of the expected cost [-], shape ()"""
    criteria: jax.Array = eqx.field(converter=float_array, default=(1.0 / 3, 1.0 / 3, 1.0 / 3))
    """weights of the normalised criteria inside the expected cost [-], shape (3,)"""
    tail: jax.Array = eqx.field(converter=float_array, default=1.0)
    """weight of the tail risk (CVaR) [-], shape ()"""
    alpha: jax.Array = eqx.field(converter=float_array, default=0.75)
    """CVaR level: the tail is the worst (1 - alpha) fraction of the batch [-], shape (), in [0, 1)"""
    tail_width: jax.Array = eqx.field(converter=float_array, default=0.01)
    """softplus width of :func:`~jaxcable.studies.optimise.smooth_cvar`, in normalised criterion units (0.01 = 1 % of a
    limit) [-], shape ()"""
    penalty: jax.Array = eqx.field(converter=float_array, default=(100.0, 100.0, 100.0))
    """weights of the squared violation penalties [-], shape (3,). 100: a 10 % violation in every
    case costs 1, as much as the whole expected cost at the limits, so violations dominate (with 10,
    the optimiser traded a 19 % stroke violation for lower decelerations; bench_design.md)"""
    margin: jax.Array = eqx.field(converter=float_array, default=0.0)
    """fractional margin the penalties demand below each limit (0.02: r < 0.98) [-], shape ()"""
    capture_criteria: jax.Array = eqx.field(converter=float_array, default=(0.25, 0.25))
    """weights of the normalised tracking-phase criteria (``CAPTURE_CRITERIA``: capture margin,
    tracking error) inside the expected cost [-], shape (2,); used by ``phase="full"`` problems only.
    A quarter each: together they weigh half as much as the three passive criteria (which sum to 1),
    so a design is not bought with a worse arrest, yet the gain a_p (which acts on the passive
    criteria only through the captured state) has a term of its own"""
    capture_penalty: jax.Array = eqx.field(converter=float_array, default=(100.0, 100.0))
    """weights of the squared violation penalties of the tracking-phase criteria [-], shape (2,)
    (``phase="full"`` only): as ``penalty``: a miss is a failed landing"""
    design_cost: jax.Array | None = None
    """weight of each variable's ``x_k / upper_k`` in the design cost [-], shape (k,); None: 0"""
    tail_criterion: str = eqx.field(static=True, default="a_max")
    """which normalised criterion the CVaR is taken of: z_max, a_max, sigma_max or worst"""
    tail_form: str = eqx.field(static=True, default="smooth")
    """``smooth`` (:func:`~jaxcable.studies.optimise.smooth_cvar`) or ``exact``
    (:func:`~jaxcable.studies.optimise.cvar`)"""

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
        check_alpha(self.alpha)
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
    weights: ObjectiveWeights = eqx.field(default_factory=ObjectiveWeights)
    limits: LandingCriteria = LandingCriteria()
    widths: SmoothingWidths = SmoothingWidths()
    conditions: dict | None = None
    """``phase="full"``: ``{name: (n,) array}`` for the five names of ``CONDITIONS`` (wind angle
    [deg], steady wind speed [m/s], gust intensity [-], motor delay [s], noise RMS [m]); None for
    ``phase="passive"``"""
    gain_per_s: jax.Array = eqx.field(converter=float_array, default=2.0)
    """PD gain a_p [1/s] used when ``a_p`` is not a design variable (``phase="full"``), shape ()"""
    tracking_tolerance_m: jax.Array = eqx.field(converter=float_array, default=1.0)
    """limit of the tracking error at capture [m] (two_phase.py's reading of "approaches zero"), shape ()"""
    capture_reference_m: jax.Array = eqx.field(converter=float_array, default=1.0)
    """capture margin of a centred, vertical capture [m] (the throat's half-width less the
    clearance; :func:`design_problem` computes it from the hook geometry), shape (): the capture
    criterion is normalised as ``r = 1 - margin / capture_reference_m`` (0: centred, 1: the edge)"""
    margin_width_m: jax.Array = eqx.field(converter=float_array, default=0.02)
    """width of the soft minimum over the four hooks' capture margins [m], shape ()"""
    cable_damping_s: float = eqx.field(static=True, default=DEFAULT_CABLE_DAMPING_S)
    """The cables' stiffness-proportional damping beta [s] in the passive phase (the paper gives no
    value; default the scenes' calibrated 6.3e-3 s, :data:`.passive.DEFAULT_CABLE_DAMPING_S`). a_max
    depends strongly on it: the cable-counterweight mode rings with beta = 1e-5 s."""
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
    ``"auto"``: on the CPU :data:`jaxcable.studies.batching.AUTO_CHUNK` (forward value and reverse
    mode 32, forward mode 16; a vmapped solve's cost per case grows with the batch beyond these on
    the CPU: at n = 64 the forward call runs 1.28x, the forward-mode gradient 1.11x and reverse mode
    1.17x faster; ``python experiments/bench_design.py --sections chunk``), elsewhere the whole
    batch in one vmap.
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
            check_count("checkpoints", self.checkpoints, 1, " or None")
        if self.chunk is not None and self.chunk != "auto":
            check_count("chunk", self.chunk, 1, ", 'auto' or None")
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
    names = design_space(variables).names
    return "full" if any(DESIGN_VARIABLES[n][1] == "full" for n in names) else "passive"


def capture_reference(layout: ArrestingLayout | None = None) -> float:
    """Capture margin [m] of a centred, vertical rocket with the frame at rest at the centre: the
    smallest of the four hooks' margins of :meth:`TrackingScene.capture_margins` at t = 0 (the
    horizontal geometry does not depend on the height)."""
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
    scene_options: dict | None = None,
    **settings,
) -> DesignProblem:
    """A design problem over ``n`` Halton cases of ``scenario``, deterministic for ``seed``
    (:func:`jaxcable.arresting.uncertainty.halton_samples`).

    ``phase``: ``"passive"`` (Table 8 captured states, passive scene at ``fidelity``), ``"full"``
    (Table 3 terminal-guidance states with Table 4 wind, delay and noise; two-phase landing at level
    rigid) or None (default): ``"full"`` when ``a_p`` is a design variable, else ``"passive"``
    (:func:`default_phase`). ``settings`` go to :class:`DesignProblem` (``t_end_s``, ``rtol``,
    ``gradient``, ``gain_per_s``, ...). ``scene_options``: further :func:`.passive.passive_landing_scene`
    options of the host-built ale/full scenes (e.g. ``{"n_span_elements": 16, "n_fine": 8}``, a
    cheaper mesh than the default)."""
    space = design_space(variables, bounds)
    check_count("n", n, 1, " (captures in the batch)")
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
        settings.setdefault(
            "rtol", level_solver_settings(fidelity, settings.get("cable_damping_s"), (scene_options or {}).get("hook_contact"))[1]
        )
        settings.setdefault("atol", settings["rtol"])
    buffer = BufferDevice() if buffer is None else buffer
    layout = ArrestingLayout() if layout is None else layout
    host_built = phase == "passive" and fidelity != "rigid" and settings.get("scenes") is None
    if scene_options and not host_built:
        raise ValueError(
            "scene_options apply to the scenes design_problem builds (phase='passive', fidelity 'ale' or "
            f"'full', no scenes given); got phase={phase!r}, fidelity={fidelity!r}"
        )
    if host_built:
        settings["scenes"] = host_built_scenes(
            fidelity, captures, layout, buffer, settings.get("t_end_s", DesignProblem.t_end_s),
            settings.get("cable_damping_s", DEFAULT_CABLE_DAMPING_S), **(scene_options or {}),
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
    p = paper_design()
    # a_p: Table 4's gain of the problem's scenario (2, 5, 6 1/s for I, II, III)
    known = {"m_w": float(p.m_w), "F_f": float(p.F_f), "a_p": float(problem.gain_per_s)}
    known.update({f"b{k}": 1.0 for k in range(MAX_PROFILE_KNOTS)})  # the paper's constant brake
    sp = problem.space
    mid = 0.5 * (np.asarray(sp.lower) + np.asarray(sp.upper))
    return sp.from_dict({n: known.get(n, float(mid[i])) for i, n in enumerate(sp.names)})


# ------------------------------------------------------------------------------------------------
# How a design enters the scene
# ------------------------------------------------------------------------------------------------

# How each design variable enters the buffer devices; ``a_p`` enters the controller of the
# two-phase scene (:func:`design_gain`).
_PASSIVE_SETTERS = {
    "m_w": lambda buffer, v: eqx.tree_at(lambda b: b.counterweight_mass_kg, buffer, v),
    "F_f": lambda buffer, v: eqx.tree_at(lambda b: b.brake_force_N, buffer, v),
}


def design_buffer(problem: DesignProblem, x) -> BufferDevice:
    """``problem.buffer`` with the design ``x`` (k,) in it: m_w, F_f and the brake profile's factors."""
    buffer = problem.buffer
    for i, name in enumerate(problem.space.names):
        if name in _PASSIVE_SETTERS:
            buffer = _PASSIVE_SETTERS[name](buffer, x[i])
    knots = _profile_indices(problem.space.names)
    if knots:
        profile = x[jnp.asarray(knots)]
        buffer = eqx.tree_at(lambda b: b.brake_profile, buffer, profile, is_leaf=lambda v: v is None)
    return buffer


def design_gain(problem: DesignProblem, x):
    """The PD gain a_p [1/s] of the design ``x`` (k,): its ``a_p`` if a variable, else ``problem.gain_per_s``."""
    names = problem.space.names
    return x[names.index("a_p")] if "a_p" in names else problem.gain_per_s


def design_scene(problem: DesignProblem, capture: CaptureState, x):
    """The passive scene of one captured state ``capture`` at the design ``x`` (k,) (level rigid:
    built inside the traced objective)."""
    return passive_landing_scene(
        problem.fidelity, capture, problem.layout, design_buffer(problem, x), t_end_s=problem.t_end_s,
        cable_damping_s=problem.cable_damping_s,
    )  # fmt: skip


def host_built_scenes(fidelity, captures: CaptureState, layout, buffer, t_end_s, cable_damping_s, **scene_options):
    """The passive scenes of a batch of concrete captures at level ale or full, stacked (n, ...);
    ``scene_options`` go to :func:`.passive.passive_landing_scene` (the mesh, the contact law)."""
    n = int(np.shape(captures.x_m)[0])
    one = lambda j: jax.tree_util.tree_map(lambda v: v[j], captures)  # noqa: E731
    return stack_cases([
        passive_landing_scene(
            fidelity, one(j), layout, buffer, t_end_s=t_end_s, cable_damping_s=cable_damping_s, **scene_options
        )
        for j in range(n)
    ])  # fmt: skip
