"""Test configuration: float64 physics for every test (the package itself never flips it on import)."""

import os

os.environ.setdefault("MPLBACKEND", "Agg")

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)
