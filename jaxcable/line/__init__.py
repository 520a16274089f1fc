"""Rope and cable models: the finite-segment (Kane) rope and the ALE cable element."""

from .ale import AleCable, AleState, ale_cable_vector_field, cable_energy

from .segments import (
    ChainKinematics,
    ChainState,
    SegmentRope,
    chain_accelerations,
    chain_accelerations_dense,
    kinematics,
    kinetic_energy,
    make_rope,
)

__all__ = [
    "AleCable",
    "AleState",
    "ale_cable_vector_field",
    "cable_energy",
    "ChainKinematics",
    "ChainState",
    "SegmentRope",
    "chain_accelerations",
    "chain_accelerations_dense",
    "kinematics",
    "kinetic_energy",
    "make_rope",
]
