"""Design at the ale level: the batch's scenes are meshed on the host by ``design_problem`` and the
design's buffer is swapped into them inside the traced objective.

Checked against things computed another way: each case's hard criteria against an independent
``run_landing`` of the same capture and buffer, and the forward-mode gradient through the ALE
solve against central finite differences.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxcable.arresting.landing import run_landing
from jaxcable.arresting.passive import LIGHT_CABLE_DAMPING_S
from jaxcable.arresting.design import CRITERIA, DesignProblem, design_buffer, design_problem, objective_and_grad, objective_value, paper_start

T_END = 0.05  # s: the hooks' impact on the cables and the counterweights' start
# a coarse mesh: the path is under test, not the peaks; the capsule contact, where a lightly damped
# cable runs explicit Bosh3 (with the hook as a sliding node every damping runs the W-method)
MESH = {"n_span_elements": 16, "n_fine": 8, "hook_contact": "capsule"}


@pytest.fixture(scope="module")
def problem():
    # a lightly damped cable: explicit Bosh3, whose compile and 0.05 s cost a third of the W-method's
    # at the default damping (measured 3.4 min for this file on the W-method); the gradient test
    # below runs the default damping on the W-method
    return design_problem(
        "m_w,F_f", n=2, fidelity="ale", t_end_s=T_END, cable_damping_s=LIGHT_CABLE_DAMPING_S, scene_options=MESH
    )


# slow tier: 95 s on 2 cores; the design objective's vmapped batch against one vmap is also checked
# in tests/test_design_chunk.py (slow), and the sweeps' rows against single landings in the default tier
@pytest.mark.slow
def test_ale_batch_matches_independent_landings(problem):
    x = paper_start(problem)
    _, aux = objective_value(problem, problem.space.to_unconstrained(x))
    assert np.all(np.asarray(aux["status"]) == 0)
    for j in range(problem.n_cases):
        capture = jax.tree_util.tree_map(lambda v: v[j], problem.captures)
        ref = run_landing(
            "ale", capture, buffer=design_buffer(problem, x), t_end_s=T_END, cable_damping_s=LIGHT_CABLE_DAMPING_S, **MESH
        )
        for key in CRITERIA:
            # the design's solve uses the checkpointed loop, run_landing the plain one: the same
            # solver and tolerance (Bosh3, 1e-4), different round-off, so a step or two may differ
            # (measured: 1e-6 relative on sigma_max); the bound is the level's tolerance
            np.testing.assert_allclose(float(aux["hard"][key][j]), ref.outputs[key], rtol=1e-4)
    # the design is in the scenes: a heavier counterweight changes the outcome
    heavier = x.at[0].set(3000.0)
    _, aux2 = objective_value(problem, problem.space.to_unconstrained(heavier))
    assert not np.allclose(np.asarray(aux2["hard"]["sigma_max_mpa"]), np.asarray(aux["hard"]["sigma_max_mpa"]))


@pytest.mark.slow
@pytest.mark.parametrize("fidelity", ["ale", "full"])
def test_ale_gradient_matches_central_differences(fidelity):
    # one capture, 0.15 s (by 0.05 s the buffer has barely moved: dJ/du ~ 1e-4 against J ~ 1, too
    # small for the differences to resolve), tight tolerance so that the differences resolve the
    # derivative; measured at the ale level: 9.5e-7 and 2.7e-6 relative at h = 1e-3 (1.6e-5, 2.2e-5
    # at h = 1e-2). The full level adds the flexible rocket and the hinged, sprung hooks.
    p = design_problem(
        "m_w,F_f", n=1, fidelity=fidelity, t_end_s=0.15, rtol=1e-7, atol=1e-7, cable_damping_s=LIGHT_CABLE_DAMPING_S,
        scene_options=MESH,
    )  # fmt: skip
    u = p.space.to_unconstrained(paper_start(p))
    j, g, _ = objective_and_grad(p, u)
    assert np.all(np.isfinite(np.asarray(g))) and np.all(np.abs(np.asarray(g)) > 0)
    h = 1e-3
    for i in range(2):
        e = jnp.zeros(2).at[i].set(h)
        fd = (float(objective_value(p, u + e)[0]) - float(objective_value(p, u - e)[0])) / (2 * h)
        assert float(g[i]) == pytest.approx(fd, rel=1e-4)


def test_ale_problem_without_scenes_is_refused(problem):
    with pytest.raises(ValueError, match="host"):
        DesignProblem(space=problem.space, captures=problem.captures, buffer=problem.buffer, layout=problem.layout, fidelity="ale")


# slow tier: 70-100 s on 2 cores (the ale design problem compiled once for this test alone)
@pytest.mark.slow
def test_ale_cases_report_whether_the_contact_derivative_is_exact(problem):
    """Each ale case reports whether at most ``contact_tangent_pairs`` contact pairs touched (the
    sparse contact derivative is exact then); the optimisers' history warns when one did not."""
    import dataclasses
    import warnings

    from jaxcable.arresting.design import history_record
    from jaxcable.studies.optimise import HistoryRows

    x = paper_start(problem)
    u = problem.space.to_unconstrained(x)
    _, aux = objective_value(problem, u)
    assert np.all(np.asarray(aux["contact_tangent_exact"]))  # 48 carried, 8-16 touch
    cables = dataclasses.replace(problem.scenes.cables, contact_tangent_pairs=1)
    few = dataclasses.replace(problem, scenes=dataclasses.replace(problem.scenes, cables=cables))
    _, aux_few = objective_value(few, u)
    assert not np.any(np.asarray(aux_few["contact_tangent_exact"]))
    rows = HistoryRows(history_record(problem), problem.criteria_names)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rows.add(1.0, 0.0, aux)  # exact: no warning
    with pytest.warns(RuntimeWarning, match="contact_tangent_pairs"):
        rows.add(1.0, 0.0, aux_few)
