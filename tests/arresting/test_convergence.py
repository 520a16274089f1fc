"""Convergence of the landing criteria (slow tier): the design case at the ale level over its stroke
(1 s), with the scenes' defaults (calibrated damping, the hook as a sliding node on the ale level's
mesh, 80 span elements with 16 fine), against a twice stiffer hook ring, a ten times tighter
tolerance and a twice finer mesh.

The goals are those of ``experiments/convergence_landing.py`` (``docs/arresting_validation.md``):
z_max within 1%, the criteria a_max and sigma_max (CFC 60) within 3%. The full study (both levels,
the deviated case, every knob) is the script's; this is its sentinel. On the mesh shared with the
full level before (64 span elements, 32 fine) the ale level's a_max missed the goal: 5.36 g against
5.15-5.18 g on 128-256 elements; on its own mesh it reads 5.21 g.
"""

import equinox as eqx
import pytest

from jaxcable.arresting.landing import run_landing
from jaxcable.arresting.passive import LEVEL_CABLE_MESH, scene_contact_law

T_END = 1.0  # s: the stroke (the 1-DOF stop is at 0.77 s)
GOALS = {"z_max_m": 0.01, "a_max_g": 0.03, "sigma_max_mpa": 0.03}


@pytest.mark.slow
def test_design_case_criteria_converge_in_mesh_contact_and_tolerance():
    law = scene_contact_law()
    variants = {
        "contact stiffness x 2": {"contact": eqx.tree_at(lambda c: c.k, law, 2.0 * law.k)},
        "rtol / 10": {"rtol": 1e-6, "atol": 1e-6},
        "mesh x 2": dict(zip(("n_span_elements", "n_fine"), (2 * n for n in LEVEL_CABLE_MESH["ale"]))),
    }
    base = run_landing("ale", t_end_s=T_END).outputs
    assert base["solver_status"] == "successful"
    for name, kw in variants.items():
        o = run_landing("ale", t_end_s=T_END, **kw).outputs
        assert o["solver_status"] == "successful", name
        for key, goal in GOALS.items():
            assert o[key] == pytest.approx(base[key], rel=goal), (name, key, o[key], base[key])
