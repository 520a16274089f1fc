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

from jaxcable.core.validation import check_finite, check_positive, check_range

__all__ = ["ArrestingLayout", "CaptureState", "HOOK_OF_CABLE", "span_endpoints"]

HOOK_OF_CABLE = (0, 2, 1, 3)
"""Index of the hook that engages cable k (cables: east, west, north, south)."""


class ArrestingLayout(eqx.Module):
    """Arresting-cable geometry and cable properties (Table 1 defaults). Arrays, sweepable."""

    half_span_m: jax.Array = eqx.field(converter=jnp.asarray, default=25.0)
    """``l_0``: half the truss side [m] (Table 1: 2 l_0 = 50 m)."""
    frame_half_width_m: jax.Array = eqx.field(converter=jnp.asarray, default=3.5)
    """``l_1``: half the capture-frame side [m] (Table 1: 2 l_1 = 7 m)."""
    tower_height_m: jax.Array = eqx.field(converter=jnp.asarray, default=30.0)
    """``H``: height of the top plane above the ground pulleys [m] (Table 1: H >= 30 m)."""
    block_strand_m: jax.Array = eqx.field(converter=jnp.asarray, default=10.0)
    """``D``: initial length of each strand from the ground pulley to the moving block [m] (ours)."""
    cable_radius_m: jax.Array = eqx.field(converter=jnp.asarray, default=0.02)
    """Arresting cable radius [m] (section II.B: 20 mm); stress = tension / (pi r^2)."""
    EA_N: jax.Array = eqx.field(converter=jnp.asarray, default=2.64e8)
    """Cable axial stiffness [N] (Table 1)."""
    rhoA_kg_per_m: jax.Array = eqx.field(converter=jnp.asarray, default=9.8)
    """Cable mass per unit length [kg/m] (Table 1)."""
    pretension_N: jax.Array = eqx.field(converter=jnp.asarray, default=5.0e4)
    """Cable pre-tension at capture [N] (section II.A: "pre-tensioned"; value not given: ours)."""

    def __check_init__(self):
        for name in (
            "half_span_m",
            "frame_half_width_m",
            "tower_height_m",
            "block_strand_m",
            "cable_radius_m",
            "EA_N",
            "rhoA_kg_per_m",
        ):
            check_positive(name, getattr(self, name))
        check_positive("pretension_N", self.pretension_N, allow_zero=True)

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
    """

    x_m: jax.Array = eqx.field(converter=jnp.asarray, default=0.0)
    y_m: jax.Array = eqx.field(converter=jnp.asarray, default=0.0)
    z_m: jax.Array = eqx.field(converter=jnp.asarray, default=0.0)
    """Height of O [m]; scene builders set it so the engaged throats sit on the top plane."""
    vx_m_s: jax.Array = eqx.field(converter=jnp.asarray, default=0.0)
    vy_m_s: jax.Array = eqx.field(converter=jnp.asarray, default=0.0)
    vz_m_s: jax.Array = eqx.field(converter=jnp.asarray, default=-20.0)
    """Vertical velocity [m/s], z up: the design case descends at 20 m/s (vz = -20)."""
    theta_x_deg: jax.Array = eqx.field(converter=jnp.asarray, default=0.0)
    theta_y_deg: jax.Array = eqx.field(converter=jnp.asarray, default=0.0)
    theta_z_deg: jax.Array = eqx.field(converter=jnp.asarray, default=0.0)
    omega_x_deg_s: jax.Array = eqx.field(converter=jnp.asarray, default=0.0)
    omega_y_deg_s: jax.Array = eqx.field(converter=jnp.asarray, default=0.0)
    omega_z_deg_s: jax.Array = eqx.field(converter=jnp.asarray, default=0.0)

    def __check_init__(self):
        for name in self.__dataclass_fields__:
            check_finite(name, getattr(self, name))
        check_range("theta_z_deg", self.theta_z_deg, -45.0, 45.0, unit=" deg (hook k must face cable k)")
        tilt = _concrete_norm(self.theta_x_deg, self.theta_y_deg)
        if tilt is not None and tilt >= 60.0:
            raise ValueError(f"inclination |(theta_x, theta_y)| = {tilt:g} deg: must be < 60 deg")

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
        if abs(float(v)) >= float(lim):
            raise ValueError(
                f"capture {name} = {float(v):g} m puts the hooks outside the capture frame's travel: "
                f"|{name}| must be < l_0 - l_1 = {float(lim):g} m"
            )
