"""Convergence of the landing criteria (slow tier): the design case at the ale level over its stroke
(1 s), with the scenes' defaults (calibrated damping, 32 span elements), against a twice stiffer
hook-cable contact, a ten times tighter tolerance and a twice finer mesh.

The goals are those of ``experiments/convergence_landing.py`` (``docs/arresting_validation.md``):
z_max within 1%, the criteria a_max and sigma_max (CFC 60) within 3%. The full study (both levels,
the deviated case, every knob) is the script's; this is its sentinel. Over a shorter window the
criteria are not converged: over the first 0.45 s a_max is 4.96 g on 32 elements and 4.46 g on 64
(measured); the landing's a_max is the later peak (0.6 s), which both meshes put within 1.1%.
"""

import equinox as eqx
import pytest

from jaxcable.arresting.landing import run_landing
from jaxcable.arresting.passive import (
    DEFAULT_FINE_ELEMENTS,
    DEFAULT_SPAN_ELEMENTS,
    scene_contact_law,
)

T_END = 1.0  # s: the stroke (the 1-DOF stop is at 0.77 s)
GOALS = {"z_max_m": 0.01, "a_max_g": 0.03, "sigma_max_mpa": 0.03}


@pytest.mark.slow
def test_design_case_criteria_converge_in_mesh_contact_and_tolerance():
    law = scene_contact_law()
    variants = {
        "contact stiffness x 2": {"contact": eqx.tree_at(lambda c: c.k, law, 2.0 * law.k)},
        "rtol / 10": {"rtol": 1e-6, "atol": 1e-6},
        "mesh x 2": {"n_span_elements": 2 * DEFAULT_SPAN_ELEMENTS, "n_fine": 2 * DEFAULT_FINE_ELEMENTS},
    }
    base = run_landing("ale", t_end_s=T_END).outputs
    assert base["solver_status"] == "successful"
    for name, kw in variants.items():
        o = run_landing("ale", t_end_s=T_END, **kw).outputs
        assert o["solver_status"] == "successful", name
        for key, goal in GOALS.items():
            assert o[key] == pytest.approx(base[key], rel=goal), (name, key, o[key], base[key])
