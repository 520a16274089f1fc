"""Rigid bodies: the rocket (thrust, burning mass)."""

from .rocket import PointRocket, paper_rocket

__all__ = ["PointRocket", "paper_rocket"]
