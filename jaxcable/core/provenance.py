"""Where a figure came from: machine, JAX version, precision (written next to every benchmark)."""

from __future__ import annotations

import os
import platform

import jax

__version__ = "0.1.0"


def machine_info() -> dict:
    """Machine, processor, core count, JAX version and backend, float64 flag, load average."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    dev = jax.devices()[0]
    return {
        "machine": platform.machine(),
        "processor": cpu,
        "cpu_count": os.cpu_count(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "jax": jax.__version__,
        "jax_backend": f"{dev.platform} ({dev.device_kind})",
        "float64": bool(jax.config.jax_enable_x64),
        "jaxcable": __version__,
        "load_average_1_5_15_min": [round(x, 2) for x in os.getloadavg()],
    }
