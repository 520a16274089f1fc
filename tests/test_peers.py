"""Peer cross-check: jaxcable's finite-segment chain against an independent derivation in
PyDy / sympy.physics.mechanics ``KanesMethod`` (integrated with scipy), on the same trajectory.

Runs only where the optional peers are installed (``pip install -e ".[peers]"``); CI does not
install them, so it skips there. The chain, its initial state and the PyDy derivation are those of
``experiments/peers/pydy_chain.py`` (a pinned 3-link pendulum of point masses released straight
from rest 30 deg below the horizontal), imported from that script so that the test checks the
benchmark's own setup.
"""

import importlib.util
from pathlib import Path

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

pytest.importorskip("pydy")

_SCRIPT = Path(__file__).resolve().parents[1] / "experiments" / "peers" / "pydy_chain.py"


def _load_script():
    spec = importlib.util.spec_from_file_location("peers_pydy_chain", _SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_three_link_chain_matches_pydy_kanes_method():
    pc = _load_script()
    n, t_end, tol = 3, 1.0, 1e-9
    ts = np.linspace(0.0, t_end, 11)
    pc.T_END = t_end  # run_pydy integrates to the module's T_END

    # PyDy: symbolic KanesMethod + codegen, DOP853 at 100x the tolerance used for jaxcable.
    ref = pc.run_pydy(n, tol * 1e-2, ts)

    # jaxcable: the benchmark's scene, integrated directly with diffrax (cheaper to compile than
    # jaxcable.core.simulate's probes/outputs; the vector field is the one simulate integrates).
    scene = pc.jaxcable_chain_scene(n)

    @eqx.filter_jit
    def solve(scene):
        sol = diffrax.diffeqsolve(
            diffrax.ODETerm(lambda t, y, args: scene.vector_field(t, y)),
            diffrax.Tsit5(),
            0.0,
            t_end,
            None,
            scene.initial_state(),
            saveat=diffrax.SaveAt(ts=jnp.asarray(ts), fn=lambda t, y, args: scene.kinematics(t, y).positions),
            stepsize_controller=diffrax.PIDController(rtol=tol, atol=tol),
            max_steps=100_000,
        )
        return sol.ys

    positions = np.asarray(jax.block_until_ready(solve(scene)))
    assert positions.shape == ref["positions"].shape

    # The motion is not trivial: the tip travels metres and the links bend away from straight.
    tip_travel = np.linalg.norm(ref["positions"][-1, -1] - ref["positions"][0, -1])
    assert tip_travel > 2.0
    assert np.ptp(ref["theta"][-1]) > 0.1
    # Agreement to the integration tolerance: tip positions (metres, scale L = 10 m) and link angles.
    # Measured: 3.9e-10 m and 5.2e-10 rad (Tsit5 at rtol = atol = 1e-9, 36 steps); the bounds leave
    # ~20x margin for platform differences. A wrong mass, length or sign in either model gives >= 1e-3.
    tip_err = np.max(np.linalg.norm(positions[:, -1] - ref["positions"][:, -1], axis=-1))
    assert tip_err < 1e-8, tip_err
    angle_err = np.max(np.abs(pc.wrapped(pc.link_angles(positions) - ref["theta"])))
    assert angle_err < 1e-8, angle_err
    # The emulated pin (1e30 kg rocket with its weight cancelled) does not move.
    assert np.max(np.abs(positions[:, 0] - positions[0, 0])) < 1e-12
