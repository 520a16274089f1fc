"""Test configuration: float64 physics for every test (the package itself never flips it on import),
one on-disk compilation cache for the whole run, and compiled code released when a worker holds too
much of it, the longest test files first, and XLA's backend at optimisation level 0.

**XLA optimisation level.** Most tests compile more than they run (short solves of small scenes),
and compiling is cheaper with XLA's backend (LLVM) at optimisation level 0
(``XLA_FLAGS=--xla_backend_optimization_level=0``). Measured on 2 cores, the machine's other core
busy with the same background job throughout, one process each: ``tests/test_segments.py`` with
``tests/arresting/test_cables.py`` 171 s -> 143 s, ``tests/arresting/test_stiff.py`` with
``tests/test_sweep_two_phase.py`` 399 s -> 340 s; LLVM's expensive passes alone turned off
(``--xla_llvm_disable_expensive_passes=true``): 434 s, no gain. The level changes how fast the
compiled code runs, not what it computes (the suite passes at both, with the same tolerances). The
flag is appended to ``XLA_FLAGS`` for this process and everything it starts (workers, command
lines, notebook kernels), unless ``XLA_FLAGS`` already names a backend optimisation level or
``JAXCABLE_TEST_XLA_OPTIMISE=1`` asks for the default (as users run it). Benchmarks never run
under it (they are scripts in ``experiments/``, not tests).

**Compilation cache.** Every process of a run (the pytest-xdist workers, the command lines the
tests start, the notebooks' kernels) reads and writes one folder of JAX's persistent compilation
cache, so a program compiled once in the run is read back instead of compiled again: by the other
worker, by a command line that runs what a test ran, and after ``jax.clear_caches()`` (below). The
folder is ``$JAXCABLE_TEST_CACHE_DIR`` when set (kept between runs: later runs read it back), else a
new temporary folder that is removed at the end, so that a run starts cold, as on a fresh machine.
``JAXCABLE_NO_CACHE=1`` turns it off. Programs holding host callbacks are never written (JAX's
rule), so a solve through plain ``diffrax.diffeqsolve`` is compiled again each time; the jitted
solves of ``jaxcable.simulate`` are written.

**Memory mappings.** XLA's CPU backend maps each compiled executable's code into the process in
many small memory mappings, and a process may hold at most ``vm.max_map_count`` of them (65530 by
default on Linux). A pytest-xdist worker runs half the suite's files in one process, and JAX keeps
every executable it compiled: ``tests/arresting/test_two_phase.py`` alone leaves 17,858 mappings,
``tests/test_sweep_two_phase.py`` 27,724. Past the limit the process dies of a segmentation fault
in XLA's compilation or execution (seen once in a full run, after which pytest-xdist waited
forever; reproduced with ``sysctl vm.max_map_count=15000``: ``test_two_phase.py`` segfaults in its
9th test). ``jax.clear_caches()`` drops the executables (17,858 -> 764 mappings). It is called after
a test module that leaves the process above ``CLEAR_ABOVE_MAPPINGS``: below that, the next module
(at most ~28,000 more) cannot reach the limit, and it keeps what later modules compile again (the
jitted ``simulate`` of the same scene structure) without tracing it again.

**Order.** ``pytest`` runs one test file per worker at a time (``--dist loadfile``), handing out the
files in collection order (``--no-loadscope-reorder``: pytest-xdist would otherwise order them by
their number of tests, not their cost). The files of ``LONGEST_FIRST`` come first, longest first, so
that the two workers of a 2-core machine finish together instead of one waiting for the other's
last long file."""

import atexit
import gc
import os
import shutil
import tempfile
import warnings

os.environ.setdefault("MPLBACKEND", "Agg")

TEST_XLA_FLAG = "--xla_backend_optimization_level=0"
"""Appended to ``XLA_FLAGS`` before JAX starts its CPU client (module docstring)."""
if "xla_backend_optimization_level" not in os.environ.get("XLA_FLAGS", "") and os.environ.get("JAXCABLE_TEST_XLA_OPTIMISE") != "1":
    os.environ["XLA_FLAGS"] = f"{os.environ.get('XLA_FLAGS', '')} {TEST_XLA_FLAG}".strip()

import jax  # noqa: E402
import pytest  # noqa: E402

jax.config.update("jax_enable_x64", True)

from jaxcable.core.config import CACHE_DIR_ENV, cache_disabled_by_env, enable_compilation_cache  # noqa: E402

TEST_CACHE_ENV = "JAXCABLE_TEST_CACHE_DIR"
"""Environment variable naming the run's compilation-cache folder: set by you to keep the cache
between runs, else by the first pytest process of a run (its xdist workers inherit it)."""

CLEAR_ABOVE_MAPPINGS = 20_000
"""``jax.clear_caches()`` after a test module that leaves more memory mappings than this: the
heaviest module adds ~28,000, so the next one ends below ~48,000 of the 65,530 allowed."""

MAPPINGS_WARNING = 45_000
"""Warn when a test module ends with more memory mappings than this (the kernel's default limit is
65530): that module alone compiles enough to need splitting."""


LONGEST_FIRST = (
    # CPU seconds of each file run alone (-n 0; Intel Xeon 2.5 GHz), longest first
    "tests/test_throw_scene.py",
    "tests/arresting/test_stiff.py",
    "tests/arresting/test_two_phase.py",
    "tests/test_notebooks.py",
    "tests/arresting/test_passive.py",
    "tests/test_simulate.py",
    "tests/test_design_ale.py",
    "tests/test_design.py",
    "tests/test_sweep_two_phase.py",
    "tests/test_sweep.py",
    "tests/test_hard_cases.py",
    "tests/arresting/test_multibody.py",
    "tests/test_contact_tangent.py",
    "tests/test_segments.py",
    "tests/arresting/test_control.py",
    "tests/arresting/test_stiff_limits.py",
)
"""Test files that run first, in this order; every other file follows in collection order."""


def pytest_collection_modifyitems(session, config, items):
    rank = {name: i for i, name in enumerate(LONGEST_FIRST)}
    root = config.rootpath

    def key(item):
        try:
            name = item.path.relative_to(root).as_posix()
        except ValueError:
            name = ""
        return rank.get(name, len(rank))

    items.sort(key=key)  # stable: the order inside a file and among the other files is kept


def _run_cache_folder() -> str | None:
    if cache_disabled_by_env():
        return None
    folder = os.environ.get(TEST_CACHE_ENV)
    if not folder:
        folder = tempfile.mkdtemp(prefix="jaxcable-test-cache-")
        os.environ[TEST_CACHE_ENV] = folder
        atexit.register(shutil.rmtree, folder, ignore_errors=True)  # the process that made it
    return folder


_CACHE = _run_cache_folder()
if _CACHE is not None:
    enable_compilation_cache(_CACHE)
    # the command lines that tests start read and write the same folder (never the user's ~/.cache)
    os.environ[CACHE_DIR_ENV] = _CACHE


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
    if count is None or count > CLEAR_ABOVE_MAPPINGS:
        jax.clear_caches()
        gc.collect()
