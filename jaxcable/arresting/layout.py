r"""Geometry of the arresting-cable system and the capture state (Table 1, Figs 1, 5, 7).

World frame ``oxyz``: origin at the centre of the truss top plane, **z up** (section II.B measures
the rocket's drop ``z`` downward; our outputs report that drop as a positive ``z_drop``). The four
guide rails run along the square's sides at ``x = +-l_0`` and ``y = +-l_0`` on the top plane z = 0.

Our reading of Fig 1b/7 (the figures are not in the text copy; the reading reproduces eq 12 exactly,
which is what the 1-DOF limit test checks). Cable ``k`` has a straight *arresting span* across the
truss between two slider pulleys on opposite rails; the four spans form the capture frame of side
``2 l_1``:

========  ====================  ======================================================
cable k   span direction        slider pulleys (capture frame centred at (x_c, y_c))
========  ====================  ======================================================
0 (east)  along y               (x_c + l_1, -l_0, 0) -> (x_c + l_1, +l_0, 0)
1 (west)  along y               (x_c - l_1, -l_0, 0) -> (x_c - l_1, +l_0, 0)
2 (north) along x               (-l_0, y_c + l_1, 0) -> (+l_0, y_c + l_1, 0)
3 (south) along x               (-l_0, y_c - l_1, 0) -> (+l_0, y_c - l_1, 0)
========  ====================  ======================================================

Beyond each slider pulley the cable runs down its tower to a ground pulley ``G`` (below the span's
midpoint, height ``-H``) and down a strand of length ``D`` to the moving pulley block of its buffer
device; both cable ends are tied to the block. The block moving up by ``u`` shortens both strands
by ``u``, which feeds ``2 u`` of cable into the span (see :mod:`jaxcable.arresting.buffer`).

Hooks engage cables one to one: hook 0 (body +X) with cable 0, hook 1 (+Y) with cable 2, hook 2
(-X) with cable 1, hook 3 (-Y) with cable 3, which holds while the roll angle |theta_z| < 45 deg.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from jaxcable.core.validation import (
    abs_at_most,
    as_array,
    check_fields,
    check_range,
    positive,
)

__all__ = ["ArrestingLayout", "CaptureState", "HOOK_OF_CABLE", "kink_return_times", "span_endpoints"]

HOOK_OF_CABLE = (0, 2, 1, 3)
"""Index of the hook that engages cable k (cables: east, west, north, south)."""


class ArrestingLayout(eqx.Module):
    """Arresting-cable geometry and cable properties (Table 1 defaults). Arrays, sweepable.

    Bounds (checked on concrete values; each admits Table 1 with a wide margin): lengths positive
    and at most 1 km (Table 1's truss is 50 m wide on 30 m towers); the capture frame inside the
    truss (``l_1 < l_0``); the cable radius below 0.5 m and below ``l_1`` (section II.B: 20 mm);
    ``EA`` at most 1e13 N (Table 1: 2.64e8 N; the stiffened-cable limit tests use 1000x that);
    ``rhoA`` at most 1e4 kg/m (Table 1: 9.8); the pre-tension at most 1 % of ``EA`` (a strain of
    1 %, about where steel wire rope breaks; the default 5e4 N is 1.9e-4 of ``EA``).
    """

    half_span_m: jax.Array = eqx.field(converter=as_array, default=25.0)
    """``l_0``: half the truss side [m] (Table 1: 2 l_0 = 50 m)."""
    frame_half_width_m: jax.Array = eqx.field(converter=as_array, default=3.5)
    """``l_1``: half the capture-frame side [m] (Table 1: 2 l_1 = 7 m)."""
    tower_height_m: jax.Array = eqx.field(converter=as_array, default=30.0)
    """``H``: height of the top plane above the ground pulleys [m] (Table 1: H >= 30 m)."""
    block_strand_m: jax.Array = eqx.field(converter=as_array, default=10.0)
    """``D``: initial length of each strand from the ground pulley to the moving block [m] (ours)."""
    cable_radius_m: jax.Array = eqx.field(converter=as_array, default=0.02)
    """Arresting cable radius [m] (section II.B: 20 mm); stress = tension / (pi r^2)."""
    EA_N: jax.Array = eqx.field(converter=as_array, default=2.64e8)
    """Cable axial stiffness [N] (Table 1)."""
    rhoA_kg_per_m: jax.Array = eqx.field(converter=as_array, default=9.8)
    """Cable mass per unit length [kg/m] (Table 1)."""
    pretension_N: jax.Array = eqx.field(converter=as_array, default=5.0e4)
    """Cable pre-tension at capture [N] (section II.A: "pre-tensioned"; value not given: ours)."""

    def __check_init__(self):
        km = {"high": 1000.0, "unit": " m", "why": "Table 1: a 50 m truss on 30 m towers"}
        check_fields(
            self,
            {
                "half_span_m": positive(**km),
                "frame_half_width_m": positive(**km),
                "tower_height_m": positive(**km),
                "block_strand_m": positive(**km),
                "cable_radius_m": positive(high=0.5, unit=" m", why="section II.B: 20 mm"),
                "EA_N": positive(high=1e13, unit=" N", why="Table 1: 2.64e8 N"),
                "rhoA_kg_per_m": positive(high=1e4, unit=" kg/m", why="Table 1: 9.8 kg/m"),
                "pretension_N": positive(allow_zero=True),
            },
        )
        _check_less("frame_half_width_m", self.frame_half_width_m, "half_span_m", self.half_span_m,
                    "the capture frame must lie inside the truss")  # fmt: skip
        _check_less("cable_radius_m", self.cable_radius_m, "frame_half_width_m", self.frame_half_width_m,
                    "the cables must fit inside the capture frame")  # fmt: skip
        _check_less("pretension_N", self.pretension_N, "0.01 EA_N", 0.01 * np.asarray(self.EA_N, float)
                    if _is_concrete(self.EA_N) else None, "a strain of 1 %, where steel wire rope breaks",
                    or_equal=True)  # fmt: skip

    @property
    def cable_area_m2(self):
        return jnp.pi * self.cable_radius_m**2


def span_endpoints(layout: ArrestingLayout, frame_centre_xy):
    """Slider-pulley positions of the four spans: (4, 2, 3) [m] (start, end), and the unit
    direction along each span (4, 3) and across it (4, 3)."""
    l0, l1 = layout.half_span_m, layout.frame_half_width_m
    xc, yc = frame_centre_xy[0], frame_centre_xy[1]
    zero = jnp.zeros_like(l0)
    starts = jnp.stack(
        [
            jnp.stack([xc + l1, -l0, zero]),
            jnp.stack([xc - l1, -l0, zero]),
            jnp.stack([-l0, yc + l1, zero]),
            jnp.stack([-l0, yc - l1, zero]),
        ]
    )
    ends = starts + jnp.stack(
        [
            jnp.stack([zero, 2 * l0, zero]),
            jnp.stack([zero, 2 * l0, zero]),
            jnp.stack([2 * l0, zero, zero]),
            jnp.stack([2 * l0, zero, zero]),
        ]
    )
    along = jnp.array([[0.0, 1, 0], [0, 1, 0], [1, 0, 0], [1, 0, 0]])
    return jnp.stack([starts, ends], axis=1), along


class CaptureState(eqx.Module):
    """Rocket state when the hooks engage (section IV: x, y, velocities, rotation vector, rates).

    Position/velocity are those of O, the centre of the plane through the four hook tips. Angles in
    degrees and rates in deg/s as the paper's tables give them; the rotation vector
    ``[theta_x, theta_y, theta_z]`` rotates oxyz onto the rocket frame OXYZ. Defaults: the design
    case of section II.B (centre, vertical, 20 m/s down).

    Bounds (checked on concrete values; :data:`CAPTURE_BOUNDS`), each far outside every state of the
    paper, the tests and the experiments, and each inside the range where the models hold:

    * ``|x|, |y|, |z| <= 1000 m``: 20x the 50 m truss of Table 1 (Table 3: |x|, |y| <= 13 m; the
      terminal-guidance height h <= 200 m, Table 4). The layout's own limit
      ``|x|, |y| < l_0 - l_1`` is checked where the layout is known (:func:`check_hooks_inside_frame`).
    * each velocity component ``|v| <= 100 m/s``: 5x the paper's 20 m/s design speed (section II.B;
      the hard-case test lands at 40 m/s) and under 2 % of the cables' axial wave speed
      ``sqrt(EA / rhoA) = 5.2 km/s``, so the rigid level's quasi-static massless cables stay valid.
      A faster capture is outside every model here: it would report a drop of kilometres as a
      successful solve (``--vz 1e9`` gave z_max = 2.4e8 m).
    * ``|theta_z| < 45 deg``: hook k must face cable k (module docstring); the inclination
      ``|(theta_x, theta_y)| < 60 deg`` (Table 8: 16 deg), beyond which the hooks' throats no longer
      face the capture plane.
    * each rate ``|omega| <= 360 deg/s`` (one turn per second): 60x Table 8's 6 deg/s.
    """

    x_m: jax.Array = eqx.field(converter=as_array, default=0.0)
    y_m: jax.Array = eqx.field(converter=as_array, default=0.0)
    z_m: jax.Array = eqx.field(converter=as_array, default=0.0)
    """Height of O [m]; scene builders set it so the engaged throats sit on the top plane."""
    vx_m_s: jax.Array = eqx.field(converter=as_array, default=0.0)
    vy_m_s: jax.Array = eqx.field(converter=as_array, default=0.0)
    vz_m_s: jax.Array = eqx.field(converter=as_array, default=-20.0)
    """Vertical velocity [m/s], z up: the design case descends at 20 m/s (vz = -20)."""
    theta_x_deg: jax.Array = eqx.field(converter=as_array, default=0.0)
    theta_y_deg: jax.Array = eqx.field(converter=as_array, default=0.0)
    theta_z_deg: jax.Array = eqx.field(converter=as_array, default=0.0)
    omega_x_deg_s: jax.Array = eqx.field(converter=as_array, default=0.0)
    omega_y_deg_s: jax.Array = eqx.field(converter=as_array, default=0.0)
    omega_z_deg_s: jax.Array = eqx.field(converter=as_array, default=0.0)

    def __check_init__(self):
        CaptureState.check_arguments(**{name: getattr(self, name) for name in self.__dataclass_fields__})

    @staticmethod
    def check_arguments(*, names=None, **values):
        """Check some fields' values by the class's bounds before building one, e.g. a scene
        builder's arguments that become a capture state:
        ``check_arguments(z_m=h, vz_m_s=-h / t_c, names=dict(z_m="height_m", ...))``; ``names``
        maps a field to the name its error gives (default: the field's)."""
        names = names or {}
        for name in values:
            if name not in CAPTURE_BOUNDS:
                raise ValueError(f"unknown CaptureState field {name!r}; choose one of {sorted(CAPTURE_BOUNDS)}")
        for name, value in values.items():
            CAPTURE_BOUNDS[name](names.get(name, name), value)
        if "theta_x_deg" in values and "theta_y_deg" in values:
            tilt = _concrete_norm(values["theta_x_deg"], values["theta_y_deg"])
            if tilt is not None and tilt >= 60.0:
                raise ValueError(
                    f"inclination |(theta_x_deg, theta_y_deg)| must be < 60 deg, got {tilt:g} deg "
                    f"(theta_x_deg={values['theta_x_deg']!r}, theta_y_deg={values['theta_y_deg']!r})"
                )

    @property
    def position(self):
        return jnp.stack([self.x_m, self.y_m, self.z_m])

    @property
    def velocity(self):
        return jnp.stack([self.vx_m_s, self.vy_m_s, self.vz_m_s])

    @property
    def rotation_vector(self):
        return jnp.deg2rad(jnp.stack([self.theta_x_deg, self.theta_y_deg, self.theta_z_deg]))

    @property
    def omega(self):
        return jnp.deg2rad(jnp.stack([self.omega_x_deg_s, self.omega_y_deg_s, self.omega_z_deg_s]))


_POSITION = abs_at_most(1000.0, " m", "20x the 50 m truss of Table 1")
_VELOCITY = abs_at_most(100.0, " m/s", "5x the 20 m/s design speed; far beyond it no model here holds")
_RATE = abs_at_most(360.0, " deg/s", "one turn per second, 60x Table 8's 6 deg/s")
CAPTURE_BOUNDS = {
    "x_m": _POSITION,
    "y_m": _POSITION,
    "z_m": _POSITION,
    "vx_m_s": _VELOCITY,
    "vy_m_s": _VELOCITY,
    "vz_m_s": _VELOCITY,
    "theta_x_deg": abs_at_most(60.0, " deg", "the inclination |(theta_x, theta_y)| must be < 60 deg"),
    "theta_y_deg": abs_at_most(60.0, " deg", "the inclination |(theta_x, theta_y)| must be < 60 deg"),
    "theta_z_deg": lambda name, v: check_range(name, v, -45.0, 45.0, unit=" deg", why="hook k must face cable k"),
    "omega_x_deg_s": _RATE,
    "omega_y_deg_s": _RATE,
    "omega_z_deg_s": _RATE,
}
"""The bound of each :class:`CaptureState` field, ``{field: check(name, value)}`` (reasons in the
class docstring)."""


def kink_return_times(layout: ArrestingLayout, ts, stress_pa, drop_m, round_trips=(1, 2)):
    """When a transverse kink launched by the hook at the middle of an arresting span at t = 0 is
    back at the hook [s], after each of ``round_trips`` trips to a slider pulley and back: the
    first time ``int_0^t c dt`` reaches ``2 k`` leg lengths, with the string's wave speed
    ``c = sqrt(T / rhoA)``, ``T = stress pi r^2`` (at least the pre-tension) and the leg
    ``hypot(l_0, drop)``. ``ts`` [s], ``stress_pa`` [Pa] and ``drop_m`` [m] are histories (NumPy),
    e.g. a rigid-level landing's quasi-static ones: an estimate that owes nothing to the ALE cables
    (``docs/arresting_validation.md``, "The centred capture above the rigid level"). NaN where the
    histories end first."""
    ts, stress_pa, drop_m = (np.asarray(x, dtype=float) for x in (ts, stress_pa, drop_m))
    tension = np.maximum(stress_pa * np.pi * float(layout.cable_radius_m) ** 2, float(layout.pretension_N))
    c = np.sqrt(tension / float(layout.rhoA_kg_per_m))
    travelled = np.concatenate([[0.0], np.cumsum(0.5 * (c[1:] + c[:-1]) * np.diff(ts))])
    leg = np.hypot(float(layout.half_span_m), drop_m)
    out = []
    for k in round_trips:
        hit = np.nonzero(travelled >= 2.0 * k * leg)[0]
        out.append(float(ts[hit[0]]) if hit.size else float("nan"))
    return out


def _is_concrete(value):
    return not isinstance(value, jax.core.Tracer)


def _check_less(name, value, other_name, other, why, or_equal=False):
    """``value < other`` (``or_equal``: ``<=``) where both are concrete."""
    if other is None or not (_is_concrete(value) and _is_concrete(other)):
        return
    v, o = np.asarray(value, float), np.asarray(other, float)
    bad = v > o if or_equal else v >= o
    if np.any(bad):
        rel = "<=" if or_equal else "<"
        raise ValueError(f"{name} must be {rel} {other_name} = {_fmt(o)} ({why}), got {_fmt(v)}")


def _fmt(a):
    a = np.asarray(a)
    return f"{float(a):g}" if a.shape == () else repr(a)


def _concrete_norm(a, b):
    if isinstance(a, jax.core.Tracer) or isinstance(b, jax.core.Tracer):
        return None
    return float(np.max(np.hypot(np.asarray(a, float), np.asarray(b, float))))


def check_hooks_inside_frame(layout: ArrestingLayout, capture: CaptureState):
    """A capture must put the rocket inside the truss: |x|, |y| < l_0 - l_1 (clear error otherwise)."""
    lim = layout.half_span_m - layout.frame_half_width_m
    for name in ("x_m", "y_m"):
        v = getattr(capture, name)
        if isinstance(v, jax.core.Tracer) or isinstance(lim, jax.core.Tracer):
            continue
        if np.any(np.abs(np.asarray(v, float)) >= np.asarray(lim, float)):
            raise ValueError(
                f"capture {name} = {_fmt(v)} m puts the hooks outside the capture frame's travel: "
                f"|{name}| must be < l_0 - l_1 = {_fmt(lim)} m"
            )
