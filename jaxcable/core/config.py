"""Precision control. The physics runs in float64 by default at the package's entry points
(command line, experiments, notebooks call :func:`enable_x64`); importing the library does NOT change
the precision of a user's process. Call ``jaxcable.enable_x64()`` yourself, or
``jaxcable.enable_x64(False)`` to measure float32.
"""

import jax


def enable_x64(enabled: bool = True) -> None:
    """Switch JAX to float64 (``True``) or float32 (``False``) for this process."""
    jax.config.update("jax_enable_x64", bool(enabled))
