"""Precision and compilation-cache settings of a process.

Precision: the physics runs in float64 by default at the package's entry points (command line,
experiments, notebooks call :func:`enable_x64`); importing the library does NOT change the
precision of a user's process. Call ``jaxcable.enable_x64()`` yourself, or
``jaxcable.enable_x64(False)`` to measure float32.

Compilation cache: :func:`enable_compilation_cache` turns on JAX's persistent compilation cache, so
that a program XLA compiled once on this machine is read back from disk by the next process instead
of being compiled again. The command line calls it (``jaxcable --no-cache ...`` or
``JAXCABLE_NO_CACHE=1`` leave it off); importing the library does not. The folder is, first found:

1. the ``path`` argument;
2. the environment variable ``JAXCABLE_CACHE_DIR``;
3. ``$XDG_CACHE_HOME/jaxcable/jax``, or ``~/.cache/jaxcable/jax`` when ``XDG_CACHE_HOME`` is unset.

JAX keys each entry by the compiled program, the JAX/jaxlib version, the device and the XLA flags, so
a stale entry is never used, only left behind: delete the folder to reclaim the space (nothing
bounds its size). The folder is trusted code: do not point it at a place others can write to.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import jax

CACHE_DIR_ENV = "JAXCABLE_CACHE_DIR"
"""Environment variable naming the compilation-cache folder."""

NO_CACHE_ENV = "JAXCABLE_NO_CACHE"
"""Environment variable that, set to anything but ``""``, ``0``, ``false`` or ``no``, turns the
compilation cache off."""


def enable_x64(enabled: bool = True) -> None:
    """Switch JAX to float64 (``True``) or float32 (``False``) for this process."""
    jax.config.update("jax_enable_x64", bool(enabled))


def cache_disabled_by_env() -> bool:
    """Whether ``JAXCABLE_NO_CACHE`` asks for no compilation cache."""
    return os.environ.get(NO_CACHE_ENV, "").strip().lower() not in ("", "0", "false", "no")


def default_cache_dir() -> Path:
    """``$JAXCABLE_CACHE_DIR``, else ``$XDG_CACHE_HOME/jaxcable/jax``, else ``~/.cache/jaxcable/jax``."""
    if os.environ.get(CACHE_DIR_ENV):
        return Path(os.environ[CACHE_DIR_ENV]).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "jaxcable" / "jax"


def enable_compilation_cache(path: str | os.PathLike | None = None) -> Path | None:
    """Turn on JAX's persistent compilation cache in ``path`` (default :func:`default_cache_dir`).

    Every compiled program is written, however short its compilation: the thresholds
    ``jax_persistent_cache_min_compile_time_secs`` (JAX's default 1 s) and
    ``jax_persistent_cache_min_entry_size_bytes`` are set to 0 and -1 (no limit), because a
    command's start-up is many compilations, most of them well under a second, and reading one
    back costs less than compiling it. Programs with host callbacks (progress bars, ``jax.debug.print``) are never written by JAX.

    Call it before the first compilation of the process. Returns the folder, or ``None`` when
    ``JAXCABLE_NO_CACHE`` is set or the folder cannot be created (then with a warning, and the
    process simply compiles as without a cache)."""
    if cache_disabled_by_env():
        return None
    folder = Path(path).expanduser() if path is not None else default_cache_dir()
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        warnings.warn(f"compilation cache off: cannot create {folder} ({err})", stacklevel=2)
        return None
    jax.config.update("jax_compilation_cache_dir", str(folder))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", -1)
    return folder


def available_cores() -> int:
    """The CPU cores this process may run on (its affinity mask where the OS has one)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover (macOS, Windows)
        return os.cpu_count() or 1


def use_cpu_devices(count: int | str = "auto") -> int | None:
    """Split the host CPU into ``count`` JAX devices (``"auto"``: one per core this process may use,
    :func:`available_cores`), so that work sharded over the local devices (a sweep's chunks,
    :mod:`jaxcable.studies.sharding`) runs on every core: XLA runs one CPU device's program on
    one core.

    Takes effect only before JAX starts its backends (the first JAX operation of the process;
    importing jaxcable does not start them). Returns the count set, or ``None`` when JAX had started
    already or ``XLA_FLAGS`` names a device count itself (both leave the devices as they are).
    On a GPU host the GPUs stay the default devices; the count applies to the CPU backend only."""
    from jax._src import xla_bridge

    if count == "auto":
        count = available_cores()
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        raise ValueError(f"count must be a positive integer or 'auto', got {count!r}")
    if "xla_force_host_platform_device_count" in os.environ.get("XLA_FLAGS", ""):
        return None
    if xla_bridge.backends_are_initialized():
        return None
    jax.config.update("jax_num_cpu_devices", count)
    return count
