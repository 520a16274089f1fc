"""Rope and cable models."""

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
    "ChainKinematics",
    "ChainState",
    "SegmentRope",
    "chain_accelerations",
    "chain_accelerations_dense",
    "kinematics",
    "kinetic_energy",
    "make_rope",
]
