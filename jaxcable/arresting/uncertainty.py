r"""Uncertain parameters and quasi-Monte Carlo samples of the robustness evaluation.

Arresting-cable paper, section IV: Table 2 (the 15 uncertain parameters, all Halton-distributed),
Table 3 (terminal-guidance state ranges, start of the two-phase simulation), Table 4 (the three
wind scenarios I, II, III and their controller settings) and Table 8 (captured-state ranges that
start the passive-deceleration phase, section IV.C).

The paper draws its points with MATLAB's ``haltonset``; we use SciPy's scrambled Halton sequence
(:class:`scipy.stats.qmc.Halton`, ``d = 15``, one dimension per parameter in the order of
``UNCERTAIN_PARAMETERS``) and map each unit coordinate ``u`` linearly onto its range,
``lo + u (hi - lo)``. The points are therefore not MATLAB's; they are a low-discrepancy design over
the same box, deterministic for a seed, and the first ``n`` points of a larger draw equal the
``n``-point draw (a sweep can be extended without changing its earlier cases).

Readings and corrections of the paper, written down:

* **Table 8's row numbering is garbled** ("1-2, 1-2, 3-4, 5-6, 7, 10"). We read its six rows as
  Table 3's rows in Table 3's order: ``[r_x, r_y]`` (1-2) +-17 m, ``[v_x, v_y]`` (3-4) +-2 m/s,
  ``[theta_x, theta_y]`` (5-6) +-16 deg, ``theta_z`` (7) +-26 deg, ``[omega_x, omega_y]`` (8-9)
  +-6 deg/s, ``omega_z`` (10) +-0.6 deg/s. The parameter column is unambiguous; only the numbers
  are shifted.
* Table 8 is the same for the three scenarios (Table 4: "Captured states in Table 8"); the scenarios
  of the passive phase differ only in the maximal steady wind speed. Table 4 gives no time delay and
  no measurement noise for the passive phase (motors off, no measurements used): their ranges are
  ``(0, 0)`` there, so every passive sample has ``motor_delay_s = noise_rms_m = 0``. The Halton
  dimensions stay 15 in both phases, so a point's other coordinates do not depend on the phase.
* ``gust_intensity`` (``lambda_wg``) is given in percent in Tables 2 and 4 (10 % to 20 %); we store
  it as a fraction, 0.10 to 0.20 [-].
* Table 2 gives the wind angle range as ``[0, theta_w^max]`` with ``theta_w^max = 360`` deg and the
  steady wind speed as ``[0, v_ws^max]``; the time delay ``[0, tau^max]`` and the noise RMS
  ``[0, sigma_r^max]`` start at zero too.
* Table 3 lists ``omega_z`` on its own row with the same range as ``omega_x, omega_y`` (+-0.1 deg/s).
* The vertical capture velocity is not uncertain: "the vertical landing velocity margin of the rocket
  was given as 20 m/s" (section IV), so :func:`captures_from_samples` sets ``vz = -20`` m/s (z up).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from jaxcable.core.validation import check_choice, check_positive
from jaxcable.arresting.layout import CaptureState
from jaxcable.studies import qmc

__all__ = [
    "PARAMETER_DESCRIPTIONS",
    "PHASES",
    "SCENARIOS",
    "UNCERTAIN_PARAMETERS",
    "captures_from_samples",
    "halton_samples",
    "halton_unit",
    "scenario_ranges",
    "scenario_settings",
]

UNCERTAIN_PARAMETERS = (
    "x_m",
    "y_m",
    "vx_m_s",
    "vy_m_s",
    "theta_x_deg",
    "theta_y_deg",
    "theta_z_deg",
    "omega_x_deg_s",
    "omega_y_deg_s",
    "omega_z_deg_s",
    "wind_angle_deg",
    "wind_speed_m_s",
    "gust_intensity",
    "motor_delay_s",
    "noise_rms_m",
)
"""The 15 uncertain parameters of Table 2 in the table's order (names carry the SI/paper unit)."""

PARAMETER_DESCRIPTIONS = {
    "x_m": "lateral position deviation r_x of O [m] (Table 2 row 1)",
    "y_m": "lateral position deviation r_y of O [m] (row 2)",
    "vx_m_s": "lateral velocity deviation v_x [m/s] (row 3)",
    "vy_m_s": "lateral velocity deviation v_y [m/s] (row 4)",
    "theta_x_deg": "inclination, rotation-vector component theta_x [deg] (row 5)",
    "theta_y_deg": "inclination, rotation-vector component theta_y [deg] (row 6)",
    "theta_z_deg": "roll, rotation-vector component theta_z [deg] (row 7)",
    "omega_x_deg_s": "angular velocity deviation omega_x [deg/s] (row 8)",
    "omega_y_deg_s": "angular velocity deviation omega_y [deg/s] (row 9)",
    "omega_z_deg_s": "angular velocity deviation omega_z [deg/s] (row 10)",
    "wind_angle_deg": "wind angle theta_w [deg] (row 11)",
    "wind_speed_m_s": "stationary wind speed v_ws [m/s] (row 12)",
    "gust_intensity": "gust fluctuation intensity lambda_wg [-], a fraction (row 13; the paper: %)",
    "motor_delay_s": "motor time delay tau [s] (row 14)",
    "noise_rms_m": "RMS of the measurement noise sigma_r [m] (row 15)",
}

SCENARIOS = ("I", "II", "III")
"""The three wind scenarios of Table 4."""

PHASES = ("full", "passive")
"""``full``: the two-phase simulation from the terminal-guidance point (Tables 3 and 4);
``passive``: the passive-deceleration phase from the captured state (Tables 8 and 4)."""

# Table 4, per scenario: maximal steady wind speed [m/s], terminal-guidance height h [m], design
# tracking time t_c [s] and the proportional gain a_p [1/s] of the PD law (eq 4) (section II.A).
_SCENARIO_SETTINGS = {
    "I": dict(v_ws_max=5.0, h_m=200.0, t_c_s=10.0, a_p=2.0),
    "II": dict(v_ws_max=10.0, h_m=120.0, t_c_s=6.0, a_p=5.0),
    "III": dict(v_ws_max=20.0, h_m=100.0, t_c_s=5.0, a_p=6.0),
}

# Table 4, all scenarios and both phases: wind angle up to 360 deg, gust intensity 10 % to 20 %.
_WIND_ANGLE_MAX_DEG = 360.0
_GUST_INTENSITY_RANGE = (0.10, 0.20)
# Table 4, active phase only: tau_max = 0.1 s, sigma_r_max = 0.1 m.
_MOTOR_DELAY_MAX_S = 0.1
_NOISE_RMS_MAX_M = 0.1

# Table 3: terminal-guidance states (half-widths of symmetric ranges).
_TERMINAL_GUIDANCE_HALF = dict(
    x_m=13.0, y_m=13.0, vx_m_s=0.1, vy_m_s=0.1, theta_x_deg=5.0, theta_y_deg=5.0, theta_z_deg=25.0,
    omega_x_deg_s=0.1, omega_y_deg_s=0.1, omega_z_deg_s=0.1,
)
# Table 8 (our reading of its row numbers, see the module docstring): captured states.
_CAPTURED_HALF = dict(
    x_m=17.0, y_m=17.0, vx_m_s=2.0, vy_m_s=2.0, theta_x_deg=16.0, theta_y_deg=16.0, theta_z_deg=26.0,
    omega_x_deg_s=6.0, omega_y_deg_s=6.0, omega_z_deg_s=0.6,
)

CAPTURE_VZ_M_S = -20.0
"""Vertical velocity of O at capture [m/s], z up (section IV: the 20 m/s vertical landing margin)."""


def scenario_settings(scenario: str) -> dict:
    """Table 4 settings of a scenario: ``v_ws_max`` [m/s] (maximal steady wind speed), ``h_m`` [m]
    (terminal-guidance height), ``t_c_s`` [s] (design tracking time) and ``a_p`` [-] (saturation
    exponent of the PD controller). ``h_m``, ``t_c_s`` and ``a_p`` belong to the active phase."""
    check_choice("scenario", scenario, SCENARIOS)
    return dict(_SCENARIO_SETTINGS[scenario])


def scenario_ranges(scenario: str = "I", phase: str = "passive") -> dict:
    """``{name: (lo, hi)}`` for the 15 parameters of ``UNCERTAIN_PARAMETERS`` (in that order).

    ``phase="full"``: Table 3 states, Table 4 wind, delay and noise. ``phase="passive"``: Table 8
    captured states, Table 4 wind; delay and noise ``(0, 0)`` (not used in the passive phase)."""
    check_choice("scenario", scenario, SCENARIOS)
    check_choice("phase", phase, PHASES)
    half = _TERMINAL_GUIDANCE_HALF if phase == "full" else _CAPTURED_HALF
    ranges = {name: (-h, h) for name, h in half.items()}
    ranges["wind_angle_deg"] = (0.0, _WIND_ANGLE_MAX_DEG)
    ranges["wind_speed_m_s"] = (0.0, _SCENARIO_SETTINGS[scenario]["v_ws_max"])
    ranges["gust_intensity"] = _GUST_INTENSITY_RANGE
    active = phase == "full"
    ranges["motor_delay_s"] = (0.0, _MOTOR_DELAY_MAX_S if active else 0.0)
    ranges["noise_rms_m"] = (0.0, _NOISE_RMS_MAX_M if active else 0.0)
    return {name: (float(ranges[name][0]), float(ranges[name][1])) for name in UNCERTAIN_PARAMETERS}


def halton_unit(n: int, seed: int = 0) -> np.ndarray:
    """The first ``n`` points of the scrambled 15-dimensional Halton sequence of ``seed``: (n, 15) in
    [0, 1). Deterministic; the first rows of a larger draw equal a smaller draw (same seed)."""
    # Halton (not Sobol): the paper's design, and any n is balanced; scrambled (15 primes up to 47:
    # the unscrambled sequence correlates its high dimensions). See jaxcable.studies.qmc.
    return qmc.halton_unit(_check_count(n), len(UNCERTAIN_PARAMETERS), seed)


def halton_samples(n: int, scenario: str = "I", phase: str = "passive", seed: int = 0) -> dict:
    """``n`` quasi-Monte Carlo cases: ``{name: np.ndarray (n,)}`` for every name of
    ``UNCERTAIN_PARAMETERS``, each mapped linearly from the Halton point onto
    :func:`scenario_ranges` ``(scenario, phase)``."""
    return qmc.scaled_halton(scenario_ranges(scenario, phase), _check_count(n), seed)


def captures_from_samples(samples: dict, vz_m_s: float = CAPTURE_VZ_M_S) -> CaptureState:
    """A :class:`CaptureState` whose fields are arrays (n,) from samples (the wind, delay and noise
    entries are not capture states and are ignored). ``vz_m_s`` [m/s] (default -20, z up); ``z_m``
    is 0 (the scene builders place O). Vmap a scene builder over it to run the cases."""
    names = UNCERTAIN_PARAMETERS[:10]
    missing = [k for k in names if k not in samples]
    if missing:
        raise ValueError(f"samples lack the capture-state entries {missing}")
    arrays = {k: np.atleast_1d(np.asarray(samples[k], dtype=float)) for k in names}
    n = arrays["x_m"].shape[0]
    for k, v in arrays.items():
        if v.shape != (n,):
            raise ValueError(f"samples[{k!r}] has shape {v.shape}; every entry must have shape ({n},)")
    _check_capture_arrays(arrays)
    arrays["z_m"] = np.zeros(n)
    arrays["vz_m_s"] = np.full(n, float(vz_m_s))
    # CaptureState's own checks accept scalars only (its tilt check converts to one float), so the
    # batch is assembled by vmapping the constructor (checks skipped on tracers) after the same
    # checks ran above on every case.
    return jax.vmap(lambda d: CaptureState(**d))({k: jnp.asarray(v) for k, v in arrays.items()})


def _check_capture_arrays(arrays):
    """CaptureState's checks case by case, naming the field, the case index and the value."""
    for k, v in arrays.items():
        bad = np.nonzero(~np.isfinite(v))[0]
        if bad.size:
            raise ValueError(f"{k} must be finite, got {v[bad[0]]!r} in case {int(bad[0])}")
    roll = arrays["theta_z_deg"]
    bad = np.nonzero(np.abs(roll) >= 45.0)[0]
    if bad.size:
        raise ValueError(
            f"theta_z_deg must be in (-45.0, 45.0) deg (hook k must face cable k), "
            f"got {roll[bad[0]]!r} in case {int(bad[0])}"
        )
    tilt = np.hypot(arrays["theta_x_deg"], arrays["theta_y_deg"])
    bad = np.nonzero(tilt >= 60.0)[0]
    if bad.size:
        raise ValueError(f"inclination |(theta_x, theta_y)| = {tilt[bad[0]]:g} deg in case {int(bad[0])}: must be < 60 deg")


def _check_count(n):
    if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)):
        raise ValueError(f"n must be a non-negative integer, got {n!r}")
    check_positive("n", n, allow_zero=True)
    return int(n)
