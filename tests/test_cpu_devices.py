"""The CPU split into one JAX device per core (``use_cpu_devices``, ``jaxcable sweep --cpu-devices``).

JAX fixes the CPU's device count when it starts its backends, so every check runs in a fresh
Python process: importing jaxcable must not start them (else no entry point could set the count).
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from jaxcable.core.config import use_cpu_devices

ROOT = Path(__file__).resolve().parents[1]


def _python(code: str, **env_extra) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    env.update(JAX_PLATFORMS="cpu", PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]), **env_extra)
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600, check=False)


def test_importing_jaxcable_does_not_start_jax():
    code = (
        "import jaxcable, jaxcable.cli\n"
        "from jax._src import xla_bridge\n"
        "print(xla_bridge.backends_are_initialized())\n"
    )
    out = _python(code)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"


def test_use_cpu_devices_before_and_after_jax_starts():
    code = (
        "import jax, jaxcable\n"
        "from jaxcable.core.config import use_cpu_devices\n"
        "print(use_cpu_devices(3))\n"
        "print(len(jax.local_devices()))\n"
        "print(use_cpu_devices(2))\n"  # JAX has started: no change, None
        "print(len(jax.local_devices()))\n"
    )
    out = _python(code)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["3", "3", "None", "3"]


def test_xla_flags_device_count_wins():
    code = "import jax\nfrom jaxcable.core.config import use_cpu_devices\nprint(use_cpu_devices(3), len(jax.local_devices()))\n"
    out = _python(code, XLA_FLAGS="--xla_force_host_platform_device_count=2")
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["None", "2"]


@pytest.mark.parametrize("bad", [0, -2, 1.5, "two", True])
def test_bad_device_counts_are_refused(bad):
    with pytest.raises(ValueError, match="count must be a positive integer"):
        use_cpu_devices(bad)


def test_sweep_command_runs_on_the_devices_it_asks_for(tmp_path):
    # rigid level, 3 cases in batches of 2 over 2 devices (the last batch padded), 0.3 s after capture
    # the command line of its own process (main() called from Python leaves the devices alone)
    code = (
        "import sys\nfrom jaxcable.cli import main\n"
        f"sys.argv = ['jaxcable', '--no-cache', 'sweep', '--n', '3', '--batch-size', '2', '--t-end', '0.3', "
        f"'--cpu-devices', '2', '--out', {str(tmp_path / 'a.csv')!r}, '--json']\n"
        "sys.exit(main())\n"
    )
    out = _python(code)
    assert out.returncode == 0, out.stderr
    summary = json.loads(out.stdout)
    assert summary["devices"] == 2
    assert summary["n_cases"] == 3


def test_only_a_command_line_of_its_own_process_sets_the_devices(monkeypatch):
    # the wiring, in this process (whose JAX has started): main(argv) from Python leaves the devices
    # to the caller, main() on the process's own command line configures them
    from jaxcable import cli
    from jaxcable.cli import sweep
    from jaxcable.cli.report import Report

    calls = []
    monkeypatch.setattr(sweep, "configure_devices", lambda args: calls.append(args.cpu_devices))
    monkeypatch.setattr(sweep, "run", lambda args: Report({}, ""))
    # main() builds its parser at each call, which binds the stub as the command's work
    assert cli.main(["sweep", "--cpu-devices", "2", "--json"]) == 0
    assert calls == []
    monkeypatch.setattr(sys, "argv", ["jaxcable", "sweep", "--cpu-devices", "2", "--json"])
    assert cli.main() == 0
    assert calls == [2]


def test_default_batch_size_per_level_and_device():
    import jax

    from jaxcable.arresting.sweep import default_batch_size

    cpu = jax.local_devices(backend="cpu")[0]
    assert default_batch_size("rigid", [cpu]) == 32
    assert default_batch_size("full", [cpu]) == 1
    assert default_batch_size("ale", [cpu, cpu]) == 2  # two devices, one case each
    with pytest.raises(ValueError, match="fidelity"):
        default_batch_size("1dof", [cpu])


def test_batches_that_may_hang_several_cpu_devices_are_refused():
    import jax

    from jaxcable.arresting.sweep import check_batch_size, default_batch_size

    cpu = jax.local_devices(backend="cpu")[0]
    two = [cpu, cpu]
    check_batch_size(default_batch_size("full", two), "full", two)  # the default: one case a device
    check_batch_size(8, "full", [cpu])  # one device: its own pool threads run the batch's parts
    check_batch_size(64, "rigid", two)  # no flexible rocket below level full
    with pytest.raises(ValueError, match="batch_size = 4 puts 2 cases on each of 2 CPU devices"):
        check_batch_size(4, "full", two)
