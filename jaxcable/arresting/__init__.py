"""Arresting-cable landing (Zhang et al. 2021): the passive-deceleration phase at four fidelities.

* ``one_dof``: the rigid-cable, vertical, central-landing 1-DOF design model of Sec. II.B
  (eqs. 12-24, Fig. 6, Table 1);
* ``cables``: a cable over pulleys meshed with ALE elements, mesh rules eliminated (eqs 26-34);
* ``buffer``: counterweight, smooth stick-slip brake, moving pulley group;
* ``contact``: hook-cable Hertz/Coulomb contact (Appendix);
* ``layout``, ``cable_sets``, ``passive``: geometry, the four cables as one component (massless or
  ALE), and the scene at levels ``1dof``, ``rigid``, ``ale``, ``full``;
* ``landing``: :func:`run_landing`, the entry point of ``jaxcable land``.
"""

from jaxcable.arresting.buffer import BufferDevice
from jaxcable.arresting.cable_sets import AleCables, HookPoints, MasslessCables
from jaxcable.arresting.cables import CableCoords, CableRoute, CableState, CableSubsystem
from jaxcable.components.contact import ContactLaw, capsule_contact, pairwise_contacts
from jaxcable.arresting.landing import LandingRun, plot_landing, report_landing, run_landing
from jaxcable.arresting.layout import ArrestingLayout, CaptureState
from jaxcable.arresting.passive import (
    FIDELITY_LEVELS,
    LandingCriteria,
    PassiveLandingScene,
    SmoothingWidths,
    landing_outputs,
    passive_landing_scene,
    smooth_landing_outputs,
)

from jaxcable.arresting.one_dof import (
    G_UNIT,
    N_BUFFERS,
    N_LEGS,
    DesignCriteria,
    OneDofParams,
    OneDofSolution,
    accel_bar,
    acceleration_bound_end_of_stroke,
    allowed_tension_bar,
    buffer_from_groups,
    design_groups,
    energy_bar,
    friction_group_for_stop,
    m_t_bar_bounds,
    paper_design,
    params_groups,
    simulate_one_dof,
    speed_sq_bar,
    stop_distance_bar,
    stroke_peaks,
    tension_bar,
    v0_bar,
)

from jaxcable.arresting import design  # noqa: F401  (registers the "arresting" design problem)
from jaxcable.arresting import sweep, two_phase  # noqa: F401  (register the sweeps' case functions)
from jaxcable.arresting import bench_cases  # noqa: F401  (registers the bench cases)

__all__ = [
    "FIDELITY_LEVELS",
    "AleCables",
    "ArrestingLayout",
    "BufferDevice",
    "CableCoords",
    "CableRoute",
    "CableState",
    "CableSubsystem",
    "CaptureState",
    "ContactLaw",
    "HookPoints",
    "LandingCriteria",
    "LandingRun",
    "MasslessCables",
    "PassiveLandingScene",
    "SmoothingWidths",
    "capsule_contact",
    "landing_outputs",
    "pairwise_contacts",
    "passive_landing_scene",
    "plot_landing",
    "report_landing",
    "run_landing",
    "smooth_landing_outputs",
    "G_UNIT",
    "N_BUFFERS",
    "N_LEGS",
    "DesignCriteria",
    "OneDofParams",
    "OneDofSolution",
    "accel_bar",
    "acceleration_bound_end_of_stroke",
    "allowed_tension_bar",
    "buffer_from_groups",
    "design_groups",
    "energy_bar",
    "friction_group_for_stop",
    "m_t_bar_bounds",
    "paper_design",
    "params_groups",
    "simulate_one_dof",
    "speed_sq_bar",
    "stop_distance_bar",
    "stroke_peaks",
    "tension_bar",
    "v0_bar",
]
