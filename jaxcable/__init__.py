"""jaxcable: a differentiable JAX simulator of rope and cable dynamics for rocket engineering.

Importing jaxcable does not change JAX's precision. The physics is meant for float64: call
``jaxcable.enable_x64()`` first (the command line, experiments and notebooks do).

Layout: :mod:`jaxcable.core` (scene, simulate, validation), :mod:`jaxcable.components` (rope, ALE
cable, multibody, contact, wind), the two systems :mod:`jaxcable.throw` and :mod:`jaxcable.arresting`,
and :mod:`jaxcable.studies` (sweeps, optimisers, benchmarks).
"""

from jaxcable.core import SOLVERS, AbstractScene, Result, enable_x64, make_solver, simulate, status_message
from jaxcable.core.provenance import __version__
from jaxcable import arresting, throw  # noqa: F401  (each system registers its case functions, design problems and bench cases)
from jaxcable.throw import line_throwing_scene

__all__ = [
    "AbstractScene",
    "Result",
    "SOLVERS",
    "__version__",
    "enable_x64",
    "line_throwing_scene",
    "make_solver",
    "simulate",
    "status_message",
]
