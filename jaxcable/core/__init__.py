"""The core every system builds on: what a scene is, the one ``simulate`` entry point, input
validation, precision and compilation-cache settings, gradient-safe math and provenance."""

from jaxcable.core.config import enable_x64
from jaxcable.core.scene import AbstractScene
from jaxcable.core.simulate import SOLVERS, Result, make_solver, simulate, status_message

__all__ = ["AbstractScene", "Result", "SOLVERS", "enable_x64", "make_solver", "simulate", "status_message"]
