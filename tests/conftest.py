"""Test configuration: float64 physics for every test (the package itself never flips it on import),
and compiled code released after each test module.

Why the release: XLA's CPU backend maps each compiled executable's code into the process in many
small memory mappings, and a process may hold at most ``vm.max_map_count`` of them (65530 by
default on Linux). A pytest-xdist worker runs half the suite's files in one process, and JAX keeps
every executable it compiled: measured here, ``tests/arresting/test_two_phase.py`` alone leaves
17,858 mappings, with ``tests/test_sweep_two_phase.py`` 27,724. Past the limit the process dies of a
segmentation fault in XLA's compilation or execution: seen once in a full run (session 13: a worker
died in ``backend_compile_and_load`` and pytest-xdist then waited forever), and reproduced by
lowering the limit (``sysctl vm.max_map_count=15000``: ``test_two_phase.py`` segfaults in its 9th
test). ``jax.clear_caches()`` drops the executables (17,858 -> 764 mappings); with it after each
module the two files above end at 1,231, and three heavy files pass under a limit of 30,000."""

import gc
import os
import warnings

os.environ.setdefault("MPLBACKEND", "Agg")

import jax  # noqa: E402
import pytest  # noqa: E402

jax.config.update("jax_enable_x64", True)

MAPPINGS_WARNING = 45_000
"""Warn when a test module ends with more memory mappings than this (the kernel's default limit is
65530): that module alone compiles enough to need splitting."""


def _mappings() -> int | None:
    try:
        with open(f"/proc/{os.getpid()}/maps") as f:
            return sum(1 for _ in f)
    except OSError:  # not Linux
        return None


@pytest.fixture(autouse=True, scope="module")
def _release_compiled_code(request):
    yield
    count = _mappings()
    if count is not None and count > MAPPINGS_WARNING:
        warnings.warn(
            f"{request.module.__name__} ended with {count} memory mappings (limit vm.max_map_count, 65530 by "
            "default): compiled code nearly exhausts it",
            stacklevel=1,
        )
    jax.clear_caches()
    gc.collect()
