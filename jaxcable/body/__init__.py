"""Rigid bodies: the line-throwing rocket (thrust, burning mass), a rigid multibody engine (Kane's
method with autodiff: quaternions, hinges, massless beams) and the landing rocket with four hooks."""

from .landing_rocket import LandingRocket, LandingRocketParams, flexible_landing_rocket, rigid_landing_rocket
from .multibody import MasslessBeams, MultibodyState, MultibodySystem
from .rocket import PointRocket, paper_rocket

__all__ = [
    "LandingRocket",
    "LandingRocketParams",
    "MasslessBeams",
    "MultibodyState",
    "MultibodySystem",
    "PointRocket",
    "flexible_landing_rocket",
    "paper_rocket",
    "rigid_landing_rocket",
]
