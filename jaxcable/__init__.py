"""jaxcable: a differentiable JAX simulator of rope and cable dynamics for rocket engineering.

Importing jaxcable does not change JAX's precision. The physics is meant for float64: call
``jaxcable.enable_x64()`` first (the command line, experiments and notebooks do).
"""

from ._config import enable_x64
from .scene import AbstractScene
from .simulate import SOLVERS, Result, make_solver, simulate, status_message
from .scenes import line_throwing_scene

__all__ = [
    "AbstractScene",
    "Result",
    "SOLVERS",
    "enable_x64",
    "line_throwing_scene",
    "make_solver",
    "simulate",
    "status_message",
]
__version__ = "0.1.0"
