"""The line-throwing rocket scene (Lu et al., Mechanika 22(6) 2016): a rocket pulls a rope out of a
box at the launch point; gravity, thrust, drag, pull-out force, ground.

Build it with :func:`line_throwing_scene` (the calibrated defaults) and run it with
:func:`jaxcable.core.simulate`. The scene's components are ``rocket`` (:class:`PointRocket`), ``rope``
(:class:`SegmentRope`), ``launch`` (:class:`Launch`) and ``forces`` (a tuple of force components);
leave a force out to model less.

Calibrated defaults (see ``experiments/calibrate_throw.py`` and ``docs/throw.md``, "Calibration"):
the paper gives no drag coefficients, rope diameter or pull-out force; three scalars were fitted to
the 30 deg flight test (Table 3 test row and the radar speeds at 1-4 s). ``CALIBRATION`` records them.
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from jaxcable.core.validation import check_bool, check_choice, check_instance, check_int, check_positive, check_range
from jaxcable.throw.rocket import PointRocket, paper_rocket
from jaxcable.throw.forces import AeroDrag, Gravity, Ground, Thrust, make_pullout
from jaxcable.components.rope import (
    ChainState,
    SegmentRope,
    kinematics,
    default_windows,
    kinetic_energy,
    launch_theta,
    make_rope,
    on_window,
    rope_vector_field,
    window_sizes,
)
from jaxcable.core.scene import AbstractScene

# Fitted to the 30 deg flight test by experiments/calibrate_throw.py (see docs/throw.md, "Calibration").
CALIBRATION = {
    "rocket_drag_coefficient": 0.2709,
    "rope_drag_coefficient": 0.02332,
    "rope_linear_density_kg_per_m": 0.06928,
    "pullout": "momentum_flux",
    "rope_diameter_m": 0.01,
    "note": (
        "optax Adam, 30 steps in log space, 2 m segments, tsit5 rtol 1e-5; residuals at 1 m: range -1.6%, "
        "v_max +5.2%, flight time +6.7%, v(1..4 s) -5.1/-1.6/+0.5/+1.1% (experiments/results/calibration.json). "
        "The printed 0.43 kg/m cannot reach the measured speeds (docs/throw.md, Physical sanity)."
    ),
}


THROW_STEP_CONTROL = (0.4, 0.3)
"""``(pcoeff, icoeff)`` of the PID step-size controller that ``jaxcable throw`` passes to
:func:`~jaxcable.core.simulate` (the PI controller; ``simulate``'s own default is diffrax's I
controller, ``(0, 1)``). Each segment completion releases a hinge over the last 5% of the segment's
growth; the I controller grows the step past it and rejects (580 of 1,659 attempts at 1 m segments,
Tsit5, rtol 1e-4), the PI controller grows it more cautiously (192 of 1,365) at the same error
(range, max speed and flight time within 4.5e-5 against 3.8e-5 of Tsit5 at 1e-8) in 0.84x the time
(``experiments/rope_step_limits.py``, part c)."""

MAX_FLIGHT_S = 600.0
"""Longest flight simulated with the default saved grid [s] (10 ms samples): the 4770 N s motor
gives the 20 kg rocket at most ~240 m/s, so even a vertical flight in vacuum lands within a minute
(the command line's default is 40 s)."""


class Launch(eqx.Module):
    """Launch geometry.

    Attributes:
        angle_rad: launch elevation above the horizontal [rad], in (0, pi/2).
        rail_length_m: distance from the rope box to the rocket at t = 0 [m]; the rope between them
            lies along the launch direction (it is the initial deployed length).
    """

    angle_rad: Float[Array, ""]
    rail_length_m: Float[Array, ""]

    def __check_init__(self):
        check_range("launch.angle_rad", self.angle_rad, 0.0, np.pi / 2, unit=" rad")
        check_positive("launch.rail_length_m", self.rail_length_m)

    @property
    def direction(self):
        return jnp.stack([jnp.cos(self.angle_rad), jnp.sin(self.angle_rad)])


class ThrowProbe(eqx.Module):
    """Time histories saved on the output grid (SI units)."""

    position: Array  # rocket (x, y) [m]
    velocity: Array  # rocket (vx, vy) [m/s]
    speed: Array  # [m/s]
    acceleration: Array  # rocket acceleration along its axis (the velocity once flying) [m/s^2]
    rope_pull: Array  # force of the rope on the rocket [N]
    deployed: Array  # deployed rope length [m]
    kinetic_energy: Array  # [J]


@eqx.filter_jit
def _windowed_field(scene, t, state):
    # One trace per scene structure: diffrax traces the vector field at several places, each of
    # which would otherwise trace every window's branch again.
    return scene._field(t, state, scene.windows)


@eqx.filter_jit
def _probe_terms(scene, t, state):
    """The probe's rocket acceleration [m/s^2], force on the rocket [N] and kinetic energy [J].

    Computed on the largest of the scene's windows while the rope fits in it, else on the whole box
    (:func:`~jaxcable.components.rope.on_window`). The probe runs once per saved sample (about 900
    in a 30 deg flight), and on every link of the box those samples took 0.11 s of a 0.51 s flight
    at 1 m segments (2-core Intel Xeon, JAX 0.10.2 CPU, float64). One window, not all of them:
    diffrax places the saving function at several places of the program, each a copy of the
    branches to compile; with every window the first call took 14.6-14.9 s against 11.4-12.3 s,
    with the largest alone 11.9 s, and the run the same (0.46-0.47 s against 0.60-0.67 s on every
    link; interleaved processes, docs/throw.md "Cost of a flight"). What the saved samples cost
    now: ``python experiments/rope_step_limits.py --parts f``. The forces on the rocket repeat
    the vector field's own computation, which XLA merges (the compiled probe has the field's
    count of ``tanh``)."""
    mass, theta_launch = scene.rocket.mass(t), launch_theta(scene.launch.angle_rad)

    def terms(sub, rope):
        force_fn = lambda kin: scene.node_forces(t, kin)
        deriv, kin = rope_vector_field(sub, rope, mass, theta_launch, force_fn, scene.release_fraction)
        return deriv.v0, force_fn(kin)[0], kinetic_energy(kin)

    # the largest window and the whole box (window_sizes sorts them and ends with the box)
    return on_window(state, scene.rope, window_sizes(scene.rope.capacity, scene.windows)[-2:], terms)


def _as_tuple(value):
    # a list is hashable as a tuple (the field is static); anything else is left for __check_init__
    return tuple(value) if isinstance(value, list) else value


class LineThrowingScene(AbstractScene):
    """Rocket + finite-segment rope + forces. See the module docstring.

    ``window_links``: the box holds ``rope.capacity`` links, but while the deployed rope fits in the
    first ``N`` of them the vector field is computed on those only (the links still in the box have
    no length and no mass and follow the last free link; :func:`~jaxcable.components.rope.rope_vector_field`
    with ``windows``). ``None`` (the default) takes the powers of two from 64 below the capacity
    for a box of at least 256 links (``MIN_WINDOWED_CAPACITY``); ``()`` computes every link at
    every evaluation. The results agree to rounding; the windows
    cost compile time (one branch each) and save run time
    (``python experiments/rope_step_limits.py --parts d``, docs/throw.md "Cost of a flight").
    """

    rocket: PointRocket
    rope: SegmentRope
    launch: Launch
    forces: tuple
    save_dt_s: float = eqx.field(static=True, default=0.01)
    release_fraction: float = eqx.field(static=True, default=0.05)
    window_links: tuple | None = eqx.field(static=True, default=None, converter=_as_tuple)

    def __check_init__(self):
        check_instance("window_links", self.window_links, tuple, allow_none=True)
        for i, size in enumerate(self.window_links or ()):
            check_int(f"window_links[{i}]", size, low=1)

    @property
    def windows(self) -> tuple:
        """Prefix sizes (links) the vector field is evaluated on while the deployed rope fits:
        ``window_links``, or by default :func:`~jaxcable.components.rope.default_windows` of the
        box (``()``: every link of the box at every evaluation)."""
        return default_windows(self.rope.capacity) if self.window_links is None else self.window_links

    # --- state ---
    def initial_state(self) -> ChainState:
        n = self.rope.capacity
        theta0 = launch_theta(self.launch.angle_rad)
        zero = jnp.zeros((), dtype=self.launch.angle_rad.dtype)
        return ChainState(
            r0=self.launch.rail_length_m * self.launch.direction,
            v0=jnp.zeros(2) + zero,
            theta=jnp.full((n,), theta0),
            omega=jnp.zeros(n) + zero,
            deployed=self.launch.rail_length_m + zero,
        )

    def kinematics(self, t, state):
        return kinematics(state, self.rope, self.rocket.mass(t), launch_theta(self.launch.angle_rad))

    def node_forces(self, t, kin):
        total = jnp.zeros_like(kin.velocities)
        for f in self.forces:
            total = total + f.node_forces(t, kin, self)
        return total

    def vector_field(self, t, state: ChainState) -> ChainState:
        return _windowed_field(self, jnp.asarray(t), state)  # t as an array: a float would be static

    def _field(self, t, state, windows):
        deriv, _ = rope_vector_field(
            state,
            self.rope,
            self.rocket.mass(t),
            launch_theta(self.launch.angle_rad),
            lambda kin: self.node_forces(t, kin),
            self.release_fraction,
            windows=windows,
        )
        return deriv

    # --- diffrax hooks ---
    @property
    def has_terminal_event(self) -> bool:
        return True

    def terminal_event(self, t, state):
        # Rocket height: the flight ends at ground impact (it starts above ground on the rail).
        return state.r0[1]

    def jump_times(self):
        return jnp.reshape(self.rocket.burn_time_s, (1,))

    def default_save_ts(self, t1):
        check_range("t1", t1, 0.0, MAX_FLIGHT_S, high_inclusive=True, unit=" s",
                    why="the rocket lands within a minute at any launch angle")  # fmt: skip
        grid = jnp.arange(0.0, t1, self.save_dt_s)
        extra = jnp.minimum(jnp.stack([self.rocket.burn_time_s, 1.0, 2.0, 3.0, 4.0]), t1)
        return jnp.sort(jnp.concatenate([grid, extra]))

    def default_snapshot_ts(self, t1):
        # clipped to t1 (diffrax needs saved times inside [t0, t1]); repeated t1 entries are harmless
        return jnp.minimum(jnp.array([0.5, 1.0, 2.0, 3.0, 4.0, 6.0, 8.0]), t1)

    def probe(self, t, state):
        # The acceleration is the integrated one (vector_field, with the weld-release blend), so the
        # saved history is the derivative of the saved velocity; the forces give the rope's pull.
        a0, F0, energy = _probe_terms(self, jnp.asarray(t), state)
        v = state.v0
        speed = jnp.sqrt(jnp.sum(v**2) + 1e-300)
        axis = self.rocket.axis(v, self.launch.direction)
        pull = self.rocket.mass(t) * a0 - F0
        return ThrowProbe(
            position=state.r0,
            velocity=v,
            speed=speed,
            acceleration=jnp.dot(a0, axis),
            rope_pull=jnp.sqrt(jnp.sum(pull**2) + 1e-300),
            deployed=state.deployed,
            kinetic_energy=energy,
        )

    def snapshot(self, t, state):
        return self.kinematics(t, state).positions

    def summarize(self, result):
        p = result.probes
        valid = result.ts <= result.t_final
        speed = jnp.where(valid, p.speed, -jnp.inf)

        def speed_at(tq):
            i = jnp.argmin(jnp.abs(result.ts - tq))
            return jnp.where(tq <= result.t_final, p.speed[i], jnp.nan)

        fs = result.final_state
        seg = self.rope.segment_length_m
        return {
            "range_m": fs.r0[0],
            "flight_time_s": result.t_final,
            "max_speed_mps": jnp.max(speed),
            "impact_speed_mps": jnp.sqrt(jnp.sum(fs.v0**2)),
            "max_height_m": jnp.max(jnp.where(valid, p.position[:, 1], -jnp.inf)),
            "speed_at_1_2_3_4_s_mps": jnp.stack([speed_at(1.0), speed_at(2.0), speed_at(3.0), speed_at(4.0)]),
            "deployed_rope_m": fs.deployed,
            "n_segments": jnp.ceil(fs.deployed / seg - 1e-9).astype(jnp.int32),
        }


def line_throwing_scene(
    angle_deg: float = 30.0,
    segment_length_m: float = 1.0,
    rope_length_m: float = 750.0,
    *,
    rocket_drag_coefficient=None,
    rope_drag_coefficient=None,
    rope_linear_density_kg_per_m=None,
    rope_diameter_m=None,
    pullout: str | None = None,
    pullout_force_N: float = 0.0,
    drag_form: str = "standard",
    rail_length_m: float = 1.0,
    gravity_mps2: float = 9.81,
    air_density_kgpm3: float = 1.225,
    ground: bool = True,
    drag: bool = True,
    window_links: tuple | None = None,
) -> LineThrowingScene:
    """The paper's line-throwing rocket with the calibrated defaults (``CALIBRATION``).

    Args:
        angle_deg: launch elevation [deg], in (0, 90).
        segment_length_m: rope segment length [m] (1 m in the paper).
        rope_length_m: rope in the box [m] (rounded up to whole segments; sets the array sizes).
        rocket_drag_coefficient, rope_drag_coefficient, rope_linear_density_kg_per_m,
        rope_diameter_m: override the calibrated values.
        pullout: "none", "constant" or "momentum_flux" (default: calibrated choice).
        pullout_force_N: constant box resistance [N] for "constant" / added to "momentum_flux".
        drag_form: "standard" (default, along the relative velocity) or "per_axis" (the paper's eqs 13-14).
        rail_length_m: initial rocket distance from the box along the launch direction [m].
        ground: include the ground under the rope; drag: include aerodynamic drag.
        window_links: the link counts the vector field is evaluated on while the deployed rope fits
            (``LineThrowingScene.window_links``): None for the default windows, ``()`` for every
            link of the box at every evaluation.
    """
    check_range("angle_deg", angle_deg, 0.0, 90.0, unit=" deg")
    check_choice("drag form", drag_form, ("standard", "per_axis"))
    # physical ranges, each far outside the paper's values and the calibration (CALIBRATION)
    check_positive("rope_length_m", rope_length_m)
    check_range("rope_length_m", rope_length_m, 0.0, 5000.0, high_inclusive=True, unit=" m",
                why="6x the paper's 800 m box")  # fmt: skip
    check_positive("segment_length_m", segment_length_m)
    check_range("segment_length_m", segment_length_m, 0.1, 5000.0, inclusive=True, unit=" m",
                why="at least 10 rope diameters")  # fmt: skip
    if float(segment_length_m) > float(rope_length_m):
        raise ValueError(
            f"segment_length_m must be at most rope_length_m = {float(rope_length_m):g} m, got {segment_length_m!r}"
        )
    for name, value, high, unit in (
        ("rocket_drag_coefficient", rocket_drag_coefficient, 10.0, ""),
        ("rope_drag_coefficient", rope_drag_coefficient, 10.0, ""),
        ("rope_linear_density_kg_per_m", rope_linear_density_kg_per_m, 10.0, " kg/m"),
        ("rope_diameter_m", rope_diameter_m, 0.5, " m"),
    ):
        if value is not None:
            check_positive(name, value, allow_zero="drag" in name)
            check_range(name, value, 0.0, high, inclusive=True, unit=unit)
    check_positive("pullout_force_N", pullout_force_N, allow_zero=True)
    check_range("pullout_force_N", pullout_force_N, 0.0, 1e5, inclusive=True, unit=" N",
                why="the motor's thrust is 11 kN")  # fmt: skip
    check_positive("rail_length_m", rail_length_m)
    check_range("rail_length_m", rail_length_m, 0.0, float(rope_length_m), unit=" m",
                why="the rail's rope is part of the rope")  # fmt: skip
    check_range("gravity_mps2", gravity_mps2, 0.0, 100.0, inclusive=True, unit=" m/s^2")
    check_range("air_density_kgpm3", air_density_kgpm3, 0.0, 10.0, inclusive=True, unit=" kg/m^3")
    check_bool("ground", ground)
    check_bool("drag", drag)
    cal = CALIBRATION
    pick = lambda v, key: cal[key] if v is None else v
    rope = make_rope(
        segment_length_m=segment_length_m,
        rope_length_m=rope_length_m,
        linear_density_kg_per_m=pick(rope_linear_density_kg_per_m, "rope_linear_density_kg_per_m"),
        diameter_m=pick(rope_diameter_m, "rope_diameter_m"),
        drag_coefficient=pick(rope_drag_coefficient, "rope_drag_coefficient"),
    )
    rocket = paper_rocket(drag_coefficient=pick(rocket_drag_coefficient, "rocket_drag_coefficient"))
    launch = Launch(
        angle_rad=jnp.asarray(np.deg2rad(angle_deg), dtype=float),
        rail_length_m=jnp.asarray(rail_length_m, dtype=float),
    )
    forces = [Gravity(g_mps2=gravity_mps2), Thrust()]
    if drag:
        forces.append(AeroDrag(air_density_kgpm3=air_density_kgpm3, form=drag_form))
    forces.append(make_pullout(pick(pullout, "pullout"), pullout_force_N))
    if ground:
        forces.append(Ground())
    return LineThrowingScene(rocket=rocket, rope=rope, launch=launch, forces=tuple(forces), window_links=window_links)


def with_angle(scene: LineThrowingScene, angle_rad) -> LineThrowingScene:
    """The same scene at another launch angle [rad] (works under vmap/grad)."""
    return eqx.tree_at(lambda s: s.launch.angle_rad, scene, jnp.asarray(angle_rad, dtype=float))


def report(outputs: dict, status: str) -> dict:
    """Plain-Python, JSON-ready dict of a single run's outputs."""
    out = {}
    for key, val in outputs.items():
        arr = np.asarray(val)
        out[key] = arr.tolist() if arr.ndim else (int(arr) if arr.dtype.kind in "iu" else float(arr))
    out["solver_status"] = status
    return out
