"""The command line as one argparse tree: every subcommand's ``--help``, bad flags refused with exit
status 2 and the flag named, and the on-disk compilation cache (``--no-cache``, ``JAXCABLE_NO_CACHE``,
``JAXCABLE_CACHE_DIR``). Runs only the 1-DOF landing (no long compilations)."""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from jaxcable.cli import build_parser, main
from jaxcable.core.config import (
    CACHE_DIR_ENV,
    NO_CACHE_ENV,
    cache_disabled_by_env,
    default_cache_dir,
    enable_compilation_cache,
)

SUBCOMMANDS = ("throw", "land", "sweep", "design", "bench")
ONE_DOF = ["land", "--fidelity", "1dof", "--json"]


@pytest.fixture(autouse=True)
def _no_cache_in_this_process(monkeypatch):
    """A command run in this process must not turn the persistent cache on for the rest of the tests."""
    monkeypatch.setenv(NO_CACHE_ENV, "1")


def test_the_tree_holds_every_subcommand():
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    assert tuple(sub.choices) == SUBCOMMANDS


@pytest.mark.parametrize("command", [None, *SUBCOMMANDS])
def test_help_exits_0(command, capsys):
    argv = ["--help"] if command is None else [command, "--help"]
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    assert exit_.value.code == 0
    text = capsys.readouterr().out
    assert text.startswith(f"usage: jaxcable {command or ''}".rstrip())
    # the help speaks of the program, not of its history
    assert not re.search(r"\b(issue|ticket|session)\s+\d", text, flags=re.IGNORECASE), text


@pytest.mark.parametrize(
    "argv, flag",
    [
        (["throw", "--angle", "95"], "--angle"),
        (["throw", "--segment-length", "0"], "--segment-length"),
        (["throw", "--solver", "rk99"], "--solver"),
        (["throw", "--bogus"], "--bogus"),
        (["throw", "--pcoeff", "-0.1"], "--pcoeff"),
        (["throw", "--icoeff", "0"], "--icoeff"),
        (["land", "--fidelity", "medium"], "--fidelity"),
        (["land", "--t-end", "-1"], "--t-end"),
        (["land", "--x", "three"], "--x"),
        (["sweep", "--n", "0"], "--n"),
        (["design", "--scene", "boat"], "--scene"),
        (["bench", "--cases", "nothing"], "--cases"),
        (["fly"], "fly"),
    ],
)
def test_bad_flags_exit_2_naming_the_flag(argv, flag, capsys):
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    assert exit_.value.code == 2
    assert flag in capsys.readouterr().err


def test_bad_values_found_after_parsing_exit_2_naming_the_flag(capsys):
    assert main(["land", "--fidelity", "1dof", "--brake-profile", "1,1"]) == 2
    assert capsys.readouterr().err.startswith("jaxcable land: error: --brake-profile needs --fidelity rigid")
    assert main(["land", "--phase", "full", "--fidelity", "1dof"]) == 2
    assert capsys.readouterr().err == "jaxcable land: error: --phase full needs --fidelity rigid, ale or full\n"
    assert main(["land", "--fidelity", "rigid", "--hook-contact", "node"]) == 2
    assert capsys.readouterr().err.startswith("jaxcable land: error: --hook-contact node needs --fidelity ale or full")
    assert main(["land", "--fidelity", "ale", "--rocket-bodies", "1"]) == 2
    assert capsys.readouterr().err.startswith("jaxcable land: error: --rocket-bodies 1 needs --fidelity full")
    assert main(["land", "--phase", "full", "--fidelity", "rigid", "--span-elements", "40"]) == 2
    assert capsys.readouterr().err.startswith("jaxcable land: error: --span-elements 40 needs --fidelity ale or full")


@pytest.mark.parametrize("phase", ["passive", "full"])
def test_land_passes_the_passive_scene_options(phase, monkeypatch):
    """``jaxcable land`` hands the cable mesh, the hook model and the rocket's bodies to the passive
    scene in both phases (only the flags given; the level's defaults otherwise)."""
    import jaxcable.cli.land as land_cli

    seen = []

    def fake(*args, **kwargs):
        seen.append(kwargs.get("passive_kwargs", kwargs))
        raise RuntimeError("stop here")

    monkeypatch.setattr(land_cli, "run_landing", fake)
    monkeypatch.setattr(land_cli, "run_two_phase", fake)
    flags = ["land", "--phase", phase, "--fidelity", "full"]
    for extra, want in (
        ([], {}),
        (["--span-elements", "40", "--fine-elements", "8", "--hook-contact", "capsule", "--rocket-bodies", "1"],
         {"n_span_elements": 40, "n_fine": 8, "hook_contact": "capsule", "n_rocket_bodies": 1}),
    ):
        with pytest.raises(RuntimeError, match="stop here"):
            land_cli.run(build_parser().parse_args(flags + extra))
        got = {k: seen[-1].get(k) for k in ("n_span_elements", "n_fine", "hook_contact", "n_rocket_bodies") if k in seen[-1]}
        assert got == want


def test_no_cache_flag_before_or_after_the_command():
    parser = build_parser()
    assert parser.parse_args(["throw"]).no_cache is False
    assert parser.parse_args(["--no-cache", "throw"]).no_cache is True
    assert parser.parse_args(["land", "--no-cache"]).no_cache is True


def test_throw_runs_the_pi_step_size_controller_by_default():
    """``jaxcable throw`` passes THROW_STEP_CONTROL (the PI controller measured by
    experiments/rope_step_limits.py, part c) unless told otherwise."""
    from jaxcable.throw.scene import THROW_STEP_CONTROL

    args = build_parser().parse_args(["throw"])
    assert (args.pcoeff, args.icoeff) == THROW_STEP_CONTROL == (0.4, 0.3)
    args = build_parser().parse_args(["throw", "--pcoeff", "0", "--icoeff", "1"])
    assert (args.pcoeff, args.icoeff) == (0.0, 1.0)


def test_throw_windows_flag_reaches_the_scene(monkeypatch):
    """``jaxcable throw`` evaluates the rope on the default windows; ``--no-windows`` on every link."""
    import jaxcable.cli.throw as throw_cli

    seen = []

    def fake_simulate(scene, *args, **kwargs):
        seen.append(scene.windows)
        raise RuntimeError("stop here")

    monkeypatch.setattr(throw_cli, "simulate", fake_simulate)
    for flags, want in (([], (64, 128, 256, 512)), (["--no-windows"], ())):
        with pytest.raises(RuntimeError, match="stop here"):
            throw_cli.run(build_parser().parse_args(["throw", "--rope-length", "750", *flags]))
        assert seen[-1] == want


def test_cache_folder_from_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv(CACHE_DIR_ENV, str(tmp_path / "here"))
    assert default_cache_dir() == tmp_path / "here"
    monkeypatch.delenv(CACHE_DIR_ENV)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert default_cache_dir() == tmp_path / "xdg" / "jaxcable" / "jax"
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert default_cache_dir() == Path.home() / ".cache" / "jaxcable" / "jax"
    for value, off in (("1", True), ("yes", True), ("0", False), ("", False), ("false", False)):
        monkeypatch.setenv(NO_CACHE_ENV, value)
        assert cache_disabled_by_env() is off, value


def test_a_cache_folder_that_cannot_be_made_leaves_the_cache_off(monkeypatch, tmp_path):
    monkeypatch.delenv(NO_CACHE_ENV)
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    with pytest.warns(UserWarning, match="compilation cache off"):
        assert enable_compilation_cache(blocker / "cache") is None
    monkeypatch.setenv(NO_CACHE_ENV, "1")
    assert enable_compilation_cache(tmp_path / "cache") is None
    assert not (tmp_path / "cache").exists()


def _land_1dof(cache: Path, *extra: str, no_cache_env: bool = False) -> subprocess.Popen:
    """Start ``jaxcable [EXTRA] land --fidelity 1dof --json`` with ``cache`` as the cache folder."""
    env = {k: v for k, v in os.environ.items() if k not in (NO_CACHE_ENV, CACHE_DIR_ENV)}
    env[CACHE_DIR_ENV] = str(cache)
    if no_cache_env:
        env[NO_CACHE_ENV] = "1"
    cmd = [sys.executable, "-m", "jaxcable.cli", *extra, *ONE_DOF]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)


def _output(proc: subprocess.Popen) -> dict:
    out, err = proc.communicate(timeout=600)
    assert proc.returncode == 0, err
    return json.loads(out)


def _files(folder: Path) -> set:
    return {p.name for p in folder.iterdir()} if folder.exists() else set()


def test_compilation_cache_is_written_then_read_and_can_be_turned_off(tmp_path):
    """A first run fills the folder; a second run finds every program there (no new entry: the
    keys do not change between processes) and prints the same JSON; ``JAXCABLE_NO_CACHE=1`` and
    ``--no-cache`` leave their folders empty (the last three run side by side)."""
    cache = tmp_path / "cache"
    first = _output(_land_1dof(cache))
    written = _files(cache)
    assert written, "the first run wrote no compiled program"
    runs = {
        "cache": _land_1dof(cache),
        "env": _land_1dof(tmp_path / "env", no_cache_env=True),
        "flag": _land_1dof(tmp_path / "flag", "--no-cache"),
    }
    for name, proc in runs.items():
        assert _output(proc) == first, name
    assert _files(cache) == written
    assert not _files(tmp_path / "env") and not _files(tmp_path / "flag")
