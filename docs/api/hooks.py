"""mkdocs hook: docstrings write units in brackets after a bracketed list, ``[x, y] [m]``, which
Markdown reads as a reference link ``[x, y][m]``; mkdocs-autorefs then reports the unit as a missing
cross-reference target. This drops exactly those reports (a target that is an SI unit), so that
``mkdocs build --strict`` still fails on every other warning."""

import logging
import re

_UNIT = r"(?:-|1|m|s|N|kg|rad|deg|Pa|MPa|J|W|g|Hz|m/s|m/s\^2|rad/s|deg/s|N/m|N s/m|N m|kg/m|1/s|/s)"
_MISSING_UNIT = re.compile(r"Could not find cross-reference target '" + _UNIT + r"'$")


class _DropUnitTargets(logging.Filter):
    def filter(self, record: logging.LogRecord) -> bool:
        return not _MISSING_UNIT.search(record.getMessage())


def on_startup(**_kwargs):
    for name in ("mkdocs.plugins.mkdocs_autorefs._internal.plugin", "mkdocs.plugins.mkdocs_autorefs"):
        logging.getLogger(name).addFilter(_DropUnitTargets())
