"""Design optimisation: gradients through the solve vs central differences, reparametrisation,
CVaR vs brute force, optax steps, the smooth criteria's bounds, bad input, the command line; the
two-phase objective (a_p as a design variable): its terms by hand, and (slow) its gradient w.r.t.
m_w, F_f, a_p through both phases vs central differences and ``jaxcable design --vars m_w,F_f,a_p``.

One small problem (4 captures of Table 8, rigid level, 1 s, rtol 1e-8) is compiled once by a
module fixture; every test that simulates re-uses that compiled objective (same static structure).
"""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxcable.arresting.passive import SmoothingWidths
from jaxcable.arresting.design import (
    CONDITIONS,
    DesignProblem,
    ObjectiveWeights,
    default_phase,
    design_problem,
    design_space,
    objective_and_grad,
    objective_terms,
    optimise,
    paper_start,
)
from jaxcable.cli.design import design_main
from jaxcable.studies.optimise import cvar, smooth_cvar

# rtol 1e-8: the gradient of the discrete solve is then within 0.1 % of the converged gradient
# (at 1e-6 it is 1 % off and central differences are noisy at the percent level)
SETTINGS = dict(n=4, t_end_s=1.0, rtol=1e-8, atol=1e-8)
CLI_ARGS = ["--n", "4", "--t-end", "1.0", "--rtol", "1e-8"]


@pytest.fixture(scope="module")
def problem():
    return design_problem("m_w,F_f", **SETTINGS)


@pytest.fixture(scope="module")
def at_paper(problem):
    x0 = paper_start(problem)
    u0 = problem.space.to_unconstrained(x0)
    j, g, aux = objective_and_grad(problem, u0)
    return x0, u0, float(j), np.asarray(g), aux


def _objective_at(problem, x):
    return float(objective_and_grad(problem, problem.space.to_unconstrained(jnp.asarray(x)))[0])


def test_paper_start_is_the_one_dof_design(problem):
    """Section II.B through eq 15: m_t_bar = 4 alpha^2 m_w / m_r = 2 and F_t_bar from eq 19."""
    from jaxcable.arresting.one_dof import PAPER_ROCKET_MASS, design_groups, friction_group_for_stop, v0_bar

    m_w, F_f = np.asarray(paper_start(problem))
    m_t, F_t = design_groups(m_w, F_f, 3.0, PAPER_ROCKET_MASS)
    assert float(m_t) == pytest.approx(2.0, rel=1e-12)
    # eq 19 by hand: (v0_bar^2/2 + 0.4) / (sqrt(1 + 0.4^2) - 1)
    vb = 20.0 / np.sqrt(9.81 * 25.0)
    assert float(F_t) == pytest.approx((0.5 * vb**2 + 0.4) / (np.sqrt(1.16) - 1.0), rel=1e-12)
    assert float(F_t) == pytest.approx(float(friction_group_for_stop(v0_bar(20.0, 25.0), 0.4)), rel=1e-12)


# central differences of J in physical units: steps of 0.4 % and 0.3 % of m_w and F_f. Measured
# agreement with the gradient 0.1 % (truncation O(h^2) plus the adaptive solver's response to a
# parameter change, ~rtol / h); 0.5 % leaves room for a different BLAS, and a wrong chain rule (e.g.
# a missing dx/du) is off by factors, not by 0.5 %
FD_STEPS = np.array([5.0, 1.0e3])
FD_RTOL = 5e-3


@pytest.fixture(scope="module")
def central_differences(problem, at_paper):
    x0 = np.asarray(at_paper[0])
    fd = []
    for i in range(2):
        e = np.zeros(2)
        e[i] = FD_STEPS[i]
        fd.append((_objective_at(problem, x0 + e) - _objective_at(problem, x0 - e)) / (2 * FD_STEPS[i]))
    return np.asarray(fd)


def _physical_gradient(problem, x0, g_u):
    """dJ/dx = dJ/du / (dx/du), dx/du = (x - lo)(hi - x) / (hi - lo)."""
    x0 = np.asarray(x0)
    lo, hi = np.asarray(problem.space.lower), np.asarray(problem.space.upper)
    return np.asarray(g_u) / ((x0 - lo) * (hi - x0) / (hi - lo))


def test_gradient_matches_central_differences(problem, at_paper, central_differences):
    """dJ/dm_w and dJ/dF_f through the diffrax solve (forward mode) and the reparametrisation, in
    physical units, against central differences of the same objective in float64."""
    x0, u0, j0, g_u, aux = at_paper
    assert np.all(np.asarray(aux["status"]) == 0)
    g_x = _physical_gradient(problem, x0, g_u)
    for i, name in enumerate(problem.space.names):
        assert g_x[i] == pytest.approx(central_differences[i], rel=FD_RTOL), (name, g_x[i], central_differences[i])
        assert abs(g_x[i]) > 0.0


def test_smooth_criteria_bound_the_hard_ones(problem, at_paper):
    """Per case, soft max >= hard max (logsumexp is an upper bound) and <= hard + width log(n_save)."""
    aux = at_paper[4]
    w = SmoothingWidths()
    from jaxcable.arresting.passive import SAVE_SPACING_S

    n_save = round(problem.t_end_s / SAVE_SPACING_S) + 1  # the scene's default grid (1 ms)
    for key, width in (("z_max_m", w.z_m), ("a_max_g", w.a_g), ("sigma_max_mpa", w.sigma_mpa)):
        soft, hard = np.asarray(aux["smooth"][key]), np.asarray(aux["hard"][key])
        assert np.all(soft >= hard - 1e-12), key
        assert np.all(soft <= hard + width * np.log(n_save) + 1e-12), key


def test_reparametrisation_round_trip_and_bounds():
    sp = design_space("m_w,F_f", bounds={"F_f": (1.0e5, 6.0e5)})
    assert sp.names == ("m_w", "F_f")
    x = jnp.array([1388.9, 3.0886e5])
    np.testing.assert_allclose(np.asarray(sp.to_physical(sp.to_unconstrained(x))), np.asarray(x), rtol=1e-13)
    # any u maps inside the bounds (closed at float64 saturation, |u| ~ 40)
    rng = np.random.default_rng(0)
    u = jnp.asarray(rng.normal(scale=20.0, size=(200, 2)))
    xs = np.asarray(jax_vmap_physical(sp, u))
    assert np.all(xs >= np.asarray(sp.lower)) and np.all(xs <= np.asarray(sp.upper))
    np.testing.assert_allclose(np.asarray(sp.to_physical(jnp.zeros(2))), [2650.0, 3.5e5], rtol=1e-14)
    # the design's value is the sigmoid's: u = logit((x - lo) / (hi - lo)) by hand
    p = (1388.9 - 300.0) / 4700.0
    assert float(sp.to_unconstrained(x)[0]) == pytest.approx(np.log(p / (1 - p)), rel=1e-13)


def jax_vmap_physical(space, u):
    import jax

    return jax.vmap(space.to_physical)(u)


def test_cvar_against_brute_force():
    rng = np.random.default_rng(1)
    v = rng.normal(size=20)
    desc = np.sort(v)[::-1]
    # integer tail size: mean of the worst k by sorting
    for alpha, k in ((0.75, 5), (0.5, 10), (0.95, 1)):
        assert float(cvar(jnp.asarray(v), alpha)) == pytest.approx(desc[:k].mean(), rel=1e-13)
    assert float(cvar(jnp.asarray(v), 0.0)) == pytest.approx(v.mean(), rel=1e-13)
    # any level: Rockafellar-Uryasev min_t t + E[(X - t)+]/(1 - alpha), piecewise linear and convex
    # in t, so the minimum is at a sample: brute force over the samples
    for alpha in (0.1, 0.33, 0.62, 0.9, 0.97):
        ru = min(t + np.mean(np.maximum(v - t, 0.0)) / (1 - alpha) for t in v)
        assert float(cvar(jnp.asarray(v), alpha)) == pytest.approx(ru, rel=1e-12, abs=1e-13)
        width = 0.05
        smooth = float(smooth_cvar(jnp.asarray(v), alpha, width))
        # softplus >= hinge and exceeds it by at most width log 2
        assert ru - 1e-12 <= smooth <= ru + width * np.log(2) / (1 - alpha) + 1e-12
        fine = float(smooth_cvar(jnp.asarray(v), alpha, 1e-4))
        assert fine == pytest.approx(ru, abs=1e-4 * np.log(2) / (1 - alpha) + 1e-12)


def test_smooth_cvar_gradient_is_the_envelope_gradient():
    """d smooth_cvar / dX = sigmoid((X - t*)/w) / (n (1 - alpha)) (envelope theorem); check against
    central differences of the value (the bisection itself is not differentiated)."""
    import jax

    rng = np.random.default_rng(2)
    v = jnp.asarray(rng.normal(size=12))
    alpha, width = 0.7, 0.1
    g = np.asarray(jax.grad(lambda x: smooth_cvar(x, alpha, width))(v))
    h = 1e-6
    fd = np.array(
        [
            (float(smooth_cvar(v.at[i].add(h), alpha, width)) - float(smooth_cvar(v.at[i].add(-h), alpha, width))) / (2 * h)
            for i in range(12)
        ]
    )
    np.testing.assert_allclose(g, fd, atol=1e-7)
    assert g.sum() == pytest.approx(1.0, rel=1e-9)  # weights of a mean: sum to one


def test_a_few_adam_steps_decrease_the_objective(problem, at_paper):
    x0, _, j0, _, _ = at_paper
    hist = optimise(problem, x0, steps=3, learning_rate=0.1)
    assert hist.objective.shape == (4,) and hist.x.shape == (4, 2)
    assert hist.objective[0] == pytest.approx(j0, rel=1e-12)  # same start, same compiled objective
    assert np.all(np.diff(hist.objective) < 0.0), hist.objective
    # deterministic: the same run again gives the same history
    again = optimise(problem, x0, steps=1, learning_rate=0.1)
    np.testing.assert_array_equal(again.x, hist.x[:2])


def test_cli_json(problem, at_paper, capsys):
    """``jaxcable design --json`` reports before/after with hard and smooth criteria; its "before"
    block agrees with the fixture's batch evaluated directly (same problem, same compiled objective)."""
    rc = design_main(CLI_ARGS + ["--steps", "2", "--json"])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert out["variables"] == ["m_w", "F_f"] and out["n"] == 4
    _, _, j0, _, aux = at_paper
    before = out["before"]
    assert before["objective"] == pytest.approx(j0, rel=1e-12)
    limits = {"z_max_m": 10.0, "a_max_g": 5.0, "sigma_max_mpa": 800.0}
    ok = np.ones(4, bool)
    for key, limit in limits.items():
        hard, smooth = np.asarray(aux["hard"][key]), np.asarray(aux["smooth"][key])
        assert before["criteria"]["hard"][key]["worst"] == pytest.approx(hard.max(), rel=1e-12)
        assert before["criteria"]["hard"][key]["mean"] == pytest.approx(hard.mean(), rel=1e-12)
        assert before["criteria"]["smooth"][key]["worst"] == pytest.approx(smooth.max(), rel=1e-12)
        assert before["criteria"]["hard"][key]["margin"] == pytest.approx(1.0 - hard.max() / limit, rel=1e-12)
        ok &= hard < limit
    # a case lands when it also ran to completion: solved and stopped within t_end
    ok &= np.asarray(aux["completed"], dtype=bool)
    assert before["criteria"]["success_rate"] == pytest.approx(ok.mean())
    # "after" is the best point of the history it prints: the lowest objective among the steps
    # with the highest success rate on the batch
    hist = np.asarray(out["history"]["objective"])
    rate = np.asarray(out["history"]["success_rate"])
    assert len(hist) == 3
    top = np.nonzero(rate == rate.max())[0]
    best = int(top[np.argmin(hist[top])])
    assert out["best_step"] == best
    assert out["after"]["objective"] == pytest.approx(hist[best], rel=1e-12)
    assert out["after"]["criteria"]["success_rate"] == pytest.approx(rate.max())
    # and what the optimiser reached: the lowest objective of the history, with its design
    low = out["lowest_objective"]
    assert low["step"] == int(np.argmin(hist)) and low["objective"] == hist.min()
    assert low["success_rate"] == rate[low["step"]] and list(low["design"]) == ["m_w", "F_f"]


def test_bad_input_gets_clear_errors(capsys):
    with pytest.raises(ValueError, match="design variable 'm_x'"):
        design_space("m_w,m_x")
    with pytest.raises(ValueError, match="bounds of F_f are inverted"):
        design_space("F_f", bounds={"F_f": (4e5, 2e5)})
    with pytest.raises(ValueError, match="lower bound of m_w must be positive"):
        design_space("m_w", bounds={"m_w": (-10.0, 100.0)})
    with pytest.raises(ValueError, match="repeated"):
        design_space("m_w,m_w")
    sp = design_space("m_w,F_f")
    with pytest.raises(ValueError, match="m_w must be in"):
        sp.to_unconstrained(jnp.array([-5.0, 3e5]))  # a negative counterweight mass
    with pytest.raises(ValueError, match="needs phase='full'"):
        design_problem("m_w,a_p", n=2, phase="passive")
    with pytest.raises(ValueError, match="fidelity 'ale'"):
        design_problem("m_w,a_p", n=2, fidelity="ale")
    with pytest.raises(ValueError, match="gradient"):
        design_problem("m_w", n=2, gradient="backward")
    with pytest.raises(ValueError, match="checkpoints"):
        design_problem("m_w", n=2, gradient="reverse", checkpoints=0)
    assert default_phase("m_w,F_f") == "passive" and default_phase("F_f,a_p") == "full"
    with pytest.raises(ValueError, match="alpha"):
        ObjectiveWeights(alpha=1.0)
    with pytest.raises(ValueError, match="tail_criterion"):
        ObjectiveWeights(tail_criterion="median")
    with pytest.raises(ValueError, match="penalty"):
        ObjectiveWeights(penalty=(1.0, -1.0, 1.0))
    with pytest.raises(ValueError, match="n must be a positive integer"):
        design_problem("m_w", n=0)
    assert design_main(["--vars", "m_w,a_p", "--phase", "passive"]) == 2
    assert design_main(["--alpha", "1.5", "--n", "2"]) == 2  # CVaR level outside [0, 1)
    assert design_main(["--margin", "-0.1", "--n", "2"]) == 2
    assert "needs phase='full'" in capsys.readouterr().err
    assert design_main(["--vars", "m_w", "--start", "m_w=-3"]) == 2
    assert "m_w must be in" in capsys.readouterr().err


@pytest.mark.slow
def test_reverse_mode_matches_forward_mode(problem, at_paper, central_differences):
    """RecursiveCheckpointAdjoint + grad against ForwardMode + jacfwd: the same objective and its
    gradient, up to what the adaptive solve determines.

    The two modes trace the solve into different XLA programs (jacfwd carries the tangents along the
    forward solve, reverse mode's forward pass stores checkpoints), whose primal arithmetic rounds
    differently. Where an accept/reject decision of the step-size controller sits at its threshold,
    the round-off flips it, and from there the two take different step sequences (measured on a
    2-core AMD EPYC: 995, 837, 912, 1051 steps forward, 996, 841, 908, 1051 reverse; J 1.3e-7 and
    dJ/dm_w 4.9e-4 apart). So the bounds below follow from the solver's error control, not from a
    measured gap."""
    rev = design_problem("m_w,F_f", gradient="reverse", **SETTINGS)
    x0, u0, j0, g_fwd, aux_fwd = at_paper
    j, g, aux_rev = objective_and_grad(rev, u0)
    assert np.all(np.asarray(aux_rev["status"]) == 0)
    # J: every accepted step's local error estimate is below atol + rtol |y| = rtol (1 + |y|) (atol =
    # rtol here), a relative error of about rtol; on this dissipative arrest (brake friction, cable
    # damping) errors do not grow, so a solve's global error is at most the sum of its local errors,
    # N rtol after N steps. The two solves agree until a flip and each keeps that bound after it, so
    # the criteria (soft maxima of the height, acceleration and cable stress histories) of the two
    # differ by at most 2 N rtol relatively, and J by kappa times that, kappa = sum |c dJ/dc| / |J|
    # its relative condition number in the criteria c (5.3 here: the squared penalties amplify).
    # Bound: 1.1e-4 relative here; a wrong objective in either mode is off by far more.
    n_steps = max(int(np.max(np.asarray(aux_fwd["num_steps"]))), int(np.max(np.asarray(aux_rev["num_steps"]))))
    smooth = {k: jnp.asarray(v) for k, v in aux_fwd["smooth"].items()}
    dj_dc = jax.grad(lambda c: objective_terms(problem, aux_fwd["x"], c)["total"])(smooth)
    kappa = sum(float(jnp.sum(jnp.abs(dj_dc[k] * smooth[k]))) for k in smooth) / abs(j0)
    assert abs(float(j) - j0) <= 2 * n_steps * SETTINGS["rtol"] * kappa * abs(j0)
    # dJ/du: each mode is the exact derivative of its own discrete solve, so after a flip they are
    # two derivatives of two discretisations, each as close to dJ/dx as central differences of J
    # resolve it (FD_RTOL, derived above); reverse mode against them, and hence against forward
    # mode within 2 FD_RTOL (a wrong reverse pass is off by factors)
    g_x = _physical_gradient(rev, x0, g)
    np.testing.assert_allclose(g_x, central_differences, rtol=FD_RTOL)
    np.testing.assert_allclose(np.asarray(g), g_fwd, rtol=2 * FD_RTOL)


def _full_problem_without_simulating(**weights):
    """A phase-full problem built by hand (no capture-reference computation, nothing simulated)."""
    from jaxcable.arresting.buffer import BufferDevice
    from jaxcable.arresting.layout import ArrestingLayout
    from jaxcable.arresting.uncertainty import captures_from_samples, halton_samples

    samples = halton_samples(3, scenario="II", phase="full")
    return DesignProblem(
        space=design_space("m_w,a_p"),
        captures=captures_from_samples(samples),
        buffer=BufferDevice(),
        layout=ArrestingLayout(),
        weights=ObjectiveWeights(**weights),
        conditions={k: jnp.asarray(samples[k]) for k in CONDITIONS},
        capture_reference_m=1.4,
        tracking_tolerance_m=1.0,
        phase="full",
    )


def test_two_phase_objective_terms_by_hand():
    """The tracking-phase criteria enter the expected cost and the penalties as documented:
    r_capture = 1 - margin / reference, r_tracking = error / tolerance; checked against a NumPy
    evaluation of the formula on made-up per-case criteria (a miss, an edge case, a good one)."""
    problem = _full_problem_without_simulating(tail=0.0)
    smooth = dict(
        z_max_m=jnp.array([9.0, 10.5, 8.0]),
        a_max_g=jnp.array([4.0, 6.0, 5.5]),
        sigma_max_mpa=jnp.array([700.0, 820.0, 600.0]),
        capture_margin_m=jnp.array([-0.2, 0.7, 1.2]),
        tracking_error_m=jnp.array([1.3, 0.4, 0.1]),
    )
    terms = objective_terms(problem, jnp.array([1000.0, 3.0]), smooth)
    r = np.stack(
        [
            np.asarray(smooth["z_max_m"]) / 10.0,
            np.asarray(smooth["a_max_g"]) / 5.0,
            np.asarray(smooth["sigma_max_mpa"]) / 800.0,
            1.0 - np.asarray(smooth["capture_margin_m"]) / 1.4,
            np.asarray(smooth["tracking_error_m"]) / 1.0,
        ],
        axis=1,
    )
    w = np.array([1 / 3, 1 / 3, 1 / 3, 0.25, 0.25])
    assert float(terms["expected"]) == pytest.approx(np.mean(r @ w), rel=1e-13)
    penalty = np.sum(100.0 * np.mean(np.maximum(r - 1.0, 0.0) ** 2, axis=0))
    assert float(terms["penalty"]) == pytest.approx(penalty, rel=1e-13)
    # the miss (margin -0.2 m) and the 1.3 m tracking error are violations of their own
    assert np.all(r[0, 3:] > 1.0)
    # the tail can be taken of a tracking-phase criterion: CVaR of r_capture
    tail = objective_terms(_full_problem_without_simulating(tail_criterion="capture_margin", tail_form="exact",
                                                            alpha=2.0 / 3.0), jnp.array([1000.0, 3.0]), smooth)["tail"]  # fmt: skip
    assert float(tail) == pytest.approx(r[:, 3].max(), rel=1e-13)


def test_success_rate_counts_only_completed_landings():
    """A case whose criteria are all within their limits but whose run did not complete (the solve
    failed, or the rocket had not stopped by t_end) is not a success; the per-criterion rates still
    count it (made-up per-case criteria, no simulation)."""
    from jaxcable.arresting.design_objective import criteria_summary, history_record

    problem = _full_problem_without_simulating(tail=0.0)
    hard = dict(
        z_max_m=jnp.array([9.0, 9.0, 9.0, 11.0]),
        a_max_g=jnp.array([4.0, 4.0, 4.0, 4.0]),
        sigma_max_mpa=jnp.array([700.0, 700.0, 700.0, 700.0]),
        capture_margin_m=jnp.array([0.5, 0.5, 0.5, 0.5]),
        tracking_error_m=jnp.array([0.1, 0.1, 0.1, 0.1]),
    )
    aux = dict(hard=hard, smooth=hard, completed=np.array([True, False, True, True]),
               status=np.zeros(4, int), num_steps=np.ones(4, int))  # fmt: skip
    summary = criteria_summary(problem, aux)
    assert summary["success_rate"] == 0.5  # case 1 did not complete, case 3 is over z_max
    assert summary["success_rate_per_criterion"]["z_max_m"] == 0.75
    assert history_record(problem)(aux)[1] == 0.5


FULL_SETTINGS = dict(n=2, scenario="III", t_end_s=0.5, rtol=1e-8, atol=1e-8)
FULL_CLI = ["--vars", "m_w,F_f,a_p", "--n", "2", "--scenario", "III", "--t-end", "0.5", "--rtol", "1e-8"]


@pytest.mark.slow
def test_two_phase_design_gradient_and_cli(capsys):
    """dJ/d(m_w, F_f, a_p) of the two-phase objective (tracking with the capture event, then the
    passive phase; forward mode) against central differences of the same objective, in float64;
    then ``jaxcable design --vars m_w,F_f,a_p`` on the same (compiled) problem.

    Scenario III (the shortest tracking, 5 s), 2 cases, 0.5 s after capture. The tracking phase
    runs at two_phase.py's fixed rtol 1e-6, so differences are noisy at the 1e-3 level when a step
    changes (two_phase tests: h = 1e-2 on a_p, 1 %); steps 0.5-1 % of each variable."""
    problem = design_problem("m_w,F_f,a_p", **FULL_SETTINGS)
    assert problem.phase == "full" and problem.criteria_names[3:] == ("capture_margin_m", "tracking_error_m")
    # the paper's design: section II.B m_w, F_f and Table 4's a_p = 6 for scenario III
    x0 = np.asarray(paper_start(problem))
    assert x0[2] == 6.0
    u0 = problem.space.to_unconstrained(jnp.asarray(x0))
    j0, g_u, aux = objective_and_grad(problem, u0)
    j0, g_u = float(j0), np.asarray(g_u)
    assert np.all(np.asarray(aux["status"]) == 0), np.asarray(aux["status"])
    lo, hi = np.asarray(problem.space.lower), np.asarray(problem.space.upper)
    g_x = g_u / ((x0 - lo) * (hi - x0) / (hi - lo))
    steps = np.array([10.0, 2.0e3, 0.05])
    for i, name in enumerate(problem.space.names):
        e = np.zeros(3)
        e[i] = steps[i]
        fd = (_objective_at(problem, x0 + e) - _objective_at(problem, x0 - e)) / (2 * steps[i])
        # 1 %: the two_phase tests' tolerance for the same tracking-phase noise (see above)
        assert g_x[i] == pytest.approx(fd, rel=1e-2), (name, g_x[i], fd)
        assert abs(g_x[i]) > 0.0
    rc = design_main(FULL_CLI + ["--steps", "1", "--json"])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert out["phase"] == "full" and out["variables"] == ["m_w", "F_f", "a_p"]
    assert out["before"]["objective"] == pytest.approx(j0, rel=1e-12)
    hard = out["before"]["criteria"]["hard"]
    assert hard["capture_margin_m"]["worst"] == pytest.approx(float(np.min(np.asarray(aux["hard"]["capture_margin_m"]))), rel=1e-12)
    assert set(hard) == {"z_max_m", "a_max_g", "sigma_max_mpa", "capture_margin_m", "tracking_error_m"}


def test_cable_damping_reaches_the_passive_scene():
    """The modelling parameter ``cable_damping_s`` (beta, not given in the paper) is passed to the
    cables of every case's scene (no solve: the scene is only built)."""
    from jaxcable.arresting.calibration import CALIBRATED_CABLE_DAMPING_S
    from jaxcable.arresting.design import design_scene

    p = design_problem("m_w,F_f", n=2, cable_damping_s=3e-3)
    cap = jax.tree_util.tree_map(lambda a: a[0], p.captures)
    scene = design_scene(p, cap, paper_start(p))
    assert float(scene.cables.damping_s) == pytest.approx(3e-3)
    assert design_problem("m_w,F_f", n=2).cable_damping_s == pytest.approx(CALIBRATED_CABLE_DAMPING_S)


def test_brake_profile_gradient_matches_central_differences():
    """The brake profile's factors (b0 .. b3, jaxcable.arresting.buffer) as design variables: the
    forward-mode gradient through the solve and the knot interpolation against central differences
    (measured agreement 0.03-0.3 %; the factor of the last knot, which only the largest rises reach,
    has a gradient ~1e3 x smaller and is checked in absolute terms)."""
    pr = design_problem("m_w,profile:4", n=2, t_end_s=1.0, rtol=1e-8, atol=1e-8)
    assert pr.space.names == ("m_w", "b0", "b1", "b2", "b3")
    x0 = paper_start(pr)
    np.testing.assert_allclose(np.asarray(x0)[1:], 1.0)  # the paper's constant brake
    x0 = np.asarray(x0.at[2].set(1.3).at[3].set(0.8))
    j, g_u, aux = objective_and_grad(pr, pr.space.to_unconstrained(jnp.asarray(x0)))
    assert np.all(np.asarray(aux["status"]) == 0)
    lo, hi = np.asarray(pr.space.lower), np.asarray(pr.space.upper)
    g_x = np.asarray(g_u) / ((x0 - lo) * (hi - x0) / (hi - lo))
    scale = np.max(np.abs(g_x[1:]))
    for i in (1, 2, 3, 4):
        e = np.zeros(5)
        e[i] = 0.01
        fd = (_objective_at(pr, x0 + e) - _objective_at(pr, x0 - e)) / 0.02
        assert g_x[i] == pytest.approx(fd, rel=5e-3, abs=5e-3 * scale), (pr.space.names[i], g_x[i], fd)
    assert abs(g_x[1]) > 1.0  # the first knots carry the arrest


def test_brake_profile_variables_are_checked():
    assert design_space("m_w,profile:3").names == ("m_w", "b0", "b1", "b2")
    with pytest.raises(ValueError, match="no gaps"):
        design_problem("b0,b2", n=2)
    with pytest.raises(ValueError, match="K >= 2"):
        design_problem("m_w,b0", n=2)
    with pytest.raises(ValueError, match="profile:K"):
        design_space("profile:x")
    with pytest.raises(ValueError, match="at most 16"):
        design_space("profile:17")


def test_lbfgs_minimise_converges_on_an_ill_conditioned_quadratic():
    """L-BFGS (optax direction, host line search) on a quadratic in the physical variables with a
    condition number ~1e3 in u: it reaches the known minimiser in far fewer evaluations than adam
    needs steps, every evaluation is a history row, and the objective never increases between
    accepted points (Armijo)."""
    from jaxcable.studies.optimise import lbfgs_minimise, optax_minimise

    sp = design_space("m_w,F_f")
    x_star = jnp.array([1000.0, 3.5e5])
    u_star = sp.to_unconstrained(x_star)
    scale = jnp.array([1.0, 1e3])

    @jax.jit
    def vg(u):
        j, g = jax.value_and_grad(lambda v: jnp.sum(scale * (v - u_star) ** 2))(u)
        return j, g, dict(x=sp.to_physical(u))

    x0 = jnp.array([2000.0, 2.5e5])
    accepted = []
    h = lbfgs_minimise(sp, vg, x0, max_evaluations=40, callback=lambda i, j, x, aux: accepted.append(j))
    assert len(h.objective) <= 40
    np.testing.assert_allclose(h.x[h.best], np.asarray(x_star), rtol=1e-6)
    assert np.all(np.diff(accepted) <= 0.0)
    adam = optax_minimise(sp, vg, x0, steps=40, learning_rate=0.1)
    assert h.objective.min() < 1e-6 * adam.objective.min()
    with pytest.raises(ValueError, match="max_evaluations"):
        lbfgs_minimise(sp, vg, x0, max_evaluations=0)


def test_cli_lbfgs_improves_the_objective(problem, at_paper, capsys):
    """``jaxcable design --optimizer lbfgs``: same problem as the fixture (compiled once), three
    evaluations in all; the reported best objective is below the start's."""
    rc = design_main(CLI_ARGS + ["--steps", "2", "--optimizer", "lbfgs", "--json"])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert out["optimizer"] == "lbfgs"
    assert len(out["history"]["objective"]) == 3
    assert out["before"]["objective"] == pytest.approx(at_paper[2], rel=1e-12)
    assert min(out["history"]["objective"]) < out["before"]["objective"]
