"""Quasi-Monte Carlo sweeps (paper section IV): Halton points on the paper's ranges, batched and
sharded evaluation, resumable CSV, failed cases, summaries, the command line.

Cost (2 cores): one compilation of the rigid passive case function in this process (~25 s), shared
by every test that runs physics here; one 4-device subprocess compiling the same sweep (started
first, so it compiles while this process does); toy-ODE subprocesses (~5 s each) for kill-and-resume.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.stats import qmc

import jaxcable
from jaxcable.arresting.layout import CaptureState
from jaxcable.arresting.passive import LandingCriteria
from jaxcable.arresting.uncertainty import (
    SCENARIOS,
    UNCERTAIN_PARAMETERS,
    captures_from_samples,
    halton_samples,
    halton_unit,
    scenario_ranges,
    scenario_settings,
)
from jaxcable.arresting.sweep import SAVE_SPACING_S, case_fn_for, run_qmc_sweep, summarize_sweep, summary_markdown
from jaxcable.arresting.sweep_plots import plot_histories, plot_landing_plane
from jaxcable.cli.sweep import sweep_main
from jaxcable.studies import sharding
from jaxcable.studies.sweep import AbstractCaseFunction, process_indices, read_sidecar, read_sweep_csv, run_sweep

TESTS = Path(__file__).resolve().parent
# The physics sweep of these tests: 7 cases (not a multiple of 3 or 4, so the last chunk is padded
# in both the 1-device and the 4-device run), 0.6 s after capture (the rocket is still descending:
# ~300-430 steps per case at the rigid level).
SWEEP = dict(scenario="I", n=7, batch_size=3, t_end_s=0.6)
FOUR_DEVICES = dict(XLA_FLAGS=f"{os.environ.get('XLA_FLAGS', '')} --xla_force_host_platform_device_count=4".strip(), JAX_PLATFORMS="cpu")


def _env(**extra):
    env = dict(os.environ)
    env.update(extra)
    env["PYTHONPATH"] = os.pathsep.join([str(TESTS), env.get("PYTHONPATH", "")])
    return env


# ------------------------------------------------------------------------------------------------
# Halton points on the paper's ranges
# ------------------------------------------------------------------------------------------------


def test_paper_ranges():
    """Tables 3, 4 and 8 (our reading of Table 8's row numbers) and Table 4's settings."""
    assert UNCERTAIN_PARAMETERS[:2] == ("x_m", "y_m") and UNCERTAIN_PARAMETERS[-1] == "noise_rms_m"
    assert len(UNCERTAIN_PARAMETERS) == 15
    full, passive = scenario_ranges("II", "full"), scenario_ranges("II", "passive")
    assert list(full) == list(UNCERTAIN_PARAMETERS) == list(passive)
    assert full["x_m"] == (-13.0, 13.0) and full["theta_z_deg"] == (-25.0, 25.0)
    assert full["vx_m_s"] == (-0.1, 0.1) and full["omega_z_deg_s"] == (-0.1, 0.1)
    assert full["motor_delay_s"] == (0.0, 0.1) and full["noise_rms_m"] == (0.0, 0.1)
    assert passive["y_m"] == (-17.0, 17.0) and passive["vy_m_s"] == (-2.0, 2.0)
    assert passive["theta_x_deg"] == (-16.0, 16.0) and passive["theta_z_deg"] == (-26.0, 26.0)
    assert passive["omega_y_deg_s"] == (-6.0, 6.0) and passive["omega_z_deg_s"] == (-0.6, 0.6)
    assert passive["motor_delay_s"] == (0.0, 0.0) and passive["noise_rms_m"] == (0.0, 0.0)
    for scenario, v_max in zip(SCENARIOS, (5.0, 10.0, 20.0)):
        r = scenario_ranges(scenario, "passive")
        assert r["wind_speed_m_s"] == (0.0, v_max) and r["wind_angle_deg"] == (0.0, 360.0)
        assert r["gust_intensity"] == (0.10, 0.20)
    assert scenario_settings("III") == dict(v_ws_max=20.0, h_m=100.0, t_c_s=5.0, a_p=6.0)
    with pytest.raises(ValueError, match="scenario"):
        scenario_ranges("IV")
    with pytest.raises(ValueError, match="phase"):
        scenario_ranges("I", "active")


def test_halton_deterministic_prefix_and_in_range():
    a = halton_samples(37, "III", "full", seed=3)
    b = halton_samples(37, "III", "full", seed=3)
    big = halton_samples(100, "III", "full", seed=3)
    other = halton_samples(37, "III", "full", seed=4)
    for name, (lo, hi) in scenario_ranges("III", "full").items():
        assert a[name].shape == (37,)
        np.testing.assert_array_equal(a[name], b[name])
        np.testing.assert_array_equal(a[name], big[name][:37])  # a sweep can be extended
        assert np.all((a[name] >= lo) & (a[name] <= hi)), name
        assert not np.array_equal(a[name], other[name])
        # 100 points spread over the whole range (each of 4 quarters holds 25 +- 5 points)
        counts = np.histogram(big[name], bins=4, range=(lo, hi))[0]
        assert np.all(np.abs(counts - 25) <= 5), (name, counts)
    passive = halton_samples(20, "I", "passive")
    assert np.all(passive["motor_delay_s"] == 0.0) and np.all(passive["noise_rms_m"] == 0.0)
    assert halton_samples(0)["x_m"].shape == (0,)


def test_halton_lower_discrepancy_than_random():
    """The point of quasi-Monte Carlo: the 15-D points fill the unit cube more evenly than
    independent uniform draws (centred L2 discrepancy, scipy's independent implementation)."""
    u = halton_unit(128, seed=0)
    assert u.shape == (128, 15)
    random = [qmc.discrepancy(np.random.default_rng(s).random((128, 15))) for s in range(5)]
    assert qmc.discrepancy(u) < min(random)


def test_captures_from_samples():
    s = halton_samples(5, "I", "passive")
    c = captures_from_samples(s)
    assert isinstance(c, CaptureState)
    for name in UNCERTAIN_PARAMETERS[:10]:
        np.testing.assert_array_equal(np.asarray(getattr(c, name)), s[name])
    np.testing.assert_array_equal(np.asarray(c.vz_m_s), -20.0 * np.ones(5))
    assert np.asarray(c.z_m).shape == (5,)
    bad = dict(s, theta_z_deg=np.array([0.0, 0.0, 50.0, 0.0, 0.0]))
    with pytest.raises(ValueError, match="theta_z_deg.*case 2"):
        captures_from_samples(bad)
    with pytest.raises(ValueError, match="case 1"):
        captures_from_samples(dict(s, theta_x_deg=np.array([0.0, 50.0, 0, 0, 0]), theta_y_deg=np.full(5, 40.0)))


def test_process_indices_cover_every_case_once():
    n = 23
    parts = [process_indices(n, p, 4) for p in range(4)]
    np.testing.assert_array_equal(np.sort(np.concatenate(parts)), np.arange(n))
    # growing n keeps every earlier case on the same process
    assert set(process_indices(10, 1, 4)) <= set(process_indices(n, 1, 4))
    with pytest.raises(ValueError, match="process_index"):
        process_indices(n, 4, 4)


def test_full_phase_registered_at_every_sweep_level(tmp_path, capsys):
    # the two-phase case function is registered ("arresting.full") on import of jaxcable.arresting; its ale/full
    # levels mesh cables on the host from the captured state (tests/test_sweep_two_phase.py runs one)
    for level in ("rigid", "ale", "full"):
        fn = case_fn_for("full", level)
        assert type(fn).__name__ == "TwoPhaseCaseFunction" and fn.host_build == (level != "rigid")
    with pytest.raises(ValueError, match="fidelity"):
        case_fn_for("full", "1dof")
    out = tmp_path / "never.csv"
    # the two-phase tracking runs at fixed settings: the passive phase's solver options are refused
    assert sweep_main(["--phase", "full", "--rtol", "1e-5", "--n", "2", "--out", str(out), "--json"]) == 2
    assert "--rtol" in capsys.readouterr().err and not out.exists()


# ------------------------------------------------------------------------------------------------
# The passive physics sweep: unsharded here, sharded over 4 CPU devices in a subprocess
# ------------------------------------------------------------------------------------------------

_SHARDED_SCRIPT = textwrap.dedent(
    """
    import json, sys, jax
    import jaxcable
    from jaxcable.arresting.sweep import run_qmc_sweep
    from test_sweep import SWEEP
    jaxcable.enable_x64()
    run_qmc_sweep(out=sys.argv[1], progress=False, **SWEEP)
    print(json.dumps(dict(devices=jax.device_count())))
    """
)


@pytest.fixture(scope="module")
def sharded_run(tmp_path_factory):
    """Start the 4-device sweep first: it compiles while this process compiles the reference."""
    out = tmp_path_factory.mktemp("sharded") / "sharded.csv"
    proc = subprocess.Popen(
        [sys.executable, "-c", _SHARDED_SCRIPT, str(out)],
        env=_env(**FOUR_DEVICES),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    yield proc, out
    if proc.poll() is None:
        proc.kill()
        proc.wait()


@pytest.fixture(scope="module")
def reference(tmp_path_factory, sharded_run):
    out = tmp_path_factory.mktemp("reference") / "reference.csv"
    table = run_qmc_sweep(out=out, progress=False, **SWEEP)
    return out, table


def test_reference_sweep_rows(reference):
    out, table = reference
    n = SWEEP["n"]
    samples = halton_samples(n, SWEEP["scenario"], "passive")
    np.testing.assert_array_equal(table["case"], np.arange(n))
    for name in UNCERTAIN_PARAMETERS:
        np.testing.assert_array_equal(table[name], samples[name])  # exact float round trip
    assert not table["failed"].any() and set(table["solver_status"]) == {"successful"}
    assert table["captured"].all()
    # 0.6 s after capture at 20 m/s the rocket is still descending: not stopped, no stop time
    assert not table["stopped"].any() and np.isnan(table["stop_time_s"]).all()
    crit = LandingCriteria()
    np.testing.assert_allclose(table["z_margin_m"], crit.z_max_m - table["z_max_m"], rtol=1e-12)
    np.testing.assert_array_equal(table["a_ok"], table["a_max_g"] < crit.a_max_g)
    # success: captured and the criteria met, which needs a successful solve and a stopped rocket:
    # still descending, no case meets them, whatever its maxima so far
    flags = table["solve_ok"] & table["stopped"] & table["z_ok"] & table["a_ok"] & table["sigma_ok"]
    np.testing.assert_array_equal(table["criteria_met"], flags)
    np.testing.assert_array_equal(table["success"], table["captured"] & table["criteria_met"])
    assert table["solve_ok"].all() and not table["criteria_met"].any() and not table["success"].any()
    # the drop of O after 0.6 s of braking is bounded by free fall at 20 m/s and by zero
    assert np.all((table["z_max_m"] > 0) & (table["z_max_m"] < 20.0 * 0.6 + 0.5 * 9.81 * 0.6**2))
    lines = out.read_text().splitlines()
    assert len(lines) == n + 1 and len({line.split(",")[0] for line in lines[1:]}) == n


def _assert_same_sweep(a: dict, b: dict, rtol: float):
    assert list(a) == list(b)
    for name in a:
        if name == "num_steps":
            # roundoff moves step acceptances: a few steps of ~300-430
            np.testing.assert_allclose(a[name], b[name], rtol=0.05)
        elif name == "energy_budget_error":
            # a relative error of ~1e-7: it is the difference of two close numbers, compare absolutely
            np.testing.assert_allclose(a[name], b[name], atol=1e-8)
        elif a[name].dtype.kind == "f":
            np.testing.assert_allclose(a[name], b[name], rtol=rtol, atol=0, equal_nan=True, err_msg=name)
        else:
            np.testing.assert_array_equal(a[name], b[name], err_msg=name)


def test_sharded_equals_unsharded(reference, sharded_run):
    proc, out = sharded_run
    stdout, stderr = proc.communicate(timeout=240)
    assert proc.returncode == 0, stderr[-3000:]
    assert json.loads(stdout.strip().splitlines()[-1])["devices"] == 4
    # Not bitwise: the per-device batch shape (1 case per device here, 3 in the reference) changes
    # XLA's roundoff, which moves some adaptive step acceptances; the outputs then differ at the
    # integration tolerance (rtol = atol = 1e-6 on the state). Measured: <= 2e-7 relative (a_max).
    _assert_same_sweep(read_sweep_csv(out), reference[1], rtol=1e-5)


def test_resume_drops_partial_line_and_skips_written_cases(reference, tmp_path):
    """A killed writer leaves complete lines and maybe one partial line; the restart truncates the
    partial line, computes only the missing cases and ends with the uninterrupted sweep's rows."""
    src, table = reference
    out = tmp_path / "resumed.csv"
    lines = src.read_text().splitlines(keepends=True)
    out.write_text("".join(lines[:3]) + lines[3][:25])  # header, cases 0 and 1, a cut line
    Path(str(out) + ".json").write_text(Path(str(src) + ".json").read_text())
    resumed = run_qmc_sweep(out=out, progress=False, **SWEEP)
    # Same compiled code, but a case's slot in the batch (its SIMD lane) changes its roundoff
    # (measured: 2e-15 relative here), which adaptive stepping may amplify up to the integration
    # tolerance: the same comparison as sharded against unsharded.
    _assert_same_sweep(resumed, table, rtol=1e-5)
    assert len(out.read_text().splitlines()) == SWEEP["n"] + 1


def test_refuses_to_resume_a_different_sweep(reference, tmp_path):
    out, _ = reference
    before = out.read_bytes()
    with pytest.raises(ValueError, match="seed"):
        run_qmc_sweep(out=out, progress=False, **dict(SWEEP, scenario="I"), seed=1)
    with pytest.raises(ValueError, match="scenario"):
        run_qmc_sweep(out=out, progress=False, **dict(SWEEP, scenario="II"))
    with pytest.raises(ValueError, match="t_end_s"):
        run_qmc_sweep(out=out, progress=False, **dict(SWEEP, t_end_s=0.7))
    with pytest.raises(ValueError, match="n = 6 < 7"):
        run_qmc_sweep(out=out, progress=False, **dict(SWEEP, n=6))
    with pytest.raises(ValueError, match="cable_damping_s"):  # another cable damping: another sweep
        run_qmc_sweep(out=out, progress=False, **dict(SWEEP, cable_damping_s=1e-2))
    with pytest.raises(ValueError, match="cable_damping_s"):
        run_qmc_sweep(out=tmp_path / "neg.csv", progress=False, **dict(SWEEP, cable_damping_s=-1.0))
    assert out.read_bytes() == before
    stray = tmp_path / "stray.csv"
    stray.write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="sidecar"):
        run_qmc_sweep(out=stray, progress=False, **SWEEP)
    assert sweep_main(["--out", str(out), "--n", "7", "--seed", "2", "--t-end", "0.6", "--json"]) == 2


def test_an_interrupted_sweep_keeps_its_n(reference, tmp_path):
    """A run that dies after a chunk (here: its on_chunk raises) has recorded its n in the sidecar,
    so that a resume with fewer cases is refused as it is after a finished run."""
    out = tmp_path / "interrupted.csv"

    class Interrupted(Exception):
        pass

    def interrupt(chunk):
        raise Interrupted

    with pytest.raises(Interrupted):
        run_qmc_sweep(out=out, progress=False, on_chunk=interrupt, **SWEEP)
    assert read_sidecar(out)["n"] == SWEEP["n"]
    with pytest.raises(ValueError, match=f"n = {SWEEP['n'] - 1} < {SWEEP['n']}"):
        run_qmc_sweep(out=out, progress=False, **dict(SWEEP, n=SWEEP["n"] - 1))


def test_cli_json(reference, tmp_path, capsys):
    _, table = reference
    out = tmp_path / "cli.csv"
    argv = ["--scenario", "I", "--n", "7", "--batch-size", "3", "--t-end", "0.6", "--out", str(out), "--json"]
    assert sweep_main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["n_cases"] == 7 and summary["n_failed"] == 0
    assert 0.0 <= summary["success_rate"] <= 1.0
    assert summary["success_rate"] == pytest.approx(np.mean(table["success"]))
    assert summary["wind_applied"] is True
    for name in ("z_max_m", "a_max_g", "sigma_max_mpa"):
        c = summary["criteria"][name]
        assert c["min"] == pytest.approx(np.min(table[name])) and c["max"] == pytest.approx(np.max(table[name]))
        assert c["mean"] == pytest.approx(np.mean(table[name]))
    # the table form (what `jaxcable sweep` prints without --json)
    assert sweep_main(argv[:-1]) == 0  # resumes: every case is written, nothing to compute
    printed = capsys.readouterr().out
    assert "| z_max_m [m] |" in printed and "success rate" in printed


def test_summary_and_plots(reference, tmp_path):
    _, table = reference
    s = summarize_sweep(table)
    md = summary_markdown(s, "test")
    assert f"| {s['n_cases']} | 0 |" in md
    # a failed case leaves the statistics and counts as unsuccessful
    bad = {k: v.copy() for k, v in table.items()}
    bad["solver_status"] = bad["solver_status"].astype(object)  # room for a longer status
    bad["failed"][0], bad["z_max_m"][0], bad["solver_status"][0] = True, np.nan, "max_steps_reached"
    sb = summarize_sweep(bad)
    assert sb["n_failed"] == 1 and sb["failed_status"] == {"max_steps_reached": 1}
    assert sb["criteria"]["z_max_m"]["max"] == pytest.approx(np.max(table["z_max_m"][1:]))
    p1 = plot_landing_plane(bad, tmp_path / "plane.png")
    ts = np.linspace(0, 0.6, 11)
    hist = dict(ts=np.stack([ts, ts]), drop_m=np.stack([ts, 2 * ts]), acceleration_g=np.ones((2, 11)), stress_max_mpa=np.ones((2, 11)))
    p2 = plot_histories(hist, tmp_path / "hist.png")
    assert Path(p1).stat().st_size > 10_000 and Path(p2).stat().st_size > 10_000


# ------------------------------------------------------------------------------------------------
# Sweep machinery on a toy ODE case function (compiles in ~1 s): failures, kill and resume
# ------------------------------------------------------------------------------------------------


class DecayCase(AbstractCaseFunction):
    """y' = -k y, y(0) = 1 on [0, 1] with Tsit5 and a small step budget: ``y1`` against the closed
    form exp(-k); a fast decay (k = 200) needs more steps than ``max_steps`` (a numerical failure);
    ``root = sqrt(c)`` is NaN for c < 0 although the solver succeeded."""

    max_steps: int = eqx.field(static=True, default=24)

    def __call__(self, params):
        k, c = params["k"], params["c"]
        sol = diffrax.diffeqsolve(
            diffrax.ODETerm(lambda t, y, args: -k * y),
            diffrax.Tsit5(),
            0.0,
            1.0,
            0.01,
            jnp.ones(()),
            stepsize_controller=diffrax.PIDController(rtol=1e-8, atol=1e-10),
            max_steps=self.max_steps,
            throw=False,
        )
        return dict(
            y1=sol.ys[-1],
            y1_error=sol.ys[-1] - jnp.exp(-k),
            root=jnp.sqrt(c),
            status_code=sol.result._value,
            num_steps=sol.stats["num_accepted_steps"],
        )


class DecayProblem(eqx.Module):
    k: jnp.ndarray
    c: jnp.ndarray
    kind: str = eqx.field(static=True, default="decay")


class HostBuiltDecay(DecayCase):
    """The same cases through the host-build path of the sweep (as the ale level uses): ``build``
    needs concrete numbers (``float``), ``solve`` is traced."""

    @property
    def host_build(self):
        return True

    def build(self, params):
        return DecayProblem(k=jnp.asarray(float(params["k"])), c=jnp.asarray(float(params["c"])))

    def solve(self, problem):
        return DecayCase.__call__(self, dict(k=problem.k, c=problem.c))

    def __call__(self, params):
        return self.solve(self.build(params))


def decay_samples(n):
    k = np.where(np.arange(n) % 5 == 3, 200.0, 0.5 + 0.1 * np.arange(n))
    c = np.where(np.arange(n) % 7 == 4, -1.0, 1.0 + np.arange(n))
    return dict(k=k, c=c)


_KILL_SCRIPT = textwrap.dedent(
    """
    import sys, time
    from jaxcable.studies.sweep import run_sweep
    from test_sweep import DecayCase, decay_samples
    sleep = float(sys.argv[2])
    run_sweep(DecayCase(), decay_samples(12), sys.argv[1], batch_size=3, identity=dict(toy=1), progress=False,
              on_chunk=(lambda idx: time.sleep(sleep)) if sleep else None)
    """
)


class NoShardMapDecay(DecayCase):
    """The toy cases as a case function that does not run under ``shard_map`` (as the two-phase one,
    whose event root find does not trace there): on several devices the sweep gives each device its
    own slice and call."""

    @property
    def per_device_loops(self):
        return False


_PER_DEVICE_SCRIPT = textwrap.dedent(
    """
    import json, sys
    import jaxcable.studies.sharding as sharding
    import jaxcable.studies.sweep as sweep
    from test_sweep import NoShardMapDecay, decay_samples
    seen, on_mesh = [], sharding.on_mesh
    def spy(case_fn, part, mesh, method):
        seen.append(sorted(d.id for d in mesh.devices.flat))
        return on_mesh(case_fn, part, mesh, method)
    sharding.on_mesh = spy
    sweep.run_sweep(NoShardMapDecay(), decay_samples(12), sys.argv[1], batch_size=8, progress=False)
    print(json.dumps(seen))
    """
)


def test_per_device_calls_without_shard_map(tmp_path):
    """On 4 devices a case function without per-device loops runs one call per device on its own
    slice (each chunk of 8: 4 calls of 2 cases), and the rows equal a 1-device run's."""
    out = tmp_path / "per_device.csv"
    proc = subprocess.run([sys.executable, "-c", _PER_DEVICE_SCRIPT, str(out)], env=_env(**FOUR_DEVICES),
                          capture_output=True, text=True, timeout=300)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    seen = json.loads(proc.stdout.strip().splitlines()[-1])
    # two chunks, each as four calls on one device each (the threads may start them in any order)
    assert sorted(map(tuple, seen)) == sorted([(d,) for d in range(4)] * 2)
    one = run_sweep(DecayCase(), decay_samples(12), tmp_path / "one.csv", batch_size=8, progress=False)
    _assert_same_toy_rows(read_sweep_csv(out), one)


def test_failed_cases_are_rows_with_their_status(tmp_path):
    table = run_sweep(DecayCase(), decay_samples(12), tmp_path / "toy.csv", batch_size=4, progress=False)
    ok = ~table["failed"]
    # the successful cases are right (closed form) and the sweep went on past the failures
    assert np.max(np.abs(table["y1_error"][ok])) < 1e-7
    steps_failed = table["k"] == 200.0
    nan_failed = table["c"] < 0
    assert steps_failed.sum() == 2 and nan_failed.sum() == 2
    np.testing.assert_array_equal(table["failed"], steps_failed | nan_failed)
    assert set(table["solver_status"][steps_failed]) == {"max_steps_reached"}
    assert set(table["solver_status"][nan_failed & ~steps_failed]) == {"successful"}
    assert np.all(np.isnan(table["root"][nan_failed]))
    s = summarize_sweep(table)
    assert s["n_failed"] == 4 and s["failed_status"] == {"max_steps_reached": 2, "successful": 2}


def test_host_built_cases_match_traced_ones(tmp_path):
    traced = run_sweep(DecayCase(), decay_samples(6), tmp_path / "traced.csv", batch_size=3, progress=False)
    built = run_sweep(HostBuiltDecay(), decay_samples(6), tmp_path / "built.csv", batch_size=3, progress=False)
    with pytest.raises(TypeError):  # what the host path is for: build cannot be traced
        jax.vmap(HostBuiltDecay().build)({k: jnp.asarray(v) for k, v in decay_samples(2).items()})
    for name in traced:
        # same arithmetic, same batch shapes and slots: identical
        np.testing.assert_array_equal(built[name], traced[name], err_msg=name)


class StreamedDecay(HostBuiltDecay):
    """The host-built toy with its ``build`` failing on ``k = 13`` (a case whose set-up raises)."""

    def build(self, params):
        if float(params["k"]) == 13.0:
            raise ValueError("k = 13: no such case")
        return super().build(params)


_STREAM_SCRIPT = textwrap.dedent(
    """
    import json, sys, threading
    import jax
    import jaxcable.studies.sharding as sharding
    from jaxcable.studies.sweep import run_sweep
    from test_sweep import StreamedDecay, decay_samples
    seen, lock = [], threading.Lock()
    solve_one = sharding._solve_one
    def spy(case_fn, case):
        with lock:
            seen.append(sorted({d.id for x in jax.tree_util.tree_leaves(case) if hasattr(x, "devices") for d in x.devices()}))
        return solve_one(case_fn, case)
    sharding._solve_one = spy
    run_sweep(StreamedDecay(), decay_samples(12), sys.argv[1], batch_size=4, progress=False)
    print(json.dumps(seen))
    """
)


def test_one_case_a_device_streams_the_cases(tmp_path):
    """On 4 devices at one case a device the host-built cases are streamed: each is solved alone
    (the single-case solve, not vmapped), each on one device, all four devices used, every case once; the
    rows equal a 1-device run's in chunks of one case (``stream=False``; same arithmetic, one case
    alone against a vmapped chunk of one)."""
    out = tmp_path / "streamed.csv"
    proc = subprocess.run([sys.executable, "-c", _STREAM_SCRIPT, str(out)], env=_env(**FOUR_DEVICES),
                          capture_output=True, text=True, timeout=300, check=False)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    seen = json.loads(proc.stdout.strip().splitlines()[-1])
    assert len(seen) == 12 and all(len(d) == 1 for d in seen)
    assert {d[0] for d in seen} == {0, 1, 2, 3}
    got = read_sweep_csv(out)
    np.testing.assert_array_equal(got["case"], np.arange(12))
    # the same layout, one case a device, run in chunks (as before streaming; the benchmark's other
    # arm): the single-case solve is never called
    alone = []
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(sharding, "_solve_one", lambda *a: alone.append(a))
        chunked = run_sweep(StreamedDecay(), decay_samples(12), tmp_path / "chunked.csv", batch_size=1, progress=False, stream=False)
    assert not alone
    _assert_same_toy_rows(got, chunked)


def test_a_streamed_case_that_raises_stops_the_sweep_with_its_error(tmp_path):
    """A case whose build raises stops a streamed sweep with that error; the rows written before it
    stay, and the sweep resumes (here with the case fixed) to every case once."""
    samples = decay_samples(12)
    samples["k"] = np.where(np.arange(12) == 5, 13.0, samples["k"])
    out = tmp_path / "raises.csv"
    with pytest.raises(ValueError, match="k = 13"):
        run_sweep(StreamedDecay(), samples, out, batch_size=1, progress=False)
    written = read_sweep_csv(out)["case"]
    assert 5 not in written and set(written) <= set(range(12)) and len(written) >= 5
    fixed = dict(samples, k=decay_samples(12)["k"])
    # the inputs of the written cases are unchanged, so the sweep resumes; case 5's input changed
    # but it was never written
    table = run_sweep(StreamedDecay(), fixed, out, batch_size=1, progress=False)
    np.testing.assert_array_equal(table["case"], np.arange(12))


def test_kill_and_resume(tmp_path):
    """A sweep killed (SIGKILL) after its first chunk and restarted with the same arguments on 4
    devices ends with exactly the rows of an uninterrupted single-device run, each case once."""
    out = tmp_path / "killed.csv"
    first = subprocess.Popen([sys.executable, "-c", _KILL_SCRIPT, str(out), "60"], env=_env(), stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while not (out.exists() and len(out.read_text().splitlines()) >= 2):
            assert first.poll() is None, first.stderr.read()[-3000:]
            assert time.monotonic() < deadline, "no chunk written in 120 s"
            time.sleep(0.1)
    finally:
        first.send_signal(signal.SIGKILL)
        first.wait()
    written = out.read_text().splitlines()
    assert 2 <= len(written) < 13  # killed before it finished
    uninterrupted = run_sweep(
        DecayCase(), decay_samples(12), tmp_path / "whole.csv", batch_size=3, identity=dict(toy=1), progress=False
    )
    second = subprocess.run(
        [sys.executable, "-c", _KILL_SCRIPT, str(out), "0"], env=_env(**FOUR_DEVICES), capture_output=True, text=True, timeout=120
    )
    assert second.returncode == 0, second.stderr[-3000:]
    lines = out.read_text().splitlines()
    assert len(lines) == 13 and sorted(int(x.split(",")[0]) for x in lines[1:]) == list(range(12))
    _assert_same_toy_rows(read_sweep_csv(out), uninterrupted)


def _assert_same_toy_rows(got: dict, want: dict):
    """The toy sweep's rows on 4 devices against 1 device. Successful cases: roundoff only (measured
    identical). The state where a failed case stopped (max_steps) is not a result: its flags and
    status are compared, not its values (they differed by 3e-10). atol: y1_error (~3e-10) is a
    difference of nearly equal numbers, its roundoff is absolute (2e-15 measured)."""
    ok = ~want["failed"]
    for name in want:
        if want[name].dtype.kind == "f":
            np.testing.assert_allclose(got[name][ok], want[name][ok], rtol=1e-12, atol=1e-14, equal_nan=True, err_msg=name)
        else:
            np.testing.assert_array_equal(got[name], want[name], err_msg=name)


# ------------------------------------------------------------------------------------------------
# Slow: the batched case function against the single-case entry point; histories; real failures
# ------------------------------------------------------------------------------------------------


@pytest.mark.slow
def test_sweep_rows_match_single_landings(reference):
    """Case 0 of the vmapped, shard_mapped sweep against one unbatched ``simulate`` of the passive
    scene with the same capture, solver settings and saved grid."""
    from jaxcable.arresting.landing import LEVEL_DEFAULTS
    from jaxcable.arresting.passive import landing_outputs, passive_landing_scene

    from jaxcable.arresting.sweep import passive_case_fn

    _, table = reference
    t_end = SWEEP["t_end_s"]
    params = {k: jnp.asarray(float(table[k][0])) for k in UNCERTAIN_PARAMETERS}
    # the case's scene (capture state and its seeded wind), solved unbatched
    scene = passive_case_fn("rigid", t_end_s=t_end).build(params)
    assert float(scene.capture.x_m) == pytest.approx(float(table["x_m"][0]))
    assert float(scene.wind.speed_m_s) == pytest.approx(float(table["wind_speed_m_s"][0]))
    solver, rtol, atol, max_steps = LEVEL_DEFAULTS["rigid"]
    r = jaxcable.simulate(
        scene,
        t_end,
        solver=solver,
        rtol=rtol,
        atol=atol,
        max_steps=max_steps,
        save_ts=np.linspace(0.0, t_end, round(t_end / SAVE_SPACING_S) + 1),
    )
    single = landing_outputs(r.ts, r.probes, r.status)
    for name in ("z_max_m", "a_max_g", "sigma_max_mpa"):
        # batched vs unbatched: roundoff moved by adaptive stepping (see test_sharded_equals_unsharded)
        assert table[name][0] == pytest.approx(float(single[name]), rel=1e-5), name
    assert bool(table["stopped"][0]) == bool(single["stopped"])


@pytest.mark.slow
def test_histories_and_cli_plots(reference, tmp_path, capsys):
    """Figs 18-20 histories in a separate batch: their maxima are the sweep's outputs."""
    from jaxcable.arresting.sweep import passive_case_fn
    from jaxcable.studies.sweep import run_histories

    src, table = reference
    case_fn = passive_case_fn("rigid", t_end_s=SWEEP["t_end_s"])
    samples = halton_samples(SWEEP["n"], SWEEP["scenario"], "passive")
    hist = run_histories(case_fn, samples, np.arange(SWEEP["n"]))
    assert hist["drop_m"].shape == (SWEEP["n"], round(SWEEP["t_end_s"] / SAVE_SPACING_S) + 1)
    # max over the same saved grid; batch shape differs (7 here, 3 in the sweep): tolerance as above
    np.testing.assert_allclose(np.nanmax(hist["drop_m"], axis=1), table["z_max_m"], rtol=1e-5)
    # the histories are unfiltered: their maxima are the raw ones (the criteria are after CFC 60)
    np.testing.assert_allclose(np.nanmax(hist["stress_max_mpa"], axis=1), table["sigma_max_raw_mpa"], rtol=1e-5)
    np.testing.assert_allclose(np.nanmax(hist["acceleration_g"], axis=1), table["a_max_raw_g"], rtol=1e-5)
    out = tmp_path / "cli.csv"
    out.write_bytes(src.read_bytes())
    Path(str(out) + ".json").write_bytes(Path(str(src) + ".json").read_bytes())
    argv = ["--n", "7", "--batch-size", "3", "--t-end", "0.6", "--out", str(out), "--plot", str(tmp_path / "fig"), "--json"]
    assert sweep_main(argv) == 0
    plots = json.loads(capsys.readouterr().out)["plots"]
    assert [Path(p).name for p in plots] == ["fig_plane.png", "fig_histories.png"]
    assert all(Path(p).stat().st_size > 10_000 for p in plots)


@pytest.mark.slow
def test_physics_case_out_of_steps_is_a_failed_row(tmp_path):
    table = run_qmc_sweep(out=tmp_path / "short.csv", progress=False, max_steps=50, **dict(SWEEP, n=2, batch_size=2))
    assert table["failed"].all() and set(table["solver_status"]) == {"max_steps_reached"}
    assert (table["num_steps"] <= 50).all()  # accepted steps; max_steps also counts rejected ones
    assert summarize_sweep(table)["success_rate"] == 0.0


# ------------------------------------------------------------------------------------------------
# Screening sweeps confirmed at the defaults
# ------------------------------------------------------------------------------------------------


def _doctored_screen(reference, path, passive_rtol=1e-4):
    """A stand-in for a screening sweep: the reference CSV and sidecar, its rows edited so that the
    cases to confirm are known (case 2 within 0.1% of the a_max limit, case 4 failed, case 5 not
    stopped; the others far from every limit, stopped, successful); its sidecar says it ran at
    ``passive_rtol``."""
    out, _ = reference
    lines = Path(out).read_text().splitlines()
    header = lines[0].split(",")
    col = {name: header.index(name) for name in header}
    far = {"z_max_m": "5.0", "a_max_g": "2.0", "sigma_max_mpa": "400.0", "failed": "False", "stopped": "True",
           "captured": "True", "success": "True", "solver_status": "successful"}  # fmt: skip
    rows = []
    for line in lines[1:]:
        row = line.split(",")
        for name, value in far.items():
            row[col[name]] = value
        case = int(row[0])
        if case == 2:
            row[col["a_max_g"]] = "5.005"
        if case == 4:
            row[col["failed"]], row[col["success"]] = "True", "False"
        if case == 5:
            row[col["stopped"]] = "False"
        rows.append(",".join(row))
    path.write_text("\n".join([lines[0], *rows]) + "\n")
    side = json.loads(Path(str(out) + ".json").read_text())
    side["case_fn"]["passive_rtol"] = passive_rtol  # the tolerance a screen ran at (its measured band)
    Path(str(path) + ".json").write_text(json.dumps(side))
    return path


RESULTS = Path(__file__).resolve().parents[1] / "experiments" / "results"


@pytest.mark.parametrize("scenario", SCENARIOS)
@pytest.mark.parametrize("suffix, bands", [("screen3", "COARSE_SCREENING_BANDS"), ("screen3e4", "SCREENING_BANDS_3E4")])
def test_screening_bands_hold_the_recorded_screens(scenario, suffix, bands):
    """The recorded section IV screens at --rtol 1e-3 and 3e-4 against those at --rtol 1e-4 (3 x 100
    cases each, no solve here): each criterion's band covers twice the deviation seen, every verdict
    the screen turned lies inside the bands (so --confirm reruns it), and --confirm picks those bands
    from the screen's sidecar."""
    from jaxcable.arresting import screening
    from jaxcable.studies.sweep import read_sweep_csv

    bands = getattr(screening, bands)
    path = RESULTS / f"sweep_two_phase_full_1body_{scenario}_n100_{suffix}.csv"
    screen = read_sweep_csv(path)
    fine = read_sweep_csv(RESULTS / f"sweep_two_phase_full_1body_{scenario}_n100_screen.csv")
    assert len(screen["case"]) == len(fine["case"]) == 100
    assert screening.measured_band(path) == bands
    order_c, order_f = np.argsort(screen["case"]), np.argsort(fine["case"])
    for name, band in bands.items():
        c, f = np.asarray(screen[name], float)[order_c], np.asarray(fine[name], float)[order_f]
        assert 2.0 * np.nanmax(np.abs(c / f - 1.0)) <= band, name
    turned = np.asarray(screen["case"], int)[order_c][
        np.asarray(screen["success"], bool)[order_c] != np.asarray(fine["success"], bool)[order_f]
    ]
    assert set(turned.tolist()) <= set(screening.cases_to_confirm(screen, bands).tolist())


def test_cases_to_confirm_and_the_screened_sweeps_identity(reference, tmp_path):
    from jaxcable.arresting.screening import cases_to_confirm, check_screened

    screen = _doctored_screen(reference, tmp_path / "screen.csv")
    table = read_sweep_csv(screen)
    assert cases_to_confirm(table).tolist() == [2, 4, 5]
    assert cases_to_confirm(table, band=1e-4).tolist() == [4, 5]  # 5.005 g is 1e-3 from the limit
    assert cases_to_confirm(table, band=0.7).tolist() == list(range(7))  # 2 g is 0.6 from 5 g
    nan = {k: v.copy() for k, v in table.items()}
    nan["sigma_max_mpa"][0] = np.nan
    assert 0 in cases_to_confirm(nan).tolist()
    with pytest.raises(ValueError, match="band"):
        cases_to_confirm(table, band=-1.0)
    # one band per criterion: case 2's a_max (1e-3 from its limit) is inside an a_max band of 2e-3
    # and outside one of 5e-4, whatever the other two criteria's bands
    per = {"z_max_m": 0.5, "a_max_g": 2e-3, "sigma_max_mpa": 1e-4}  # 5 m is 0.5 from 10 m: outside
    assert cases_to_confirm(table, band=per).tolist() == [2, 4, 5]
    assert cases_to_confirm(table, band=dict(per, a_max_g=5e-4)).tolist() == [4, 5]
    assert cases_to_confirm(table, band=dict(per, z_max_m=0.6)).tolist() == list(range(7))
    with pytest.raises(ValueError, match="missing"):
        cases_to_confirm(table, band={"a_max_g": 1e-3})
    with pytest.raises(ValueError, match="band\\[sigma_max_mpa\\]"):
        cases_to_confirm(table, band=dict(per, sigma_max_mpa=0.0))
    side = read_sidecar(screen)
    identity, case_fn = side["identity"], side["case_fn"]
    check_screened(screen, identity, dict(case_fn, t_end_s=99.0, rtol=1e-3), SWEEP["n"])  # settings may differ
    with pytest.raises(ValueError, match="cable_damping_s"):
        check_screened(screen, identity, dict(case_fn, cable_damping_s=1e-2), SWEEP["n"])
    with pytest.raises(ValueError, match="scenario"):
        check_screened(screen, dict(identity, scenario="II"), case_fn, SWEEP["n"])
    with pytest.raises(ValueError, match="resume it first"):
        check_screened(screen, identity, case_fn, SWEEP["n"] + 1)


def test_cli_confirms_the_screened_cases_near_a_limit(reference, tmp_path, capsys):
    _, table = reference
    screen = _doctored_screen(reference, tmp_path / "screen.csv")
    out = tmp_path / "confirmed.csv"
    argv = ["--scenario", "I", "--n", "7", "--batch-size", "3", "--t-end", "0.6", "--out", str(out), "--confirm", str(screen), "--json"]
    assert sweep_main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    conf = summary["confirmation"]
    assert conf["cases"] == [2, 4, 5]
    # the reference's verdicts (0.6 s: still descending, none a success) replace the doctored ones
    doctored = read_sweep_csv(screen)
    assert conf["turned"] == [c for c in (2, 4, 5) if doctored["success"][c] != table["success"][c]] == [2, 5]
    confirmed = read_sweep_csv(out)
    assert confirmed["case"].tolist() == [2, 4, 5]
    merged = read_sweep_csv(conf["merged_csv"])
    for c in range(7):
        source = table if c in (2, 4, 5) else doctored
        for name in ("z_max_m", "a_max_g", "sigma_max_mpa"):
            np.testing.assert_allclose(merged[name][c], source[name][c], rtol=1e-9)
        assert merged["success"][c] == source["success"][c]
    assert summary["n_success"] == int(np.sum(merged["success"]))
    # three bands, one per criterion (z, a, sigma): an a_max band of 5e-4 leaves case 2 out
    out3 = tmp_path / "confirmed3.csv"
    argv3 = [*argv[:-4], str(out3), "--confirm", str(screen), "--band", "1e-3", "5e-4", "1e-3", "--json"]
    assert sweep_main(argv3) == 0
    assert json.loads(capsys.readouterr().out)["confirmation"]["cases"] == [4, 5]
    assert sweep_main([*argv3[:-3], "5e-4", "--json"]) == 2  # two numbers
    assert "one number" in capsys.readouterr().err
    # the screened file itself is refused as the output
    assert sweep_main([*argv[:-5], "--out", str(screen), "--confirm", str(screen), "--json"]) == 2
    assert "screened sweep itself" in capsys.readouterr().err
    # without --band: the band measured for the screen's tolerance; a tolerance with none is refused
    coarse = _doctored_screen(reference, tmp_path / "coarse.csv", passive_rtol=1e-3)
    out_c = tmp_path / "confirmed_coarse.csv"
    assert sweep_main([*argv[:-4], str(out_c), "--confirm", str(coarse), "--json"]) == 0
    conf = json.loads(capsys.readouterr().out)["confirmation"]
    assert conf["band"]["a_max_g"] > 1e-3 and conf["cases"] == [2, 4, 5]  # 5.005 g: inside the coarse a_max band
    odd = _doctored_screen(reference, tmp_path / "odd.csv", passive_rtol=5e-4)
    assert sweep_main([*argv[:-4], str(tmp_path / "odd_out.csv"), "--confirm", str(odd), "--json"]) == 2
    err = capsys.readouterr().err
    assert "no band is measured" in err and "0.0005" in err
