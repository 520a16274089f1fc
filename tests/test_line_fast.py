"""The Lagrangian line (:mod:`jaxcable.components.lagrangian_line`) and the unrolled explicit
solvers (:mod:`jaxcable.core.explicit_rk`): cross-model agreement with the ALE cable, statics
against Irvine's elastic catenary, energy conservation, vmap against single runs, gradients against
central differences. The case is the peer case of ``experiments/peers/moordyn_line.py`` (a line of
L0 = 10.5 m pinned at two level points 10 m apart, EA = 1e6 N, 1 kg/m, beta = 1e-3 s), on 10
elements and short horizons so the file runs in seconds."""

import importlib.util
from pathlib import Path

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxcable
from jaxcable.components.ale import (
    AleCable,
    AleState,
    ale_cable_vector_field,
    cable_energy,
)
from jaxcable.components.lagrangian_line import (
    LagrangianLine,
    LineScene,
    LineState,
    line_energy,
    line_vector_field,
    segment_tensions,
    static_equilibrium,
    tension_factor,
    uniform_line_mesh,
)
from jaxcable.core.explicit_rk import RK4, FastTsit5

EA, RHOA, BETA, L0, SPAN, G = 1e6, 1.0, 1e-3, 10.5, 10.0, 9.81
GRAVITY = jnp.array([0.0, 0.0, -G])
SEGMENTS = 10


def _irvine():
    path = Path(__file__).resolve().parents[1] / "experiments" / "peers" / "_jaxcable_statics.py"
    spec = importlib.util.spec_from_file_location("peers_jaxcable_statics", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.irvine


def _pins(n):
    return jnp.zeros(n, bool).at[0].set(True).at[-1].set(True)


def _sagging_guess(n, stretch=1.03):
    """A start for Newton with every element in tension: the inextensible catenary of a 3% longer
    line, sampled at the stretched arc lengths of the nodes."""
    from scipy.optimize import brentq

    length = stretch * L0
    a = brentq(lambda a: 2 * a * np.arcsinh(length / (2 * a)) - SPAN, 0.1, 1e4)
    arc = np.linspace(0.0, length, n) - length / 2
    x = a * np.arcsinh(arc / a) + SPAN / 2
    z = np.sqrt(a**2 + arc**2) - np.sqrt(a**2 + (length / 2) ** 2)
    return jnp.asarray(np.stack([x, np.zeros(n), z], axis=1))


@pytest.fixture(scope="module")
def hanging():
    """The static shape of the 10-element line (lumped and consistent share it: same static load)."""
    n = SEGMENTS + 1
    line = LagrangianLine(EA_N=EA, rhoA_kg_per_m=RHOA, damping_s=BETA)
    mesh = uniform_line_mesh(L0, SEGMENTS, _pins(n), "lumped")
    return static_equilibrium(line, mesh, _sagging_guess(n), GRAVITY)


def _pull_scene(r0, speed=0.5, mass="lumped", line=None):
    n = r0.shape[0]
    line = LagrangianLine(EA_N=EA, rhoA_kg_per_m=RHOA, damping_s=BETA) if line is None else line
    v0 = jnp.zeros((n, 3)).at[-1, 0].set(speed)
    return LineScene(line=line, mesh=uniform_line_mesh(L0, n - 1, _pins(n), mass), r0=r0, v0=v0)


def test_consistent_mass_is_the_ale_cable_with_material_coordinates_fixed(hanging):
    # Same element (Green strain, softplus switch, consistent mass): the vector fields agree to
    # round-off on an arbitrary moving state, with a node pinned in one component only.
    n = SEGMENTS + 1
    rng = np.random.default_rng(0)
    r = hanging + 0.05 * jnp.asarray(rng.normal(size=(n, 3)))
    v = jnp.asarray(rng.normal(size=(n, 3)))
    fixed = jnp.zeros((n, 3), bool).at[0].set(True).at[-1].set(True).at[4, 2].set(True)
    line = LagrangianLine(EA_N=EA, rhoA_kg_per_m=RHOA, damping_s=BETA)
    mesh = uniform_line_mesh(L0, SEGMENTS, fixed, "consistent")
    fast = jax.jit(line_vector_field)(line, mesh, LineState(r=r, v=v), GRAVITY)
    ale = jax.jit(ale_cable_vector_field)(
        AleCable(EA_N=EA, rhoA_kg_per_m=RHOA, damping_s=BETA),
        AleState(r=r, s=jnp.linspace(0.0, L0, n), v=v, sdot=jnp.zeros(n)),
        fixed,
        jnp.ones(n, bool),
        GRAVITY,
    )
    scale = float(jnp.max(jnp.abs(ale.v)))
    np.testing.assert_allclose(fast.v, ale.v, rtol=0, atol=1e-11 * scale)
    np.testing.assert_array_equal(fast.r, v)
    assert float(jnp.max(jnp.abs(fast.v[4, 2]))) == 0.0
    # and the same energies (kinetic with the consistent mass matrix)
    ale_cable = AleCable(EA_N=EA, rhoA_kg_per_m=RHOA, damping_s=BETA)
    ale_state = AleState(r=r, s=jnp.linspace(0.0, L0, n), v=v, sdot=jnp.zeros(n))
    energies = jax.jit(lambda: (line_energy(line, mesh, LineState(r=r, v=v), GRAVITY), cable_energy(ale_cable, ale_state, GRAVITY)))()
    np.testing.assert_allclose(energies[0], energies[1], rtol=1e-12)


@eqx.filter_jit
def _pull_history(scene, t1, dt, ts):
    """Positions and end-element tensions of a :class:`LineScene` on ``ts`` (RK4 at ``dt``)."""
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(lambda t, y, args: scene.vector_field(t, y)), RK4(), 0.0, t1, dt, scene.initial_state(),
        saveat=diffrax.SaveAt(ts=ts), stepsize_controller=diffrax.ConstantStepSize(), max_steps=None,
    )  # fmt: skip
    tension = jax.vmap(lambda r, v: segment_tensions(scene.line, scene.mesh, LineState(r=r, v=v)))(sol.ys.r, sol.ys.v)
    return sol.ys, tension


def test_lumped_mass_against_the_consistent_mass_in_the_pull(hanging):
    # Lumped against consistent mass (= the ALE cable, previous test) on the pull (0.1 s, right end
    # at 0.5 m/s, RK4 at 1e-4 s: integration error ~1e-9 m): a discretisation difference, not an
    # error. Measured (10 elements): the middle node's paths differ by 2.2e-3 m of its 0.057 m
    # travel (the axial wave launched by the pull travels at different speeds on the two meshes:
    # the lumped mesh's highest mode is sqrt(3) slower), the end tensions by 4.7% of their peak,
    # their time means by 0.9%. (On 20 elements over 1 s, experiments/peers/moordyn_line.py
    # measures the same kind of difference.) Bounds: 1.5x the measured differences.
    ts = jnp.linspace(0.0, 0.1, 51)
    out = {}
    for mass in ("lumped", "consistent"):
        states, tension = _pull_history(_pull_scene(hanging, mass=mass), 0.1, 1e-4, ts)
        out[mass] = (states.r[:, SEGMENTS // 2], tension[:, -1])
    mid_diff = float(jnp.max(jnp.linalg.norm(out["lumped"][0] - out["consistent"][0], axis=-1)))
    travel = float(jnp.max(jnp.linalg.norm(out["consistent"][0] - out["consistent"][0][0], axis=-1)))
    peak = float(jnp.max(out["consistent"][1]))
    tension_diff = float(jnp.max(jnp.abs(out["lumped"][1] - out["consistent"][1]))) / peak
    means = [float(jnp.mean(out[m][1])) for m in ("lumped", "consistent")]
    assert 0.05 < travel < 0.065, travel
    assert 1e-4 < mid_diff < 1.5 * 2.2e-3, mid_diff
    assert tension_diff < 1.5 * 4.7e-2, tension_diff
    assert means[0] == pytest.approx(means[1], rel=1.5 * 9e-3)


def test_statics_match_irvines_elastic_catenary(hanging):
    # Both mass models carry half an element's weight per node, so the discrete statics is the
    # hanging chain's: O(h^2) from the continuum. Measured relative errors (Green strain, Newton
    # residual < 1e-9 of the weight): sag +4.9e-3 at 10 elements, +1.23e-3 at 20 (h^2);
    # horizontal tension -4.3e-3 at 10. Bounds: the 10-element values + 20%.
    irvine = _irvine()
    sag_ref, H_ref = irvine(EA, RHOA * G, L0, SPAN)
    n = SEGMENTS + 1
    sag = -float(hanging[n // 2, 2])
    assert sag == pytest.approx(sag_ref, rel=6e-3)
    line = LagrangianLine(EA_N=EA, rhoA_kg_per_m=RHOA)
    mesh = uniform_line_mesh(L0, SEGMENTS, _pins(n), "lumped")
    T = segment_tensions(line, mesh, LineState(r=hanging, v=jnp.zeros_like(hanging)))
    tangent = (hanging[1] - hanging[0]) / (L0 / SEGMENTS)
    H = float(T[0] * tangent[0] / jnp.linalg.norm(tangent))
    assert H == pytest.approx(H_ref, rel=6e-3)
    assert sag > sag_ref  # the hanging chain's nodes sag deeper than the continuum


def test_undamped_line_conserves_energy(hanging, mass="lumped", switch="quadratic"):
    # Pinned at both ends, undamped, released from its static shape with a transverse kick, 0.02 s.
    # The tension law derives from an energy, so the sum is conserved up to RK4's error: measured
    # drift < 1e-10 of the kinetic energy given, at dt = 5e-5 s.
    n = SEGMENTS + 1
    line = LagrangianLine(EA_N=EA, rhoA_kg_per_m=RHOA, damping_s=0.0, switch=switch)
    kick = jnp.zeros((n, 3)).at[1:-1, 1].set(jnp.sin(jnp.pi * jnp.arange(1, n - 1) / SEGMENTS))
    scene = LineScene(line=line, mesh=uniform_line_mesh(L0, SEGMENTS, _pins(n), mass), r0=hanging, v0=kick)
    res = jaxcable.simulate(scene, 0.02, solver="rk4", dt0=5e-5, save_ts=jnp.linspace(0.0, 0.02, 6), max_steps=500)
    assert res.ok and int(res.num_steps) == 400
    states = res.probes
    energy = jax.vmap(lambda r, v: sum(line_energy(line, scene.mesh, LineState(r=r, v=v), GRAVITY)))(states.r, states.v)
    kinetic0 = float(line_energy(line, scene.mesh, scene.initial_state(), GRAVITY)[0])
    assert float(jnp.max(jnp.abs(energy - energy[0]))) < 1e-8 * kinetic0


def test_tension_laws():
    # One straight element stretched by 1%: Green force EA eps |t|, engineering EA (|t| - 1); the
    # switches are the derivatives of their energies (energy-consistent), and 0 in compression.
    mesh = uniform_line_mesh(1.0, 1, jnp.array([True, False]), "lumped")
    from jaxcable.components.lagrangian_line import _strain_energy_factor

    state = LineState(r=jnp.array([[0.0, 0.0, 0.0], [1.01, 0.0, 0.0]]), v=jnp.zeros((2, 3)))
    green = segment_tensions(LagrangianLine(EA_N=EA), mesh, state)[0]
    eng = segment_tensions(LagrangianLine(EA_N=EA, strain="engineering"), mesh, state)[0]
    assert float(green) == pytest.approx(EA * 0.5 * (1.01**2 - 1) * 1.01, rel=1e-12)
    assert float(eng) == pytest.approx(EA * 0.01, rel=1e-9)
    for switch in ("softplus", "quadratic"):
        line = LagrangianLine(switch=switch, slack_width=1e-3)
        x = jnp.linspace(-1e-2, 1e-2, 41)
        derivative, T = jax.jit(
            lambda x, line=line: (jax.vmap(jax.grad(lambda e: _strain_energy_factor(line, e)))(x), tension_factor(line, x))
        )(x)
        np.testing.assert_allclose(derivative, T, atol=1e-15)
        assert float(T[0]) == pytest.approx(0.0, abs=1e-9)  # -10 w: slack
        assert float(T[-1]) == pytest.approx(1e-2, rel=1e-4)  # +10 w: taut


@jax.jit
def _end_tension(params, hanging):
    """Tension of the element at the pulled end at 0.02 s [N] (the pull's axial wave has reached
    it) for ``params = (pull speed [m/s], EA [N])``, RK4 at 1e-4 s (forward-mode adjoint: the
    derivatives below are taken with ``jax.jacfwd``)."""
    speed, EA_N = params[0], params[1]
    line = LagrangianLine(EA_N=EA_N, rhoA_kg_per_m=RHOA, damping_s=BETA)
    scene = _pull_scene(hanging, speed=speed, line=line)
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(lambda t, y, args: scene.vector_field(t, y)), RK4(), 0.0, 0.02, 1e-4, scene.initial_state(),
        stepsize_controller=diffrax.ConstantStepSize(), adjoint=diffrax.ForwardMode(), max_steps=None,
    )  # fmt: skip
    final = jax.tree_util.tree_map(lambda x: x[-1], sol.ys)
    return segment_tensions(line, scene.mesh, final)[-1]


def test_vmap_equals_single_runs(hanging):
    params = jnp.array([[0.3, EA], [0.4, EA], [0.5, 1.2 * EA]])
    batch = jax.jit(jax.vmap(_end_tension, in_axes=(0, None)))(params, hanging)
    single = jnp.array([_end_tension(p, hanging) for p in params])
    np.testing.assert_allclose(batch, single, rtol=1e-12)
    assert float(batch[2]) > float(batch[1]) > float(batch[0]) > 0.0


def test_gradients_match_central_differences(hanging):
    # d(end tension)/d(pull speed, EA), forward mode through simulate (RK4), against central
    # differences with steps of 1e-5 relative (truncation ~1e-10 relative, round-off ~1e-11 / 1e-5).
    params = jnp.array([0.5, EA])
    grad = jax.jit(jax.jacfwd(_end_tension))(params, hanging)
    assert np.all(np.isfinite(grad))
    for i in range(2):
        step = jnp.zeros(2).at[i].set(1e-5 * params[i])
        fd = (_end_tension(params + step, hanging) - _end_tension(params - step, hanging)) / (2 * step[i])
        assert float(grad[i]) == pytest.approx(float(fd), rel=1e-5), (i, float(grad[i]), float(fd))
        assert float(grad[i]) > 0.0  # a faster pull and a stiffer line both raise the tension


def test_unrolled_solvers():
    # FastTsit5 takes diffrax.Tsit5's steps and gives its results (same tableau, stages unrolled);
    # RK4 converges at order 4 on a damped oscillator (exact solution: the matrix exponential).
    A = jnp.array([[0.0, 1.0], [-4.0, -0.3]])

    def vf(t, y, args):
        return A @ y

    y0, ts = jnp.array([1.0, 0.0]), jnp.linspace(0.0, 2.0, 5)
    ref = jax.scipy.linalg.expm(2.0 * A) @ y0
    sols = [
        diffrax.diffeqsolve(
            diffrax.ODETerm(vf), s, 0.0, 2.0, None, y0, saveat=diffrax.SaveAt(ts=ts),
            stepsize_controller=diffrax.PIDController(rtol=1e-8, atol=1e-8),
        )
        for s in (diffrax.Tsit5(), FastTsit5())
    ]
    assert int(sols[0].stats["num_steps"]) == int(sols[1].stats["num_steps"])
    np.testing.assert_allclose(sols[1].ys, sols[0].ys, rtol=0, atol=1e-13)

    @jax.jit
    def rk4(dt):
        s = diffrax.diffeqsolve(
            diffrax.ODETerm(vf), RK4(), 0.0, 2.0, dt, y0, saveat=diffrax.SaveAt(t1=True),
            stepsize_controller=diffrax.ConstantStepSize(), max_steps=200,
        )  # fmt: skip
        return s.ys[0]

    e1, e2 = float(jnp.max(jnp.abs(rk4(0.05) - ref))), float(jnp.max(jnp.abs(rk4(0.025) - ref)))
    assert 13.0 < e1 / e2 < 19.0, (e1, e2)
    # RK4(substeps=4) at 4 dt takes RK4's steps of dt inside each loop step: the same states at the
    # loop's step ends (the save grid on multiples of 4 dt), to round-off; 4x fewer loop steps
    grid = jnp.linspace(0.0, 2.0, 11)

    def solve(solver, dt):
        s = diffrax.diffeqsolve(
            diffrax.ODETerm(vf), solver, 0.0, 2.0, dt, y0, saveat=diffrax.SaveAt(ts=grid),
            stepsize_controller=diffrax.ConstantStepSize(), max_steps=200,
        )  # fmt: skip
        return s.ys, int(s.stats["num_steps"])

    (ys1, n1), (ys4, n4) = solve(RK4(), 0.025), solve(RK4(substeps=4), 0.1)
    assert (n1, n4) == (80, 20)
    np.testing.assert_allclose(ys4, ys1, rtol=0, atol=1e-13)
    assert float(jnp.max(jnp.abs(ys4[-1] - ref))) == pytest.approx(e2, rel=1e-6)
    for bad in (0, -2, 1.5, True):
        with pytest.raises(ValueError, match="substeps"):
            RK4(substeps=bad)
    with pytest.raises(ValueError, match="dt0"):
        jaxcable.simulate(_pull_scene(_sagging_guess(SEGMENTS + 1)), 0.01, solver="rk4")
