"""Property-based fuzzing of bad input: the command line and the public builders.

Each test draws bad configurations (negative, zero, NaN, infinite, out of the physical range, of the
wrong type, or inconsistent with another value) and asserts a clear error that names the field (a
builder's argument or field name, or the command-line flag), raised before anything is compiled:
never a run, and so never a silent absurd or NaN result. The bounds are the ones the builders
document (e.g. :class:`jaxcable.arresting.layout.CaptureState`); every value drawn lies outside
them, so a drawn value that a builder accepts is a failure (it would start a simulation).

The draws are derandomised (the suite is reproducible) and number 1,400 in all; the file runs in
well under a minute because every rejection happens before any compilation.
"""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from jaxcable.arresting.buffer import BufferDevice
from jaxcable.arresting.control import TrackingController
from jaxcable.arresting.landing import run_landing
from jaxcable.arresting.layout import ArrestingLayout, CaptureState
from jaxcable.arresting.passive import (
    LEVEL_CABLE_MESH,
    LandingCriteria,
    passive_landing_scene,
)
from jaxcable.arresting.two_phase import run_two_phase, tracking_scene
from jaxcable.cli import main as cli_main
from jaxcable.components.contact import ContactLaw
from jaxcable.components.wind import AeroCoefficients, WindField
from jaxcable.core.simulate import simulate
from jaxcable.throw.rocket import PointRocket
from jaxcable.throw.scene import line_throwing_scene


def _settings(n):
    return settings(
        max_examples=n,
        deadline=None,
        derandomize=True,
        database=None,
        suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    )


# -- bad numbers ----------------------------------------------------------------------------------

NON_FINITE = st.sampled_from([math.nan, math.inf, -math.inf])


def outside(low=None, high=None, *, low_open=False, high_open=False, integer=False):
    """Numbers outside [low, high] (``low_open``: ``low`` itself is bad too), and NaN/inf for floats."""
    parts = []
    if integer:
        if low is not None:
            parts.append(st.integers(max_value=int(low) - (0 if low_open else 1)))
        if high is not None:
            parts.append(st.integers(min_value=int(high) + (0 if high_open else 1)))
        return st.one_of(parts)
    kw = {"allow_nan": False, "allow_infinity": False}
    if low is not None:
        parts.append(st.floats(max_value=low, exclude_max=not low_open, **kw))
    if high is not None:
        parts.append(st.floats(min_value=high, exclude_min=not high_open, **kw))
    return st.one_of(*parts, NON_FINITE)


WRONG_TYPE = st.sampled_from(["1.0", "abc", None, [1.0, "x"], {"a": 1.0}, 1 + 2j, True, object()])
"""Values of the wrong type for a number (a string, None, a mixed list, a dict, complex, a bool, ...)."""


def bad_number(low=None, high=None, *, none_ok=False, **kw):
    """Numbers outside the range, and values of the wrong type (not ``None`` where it means "default")."""
    wrong = WRONG_TYPE.filter(lambda v: v is not None) if none_ok else WRONG_TYPE
    return st.one_of(outside(low, high, **kw), wrong)


def _names_field(err, names):
    text = str(err)
    assert any(n in text for n in names), f"error does not name {names}: {text!r}"


def _rejects(build, names):
    with pytest.raises((ValueError, TypeError)) as info:
        build()
    _names_field(info.value, names)


# -- the command line -----------------------------------------------------------------------------

# flag -> (bad values, the names an error may give it, extra arguments that make the flag count)
PASSIVE = ["land", "--fidelity", "rigid"]
ONE_DOF = ["land", "--fidelity", "1dof"]
ALE = ["land", "--fidelity", "ale"]
FULL = ["land", "--fidelity", "full"]
FULL_PHASE = ["land", "--phase", "full", "--fidelity", "rigid"]
THROW = ["throw"]

CLI_FLAGS = {
    # passive phase: capture state (CaptureState's bounds; |x|, |y| < l_0 - l_1 = 21.5 m at Table 1)
    "--x": (outside(-21.5, 21.5, low_open=True, high_open=True), ["x_m"], PASSIVE),
    "--y": (outside(-21.5, 21.5, low_open=True, high_open=True), ["y_m"], PASSIVE),
    "--vx": (outside(-100.0, 100.0), ["vx_m_s"], PASSIVE),
    "--vy": (outside(-100.0, 100.0), ["vy_m_s"], PASSIVE),
    "--vz": (outside(-100.0, 100.0), ["vz_m_s"], PASSIVE),
    "--theta-x": (outside(-60.0, 60.0, low_open=True, high_open=True), ["theta_x_deg"], PASSIVE),
    "--theta-y": (outside(-60.0, 60.0, low_open=True, high_open=True), ["theta_y_deg"], PASSIVE),
    "--theta-z": (outside(-45.0, 45.0, low_open=True, high_open=True), ["theta_z_deg"], PASSIVE),
    "--omega-x": (outside(-360.0, 360.0), ["omega_x_deg_s"], PASSIVE),
    "--omega-y": (outside(-360.0, 360.0), ["omega_y_deg_s"], PASSIVE),
    "--omega-z": (outside(-360.0, 360.0), ["omega_z_deg_s"], PASSIVE),
    # buffer, cables, mesh, run
    "--counterweight-mass": (outside(0.0, 1e5, low_open=True), ["counterweight_mass"], ONE_DOF),
    "--brake-force": (outside(0.0, 1e7), ["brake_force"], ONE_DOF),
    "--cable-damping": (outside(0.0, 0.1), ["cable_damping"], PASSIVE),
    "--span-elements": (st.one_of(outside(10, 256, integer=True), st.sampled_from(["2.5", "x"])),
                        ["span-elements", "n_span_elements"], ALE),
    # fine elements: 1 .. the ale level's default span elements - 2 (a coarse element on each side)
    "--fine-elements": (st.one_of(outside(1, LEVEL_CABLE_MESH["ale"][0] - 2, integer=True), st.sampled_from(["1.5", "x"])),
                        ["fine-elements", "n_fine"], ALE),
    "--rocket-bodies": (st.one_of(outside(1, 100, integer=True), st.sampled_from(["1.5", "x"])),
                        ["rocket-bodies", "n_rocket_bodies"], FULL),
    "--t-end": (outside(0.0, 60.0, low_open=True), ["t-end", "t_end"], PASSIVE),
    "--rtol": (outside(0.0, 0.1, low_open=True), ["rtol"], PASSIVE),
    "--fidelity": (st.sampled_from(["2dof", "", "RIGID", "nan"]), ["--fidelity"], ["land"]),
    # phase full: tracking, wind, noise (scenario I: t_c = 10 s)
    "--wind-speed": (outside(0.0, 100.0), ["wind_speed", "wind-speed"], FULL_PHASE),
    "--wind-angle": (outside(-360.0, 360.0), ["wind_angle", "wind-angle"], FULL_PHASE),
    "--gust-intensity": (outside(0.0, 1.0), ["gust_intensity", "gust-intensity"], FULL_PHASE),
    "--motor-delay": (outside(0.0, 10.0, high_open=True), ["motor_delay", "motor-delay"], FULL_PHASE),
    "--noise-rms": (outside(0.0, 10.0), ["noise_rms", "noise-rms"], FULL_PHASE),
    "--gain": (outside(0.0, 100.0, low_open=True), ["gain"], FULL_PHASE),
    "--seed": (st.one_of(outside(0, 2**32 - 1, integer=True), st.sampled_from(["1.5", "x", "nan"])),
               ["seed"], FULL_PHASE),
    # the line-throwing rocket (800 m of rope in 1 m segments by default)
    "--angle": (outside(0.0, 90.0, low_open=True, high_open=True), ["angle"], THROW),
    "--segment-length": (outside(0.1, 800.0), ["segment_length", "segment-length"], THROW),
    "--rope-length": (outside(0.0, 5000.0, low_open=True), ["rope_length", "rope-length"], THROW),
    "--t-max": (outside(0.0, 600.0, low_open=True), ["t-max", "t1"], THROW),
    "--pcoeff": (outside(0.0), ["pcoeff"], THROW),
    "--icoeff": (outside(0.0, low_open=True), ["icoeff"], THROW),
}
"""Each flag's bad values, the names its error may use (the flag, or the builder's field it feeds:
``--t-max`` is :func:`jaxcable.core.simulate`'s ``t1``, ``--fine-elements`` the scene's ``n_fine``),
and the arguments before it. Not drawn: ``--t-end`` and ``--cable-damping`` too large with ``--phase
full``, which :func:`run_two_phase` rejects only after its tracking phase (by ``run_landing``)."""


def _text(value):
    return value if isinstance(value, str) else repr(value) if isinstance(value, int) else f"{value!r}"


def _run_cli(argv, capsys):
    capsys.readouterr()
    try:
        code = cli_main(argv)
    except SystemExit as exc:  # argparse: bad syntax or a bad choice
        code = exc.code
    return code, capsys.readouterr().err


@_settings(600)
@given(data=st.data())
def test_cli_rejects_bad_flags_naming_them(data, capsys):
    flag = data.draw(st.sampled_from(sorted(CLI_FLAGS)), label="flag")
    values, names, before = CLI_FLAGS[flag]
    value = data.draw(values, label="value")
    argv = [*before, f"{flag}={_text(value)}", "--json"]  # "--x=-1e9": argparse takes a negative value
    code, err = _run_cli(argv, capsys)
    assert code == 2, (argv, code, err)
    _names_field(err, [flag, *names])


_LATERAL = {"--x": "x_m", "--y": "y_m", "--vx": "vx_m_s", "--vy": "vy_m_s", "--theta-x": "theta_x_deg",
            "--theta-y": "theta_y_deg", "--omega-x": "omega_x_deg_s", "--omega-y": "omega_y_deg_s"}  # fmt: skip

CLI_COMBINATIONS = st.one_of(
    # a 1-DOF landing is vertical and central
    st.tuples(st.sampled_from(sorted(_LATERAL)), st.floats(0.5, 10.0)).map(
        lambda t: ([*ONE_DOF, f"{t[0]}={t[1]!r}"], [_LATERAL[t[0]]])
    ),
    # the fine elements need a coarse one on each side: span >= fine + 2
    st.tuples(st.integers(3, 40), st.integers(1, 40)).filter(lambda t: t[0] < t[1] + 2).map(
        lambda t: ([*ALE, f"--span-elements={t[0]}", f"--fine-elements={t[1]}"], ["n_span_elements", "n_fine"])
    ),
    # a tilt of 60 deg or more, from two components each below 60
    st.floats(42.5, 59.9).map(
        lambda a: ([*PASSIVE, f"--theta-x={a!r}", f"--theta-y={-a!r}"], ["theta_x_deg", "theta_y_deg"])
    ),
    # the motor's dead time must end before the tracking does (scenario III: t_c = 5 s)
    st.floats(5.0, 10.0).map(
        lambda d: ([*FULL_PHASE, "--scenario=III", f"--motor-delay={d!r}"], ["motor_delay", "tracking_time"])
    ),
    # the passive phase's mesh flags and --phase full; --phase full needs a 3-D level
    st.just(([*FULL_PHASE, "--span-elements=8"], ["--span-elements"])),
    st.just((["land", "--phase", "full", "--fidelity", "1dof"], ["--fidelity"])),
    st.just(([*ONE_DOF, "--brake-profile=1,2"], ["--brake-profile"])),
    st.just(([*PASSIVE, "--brake-profile=1,x"], ["--brake-profile", "brake_profile"])),
    st.just(([*PASSIVE, "--brake-profile=1,-2"], ["--brake-profile", "brake_profile"])),
    st.just(([*PASSIVE, "--brake-profile=1"], ["--brake-profile", "brake_profile"])),
    # the segments fit in the rope
    st.floats(1.0, 100.0).map(
        lambda r: ([*THROW, f"--rope-length={r!r}", f"--segment-length={2 * r!r}"], ["segment_length"])
    ),
)


@_settings(100)
@given(case=CLI_COMBINATIONS)
def test_cli_rejects_inconsistent_flags(case, capsys):
    argv, names = case
    code, err = _run_cli([*argv, "--json"], capsys)
    assert code == 2, (argv, code, err)
    _names_field(err, names)


# -- Modules: each field of the configuration objects ----------------------------------------------

MODULE_FIELDS = {
    CaptureState: {
        **{f: bad_number(-1000.0, 1000.0) for f in ("x_m", "y_m", "z_m")},
        **{f: bad_number(-100.0, 100.0) for f in ("vx_m_s", "vy_m_s", "vz_m_s")},
        **{f: bad_number(-60.0, 60.0) for f in ("theta_x_deg", "theta_y_deg")},
        "theta_z_deg": bad_number(-45.0, 45.0, low_open=True, high_open=True),
        **{f: bad_number(-360.0, 360.0) for f in ("omega_x_deg_s", "omega_y_deg_s", "omega_z_deg_s")},
    },
    ArrestingLayout: {
        "half_span_m": bad_number(3.5, 1000.0, low_open=True),  # l_0 > l_1 = 3.5
        "frame_half_width_m": bad_number(0.02, 25.0, low_open=True, high_open=True),  # r < l_1 < l_0
        "tower_height_m": bad_number(0.0, 1000.0, low_open=True),
        "block_strand_m": bad_number(0.0, 1000.0, low_open=True),
        "cable_radius_m": bad_number(0.0, 0.5, low_open=True),
        "EA_N": bad_number(5e6, 1e13, low_open=True),  # pre-tension 5e4 N <= 1 % EA
        "rhoA_kg_per_m": bad_number(0.0, 1e4, low_open=True),
        "pretension_N": bad_number(0.0, 2.7e6),  # 1 % of EA: 2.64e6 N
    },
    BufferDevice: {
        "counterweight_mass_kg": bad_number(0.0, 1e5, low_open=True),
        "brake_force_N": bad_number(0.0, 1e7),
        "transfer_rate": bad_number(0.0, 100.0, low_open=True),
        "brake_velocity_width_m_s": bad_number(0.0, 10.0, low_open=True),
        "brake_profile_travel_m": bad_number(0.0, 1000.0, low_open=True),
        "brake_profile": st.one_of(
            st.lists(st.floats(0.0, 2.0), min_size=0, max_size=1),
            st.lists(outside(0.0, 100.0), min_size=2, max_size=4),
            st.sampled_from(["1,2", [1.0, "x"], 3 + 1j]),
        ),
    },
    LandingCriteria: {f: bad_number(0.0, low_open=True) for f in ("z_max_m", "a_max_g", "sigma_max_mpa", "filter_cfc_hz")},
    TrackingController: {
        "gain_per_s": bad_number(0.0, 100.0, low_open=True),
        "derivative_gain": bad_number(0.0, 100.0),
        "tracking_time_s": bad_number(0.1, 600.0, low_open=True),  # above the default 0.1 s delay
        "motor_delay_s": bad_number(0.0, 10.0, high_open=True),  # below the default t_c = 10 s
        "motor_bandwidth_per_s": bad_number(0.0, 1e4, low_open=True),
        "sample_period_s": bad_number(1e-4, 1.0),
        "noise_rms_m": bad_number(0.0, 10.0),
    },
    WindField: {
        "speed_m_s": bad_number(0.0, 100.0),
        "angle_deg": bad_number(-360.0, 360.0),
        "gust_intensity": bad_number(0.0, 1.0),
        "air_density_kg_m3": bad_number(0.0, 10.0),
        "length_scale_m": bad_number(0.0, low_open=True),
        "lateral_ratio": bad_number(0.0),
        "key": st.one_of(outside(0, 2**32 - 1, integer=True), st.sampled_from(["seed", 1.5, None])),
    },
    AeroCoefficients: {
        f: bad_number(0.0)
        for f in ("rocket_axial_drag_coefficient", "rocket_normal_force_slope_per_rad",
                  "cable_normal_drag_coefficient", "cable_tangential_drag_coefficient")
    },
    ContactLaw: {
        "k": bad_number(0.0, low_open=True),
        "e": bad_number(1.0, 5.0),
        "mu_s": bad_number(0.0, 2.0),
        "mu_d": bad_number(0.0, 2.0),
        "v_s": bad_number(0.0, 0.05, low_open=True, high_open=True),  # below v_d = 0.05
        "onset_width": bad_number(0.0, low_open=True),
    },
}


@_settings(350)
@given(data=st.data())
def test_module_fields_reject_bad_values_naming_the_field(data):
    cls = data.draw(st.sampled_from(list(MODULE_FIELDS)), label="module")
    field = data.draw(st.sampled_from(sorted(MODULE_FIELDS[cls])), label="field")
    value = data.draw(MODULE_FIELDS[cls][field], label="value")
    names = ["brake_profile"] if field == "brake_profile" else [field]
    _rejects(lambda: cls(**{field: value}), names)


MODULE_COMBINATIONS = st.one_of(
    st.floats(42.5, 59.9).map(lambda a: (CaptureState, {"theta_x_deg": a, "theta_y_deg": a}, "theta_x_deg")),
    st.floats(1.0, 100.0).map(lambda w: (ArrestingLayout, {"half_span_m": w, "frame_half_width_m": w}, "frame_half_width_m")),
    st.floats(0.1, 0.5).map(lambda r: (ArrestingLayout, {"frame_half_width_m": r, "cable_radius_m": r}, "cable_radius_m")),
    st.floats(1e6, 1e8).map(lambda ea: (ArrestingLayout, {"EA_N": ea, "pretension_N": 0.02 * ea}, "pretension_N")),
    st.floats(0.5, 10.0).map(lambda t: (TrackingController, {"tracking_time_s": t, "motor_delay_s": t}, "motor_delay_s")),
    st.floats(0.01, 1.0).map(lambda v: (ContactLaw, {"v_s": v, "v_d": v}, "v_s")),
    st.floats(1.0, 20.0).map(lambda m: (PointRocket, _rocket(mass_kg=m, propellant_mass_kg=m), "propellant_mass_kg")),
    st.floats(1e-3, 1.0).map(lambda f: (WindField, {"min_frequency_hz": f, "max_frequency_hz": f}, "max_frequency_hz")),
)


def _rocket(**kw):
    """The paper's rocket's fields (section 4.1), some replaced."""
    paper = {"mass_kg": 20.0, "propellant_mass_kg": 2.33, "total_impulse_Ns": 4770.0, "burn_time_s": 0.43,
             "diameter_m": 0.122, "drag_coefficient": 0.3}  # fmt: skip
    return {**paper, **kw}


@_settings(50)
@given(case=MODULE_COMBINATIONS)
def test_modules_reject_inconsistent_values(case):
    cls, kwargs, name = case
    _rejects(lambda: cls(**kwargs), [name])


# -- builders: scenes, runs and the solver ---------------------------------------------------------

_THROW_SCENE = line_throwing_scene(segment_length_m=2.0, rope_length_m=20.0)

BUILDER_ARGS = {
    "line_throwing_scene": (line_throwing_scene, {
        "angle_deg": bad_number(0.0, 90.0, low_open=True, high_open=True),
        "segment_length_m": bad_number(0.1, 750.0),
        "rope_length_m": bad_number(1.0, 5000.0),  # at least the 1 m segment
        "rocket_drag_coefficient": bad_number(0.0, 10.0, none_ok=True),
        "rope_drag_coefficient": bad_number(0.0, 10.0, none_ok=True),
        "rope_linear_density_kg_per_m": bad_number(0.0, 10.0, low_open=True, none_ok=True),
        "rope_diameter_m": bad_number(0.0, 0.5, low_open=True, none_ok=True),
        "pullout": st.sampled_from(["magic", 3, "", "NONE"]),
        "pullout_force_N": bad_number(0.0, 1e5),
        "drag_form": st.sampled_from(["sideways", None, 1]),
        "rail_length_m": bad_number(0.0, 750.0, low_open=True, high_open=True),
        "gravity_mps2": bad_number(0.0, 100.0),
        "air_density_kgpm3": bad_number(0.0, 10.0),
        "ground": st.sampled_from([1, "yes", None]),
        "drag": st.sampled_from([0, "no", None]),
    }),
    "passive_landing_scene": (lambda **kw: passive_landing_scene("rigid", **kw), {
        "capture": st.sampled_from([{"x_m": 1.0}, "design", 3.0]),
        "layout": st.sampled_from([{"EA_N": 1.0}, "Table 1", 25.0]),
        "buffer": st.sampled_from([{"brake_force_N": 1.0}, "paper", 920.0]),
        # None: the level's mesh (LEVEL_CABLE_MESH; the rigid rocket's is the ale level's)
        "n_span_elements": st.one_of(outside(10, 256, integer=True), st.sampled_from([16.0, "16"])),
        "n_fine": st.one_of(outside(1, LEVEL_CABLE_MESH["ale"][0] - 2, integer=True), st.sampled_from([8.0, "8"])),
        "fine_half_width_m": bad_number(0.0, 1000.0, low_open=True),
        "n_rocket_bodies": st.one_of(outside(1, 100, integer=True), st.sampled_from([5.0, "5"])),
        "t_end_s": bad_number(0.0, 60.0, low_open=True),
        "cable_damping_s": bad_number(0.0, 0.1),
        "frame_centre_xy": st.sampled_from([[0.0], [0.0, 0.0, 0.0], [math.nan, 0.0], [0.0, math.inf], "centre"]),
        "wind": st.sampled_from(["calm", 5.0, {"speed_m_s": 5.0}]),
        "aero": st.sampled_from(["default", 0.8]),
        "wind_time_offset_s": bad_number(0.0),
        "save_spacing_s": bad_number(0.0, 1.0, low_open=True),
        "n_save": st.one_of(outside(2, 10**7, integer=True), st.sampled_from([2.5, True, "401"])),
    }),
    "run_landing": (lambda **kw: run_landing(kw.pop("fidelity", "rigid"), **kw), {
        "fidelity": st.sampled_from(["medium", "", None, 1, "RIGID"]),
        "t_end_s": bad_number(0.0, 60.0, low_open=True),
        "solver": st.sampled_from(["rk99", "", 3]),  # None: the level's default
        "rtol": bad_number(0.0, 0.1, low_open=True, none_ok=True),
        "atol": bad_number(0.0, low_open=True, none_ok=True),
        "max_steps": st.one_of(outside(1, 10**9, integer=True), st.sampled_from([1e5, "100", True])),
        "criteria": st.sampled_from([None, {"z_max_m": 10.0}, 10.0]),
        "progress": st.sampled_from(["yes", 1, None]),
        "cable_damping_s": bad_number(0.0, 0.1),
    }),
    "tracking_scene": (tracking_scene, {
        "scenario": st.sampled_from(["IV", "i", 1, None, ""]),
        "height_m": bad_number(0.0, 1000.0, low_open=True, none_ok=True),
        "tracking_time_s": bad_number(2.0, 600.0, none_ok=True),  # h / t_c <= 100 m/s at h = 200 m
        "gain_per_s": bad_number(0.0, 100.0, low_open=True, none_ok=True),
        "motor_delay_s": bad_number(0.0, 10.0, high_open=True),
        "noise_rms_m": bad_number(0.0, 10.0),
        "wind_speed_m_s": bad_number(0.0, 100.0, none_ok=True),
        "wind_angle_deg": bad_number(-360.0, 360.0),
        "gust_intensity": bad_number(0.0, 1.0),
        "seed": st.one_of(outside(0, 2**32 - 1, integer=True), st.sampled_from([1.5, "0", None, True])),
        "terminal": st.sampled_from(["deviated", {"x_m": 13.0}, 13.0]),
        "layout": st.sampled_from(["Table 1", 25.0]),
    }),
    "run_two_phase": (run_two_phase, {
        "fidelity": st.sampled_from(["1dof", "medium", None]),
        "passive_t_end_s": bad_number(0.0, low_open=True),
        "cable_damping_s": bad_number(0.0),
        "buffer": st.sampled_from(["paper", 920.0]),
        "criteria": st.sampled_from([None, "paper"]),
        "wind_speed_m_s": bad_number(0.0, 100.0, none_ok=True),
        "noise_rms_m": bad_number(0.0, 10.0),
        "seed": st.one_of(outside(0, 2**32 - 1, integer=True), st.sampled_from([1.5, "0"])),
    }),
    "simulate": (lambda **kw: simulate(_THROW_SCENE, kw.pop("t1", 30.0), **kw), {
        "t1": bad_number(0.0, 600.0, low_open=True),
        "solver": st.sampled_from(["rk99", "", None, 3, "tsit"]),
        "rtol": bad_number(0.0, 0.1, low_open=True),
        "atol": bad_number(0.0, low_open=True),
        "max_steps": st.one_of(outside(1, 10**9, integer=True), st.sampled_from([1e5, "100", True, 2.5])),
        "dt0": st.one_of(outside(0.0, 30.0, low_open=True), st.sampled_from(["0.1", True])),
        "save_ts": st.sampled_from([[1.0, 0.5], [-1.0, 1.0], [0.0, 31.0], [0.0, math.nan], [[0.0, 1.0]], "0,1"]),
        "snapshot_ts": st.sampled_from([[2.0, 1.0], [0.0, 1e9], [math.inf], "all"]),
        "icoeff": bad_number(0.0, low_open=True),
        "pcoeff": st.one_of(st.floats(max_value=0.0, exclude_max=True), st.just(math.nan), st.just("0.4")),
        "progress": st.sampled_from(["yes", None, 1]),
        "jit": st.sampled_from(["no", None, 0]),
        "probes_after": st.sampled_from(["yes", 1, 0]),
    }),
}
"""Each public builder's arguments and their bad values (every other argument at its default)."""

_BUILDER_NAMES = {
    # the argument's name in messages where it differs from the keyword
    ("run_landing", "fidelity"): ["fidelity"],
    ("line_throwing_scene", "drag_form"): ["drag form"],
    ("line_throwing_scene", "pullout"): ["pull-out"],
    ("tracking_scene", "tracking_time_s"): ["tracking_time_s"],
}


@_settings(300)
@given(data=st.data())
def test_builders_reject_bad_arguments_naming_them(data):
    builder = data.draw(st.sampled_from(sorted(BUILDER_ARGS)), label="builder")
    build, args = BUILDER_ARGS[builder]
    name = data.draw(st.sampled_from(sorted(args)), label="argument")
    value = data.draw(args[name], label="value")
    _rejects(lambda: build(**{name: value}), _BUILDER_NAMES.get((builder, name), [name]))


def test_the_known_hole_is_closed(capsys):
    """``jaxcable land --fidelity rigid --vz 1e9`` used to report z_max = 2.4e8 m as a successful solve."""
    code, err = _run_cli(["land", "--fidelity", "rigid", "--vz", "1e9", "--json"], capsys)
    assert code == 2 and "vz_m_s" in err and "100 m/s" in err, err
    with pytest.raises(ValueError, match=r"\|vz_m_s\| must be <= 100 m/s"):
        CaptureState(vz_m_s=1e9)


def test_bounds_admit_the_values_in_use():
    """The papers', the tests' and the experiments' extreme values pass the bounds."""
    CaptureState(vz_m_s=-40.0)  # tests/test_hard_cases.py
    CaptureState(x_m=17.0, y_m=-17.0, vx_m_s=2.0, theta_x_deg=16.0, theta_y_deg=-16.0, theta_z_deg=26.0,
                 omega_x_deg_s=6.0, omega_y_deg_s=-6.0, omega_z_deg_s=0.6)  # Table 8's corners  # fmt: skip
    CaptureState(z_m=200.0, vz_m_s=-20.0)  # Table 4 scenario I's terminal state
    ArrestingLayout(EA_N=2.64e11)  # the stiffened-cable limit tests
    BufferDevice(counterweight_mass_kg=300.0, brake_force_N=0.0)
    BufferDevice(counterweight_mass_kg=5000.0, brake_force_N=5e5, brake_profile=np.full(16, 2.0))  # design bounds
    TrackingController(gain_per_s=10.0, tracking_time_s=5.0, motor_delay_s=0.1, noise_rms_m=0.1)
    WindField(20.0, 360.0, 0.2, key=2**32 - 1)
    line_throwing_scene(angle_deg=65.0, segment_length_m=20.0, rope_length_m=40.0)
