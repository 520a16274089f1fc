"""Physics shared by the systems, each written for one element and lifted to the whole:

* :mod:`~jaxcable.components.rope`: the finite-segment (Kane) rope with payout (line-throwing paper, sec. 3);
* :mod:`~jaxcable.components.ale`: the ALE variable-length cable element (arresting paper, eqs 26-31);
* :mod:`~jaxcable.components.lagrangian_line`: its fast special case with the material coordinates
  fixed (a Lagrangian line, lumped or consistent mass, the mass matrix inverted once per mesh);
* :mod:`~jaxcable.components.multibody`: rigid multibody dynamics (quaternions, hinges, massless beams);
* :mod:`~jaxcable.components.contact`: capsule-capsule contact (Hertz + Hunt-Crossley, Coulomb/STEP friction);
* :mod:`~jaxcable.components.wind`: steady wind, Kaimal gusts and aerodynamic loads on bodies and cables.
"""

from jaxcable.components.ale import AleCable, AleState, ale_cable_vector_field, cable_energy
from jaxcable.components.lagrangian_line import LagrangianLine, LineMesh, LineScene, LineState, line_mesh, uniform_line_mesh
from jaxcable.components.contact import ContactLaw, capsule_contact, pairwise_contacts
from jaxcable.components.multibody import MasslessBeams, MultibodyState, MultibodySystem
from jaxcable.components.rope import (
    ChainKinematics,
    ChainState,
    SegmentRope,
    chain_accelerations,
    chain_accelerations_dense,
    kinematics,
    kinetic_energy,
    make_rope,
)
from jaxcable.components.wind import AeroCoefficients, WindField, rocket_aero_loads

__all__ = [
    "AeroCoefficients",
    "AleCable",
    "AleState",
    "ChainKinematics",
    "ChainState",
    "ContactLaw",
    "LagrangianLine",
    "LineMesh",
    "LineScene",
    "LineState",
    "MasslessBeams",
    "MultibodyState",
    "MultibodySystem",
    "SegmentRope",
    "WindField",
    "ale_cable_vector_field",
    "cable_energy",
    "capsule_contact",
    "chain_accelerations",
    "chain_accelerations_dense",
    "kinematics",
    "kinetic_energy",
    "line_mesh",
    "make_rope",
    "pairwise_contacts",
    "rocket_aero_loads",
    "uniform_line_mesh",
]
