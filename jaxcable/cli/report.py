"""The one report printer of the command line: every command returns a :class:`Report`, printed as
one JSON object (``--json``) or as text; bad input is a ``ValueError`` naming the flag or field,
printed as ``jaxcable COMMAND: error: MESSAGE`` with exit status 2 (the status and form argparse
gives a flag it cannot parse). The argument types shared by the commands live here too, so that a
bad value is refused by argparse with the flag named."""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys


@dataclasses.dataclass
class Report:
    """What a command produced: ``data`` (JSON-able dict, printed by ``--json``), ``text`` (the human
    report), ``ok`` (exit status 0 when True, 1 otherwise)."""

    data: dict
    text: str
    ok: bool = True


def emit(command: str, run, args) -> int:
    """Run ``run(args) -> Report`` and print it; returns the exit status."""
    try:
        report = run(args)
    except ValueError as err:
        print(f"jaxcable {command}: error: {err}", file=sys.stderr)
        return 2
    if getattr(args, "json", False):
        print(json.dumps(report.data))
    elif report.text:
        print(report.text)
    return 0 if report.ok else 1


def positive(flag: str):
    """Argument type: a float > 0, refused naming ``flag`` (exit status 2)."""

    def parse(text: str) -> float:
        value = float(text)
        if not value > 0:
            raise argparse.ArgumentTypeError(f"{flag} must be positive, got {text}")
        return value

    return parse


def non_negative(flag: str):
    """Argument type: a finite float >= 0, refused naming ``flag`` (exit status 2)."""

    def parse(text: str) -> float:
        value = float(text)
        if not 0 <= value < float("inf"):
            raise argparse.ArgumentTypeError(f"{flag} must be finite and >= 0, got {text}")
        return value

    return parse


def cable_damping(flag: str = "--cable-damping"):
    """Argument type: the cables' Rayleigh beta [s], a float >= 0 or ``calibrated`` (the value fitted to
    the paper's section III.F, :data:`jaxcable.arresting.calibration.CALIBRATED_CABLE_DAMPING_S`);
    refused naming ``flag`` (exit status 2)."""

    def parse(text: str) -> float:
        if text.strip().lower() == "calibrated":
            from jaxcable.arresting.calibration import CALIBRATED_CABLE_DAMPING_S

            return CALIBRATED_CABLE_DAMPING_S
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{flag} must be a number [s] or 'calibrated', got {text!r}") from None
        if not value >= 0:
            raise argparse.ArgumentTypeError(f"{flag} must be >= 0 [s] or 'calibrated', got {text}")
        return value

    return parse


def in_open_interval(flag: str, lower: float, upper: float, unit: str = ""):
    """Argument type: a float in ``(lower, upper)``, refused naming ``flag`` (exit status 2)."""

    def parse(text: str) -> float:
        value = float(text)
        if not lower < value < upper:
            raise argparse.ArgumentTypeError(f"{flag} must be in ({lower:g}, {upper:g}){unit}, got {text}")
        return value

    return parse
