"""Screening sweeps and their confirmation: a fast sweep, then the default settings where it matters.

A screening sweep runs section IV's cases at a looser passive-phase tolerance and a shorter passive
phase (``jaxcable sweep --phase full --fidelity full --rtol 1e-4 --t-end 1.2``: about a third of the
cost at the full level, ``docs/sweeps.md``). Its criteria move a little against the defaults, so a
verdict is trusted only away from the limits. :func:`cases_to_confirm` picks the cases to rerun at
the defaults: a criterion within ``band`` (relative) of its limit, a numerical failure, or a captured
case that had not stopped by the screening's end. :func:`run_confirmation` reruns them into a CSV of
their own (resumable like any sweep) and writes the sweep's table with the confirmed rows in place of
the screened ones.

``jaxcable sweep ... --confirm SCREENED.csv --out CONFIRMED.csv`` does all three and writes the
merged table beside ``--out`` (``CONFIRMED_merged.csv``).

Without a band, :func:`run_confirmation` takes the one measured for the screen's tolerance
(:data:`MEASURED_BANDS`, read from the screened CSV's sidecar): :data:`SCREENING_BAND` = 0.2% for
``--rtol 1e-4``, 3x the largest deviation a screening sweep showed against the defaults on scenario
I's 100 cases at the full level (6.7e-4, a_max; ``experiments/section4_screening.py``), and a band
per criterion for ``--rtol 3e-4`` and ``1e-3``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from jaxcable.arresting.passive import LandingCriteria
from jaxcable.arresting.sweep import (
    CRITERIA,
    qmc_case_fn,
    run_qmc_sweep,
    sweep_identity,
)
from jaxcable.core.validation import check_positive
from jaxcable.studies.sweep import merge_sweep_csvs, read_sidecar, read_sweep_csv

__all__ = [
    "COARSE_SCREENING_BANDS", "MEASURED_BANDS", "SCREENING_BAND", "SCREENING_BANDS_3E4", "SCREENING_SETTINGS", "cases_to_confirm", "check_screened",
    "criterion_bands", "measured_band", "merged_path", "run_confirmation",
]  # fmt: skip

SCREENING_BAND = 2e-3
"""Relative distance from a criterion's limit inside which a screened verdict is rerun (0.2%)."""

COARSE_SCREENING_BANDS = {"z_max_m": 1.2e-3, "a_max_g": 1.8e-2, "sigma_max_mpa": 2.9e-3}
"""Bands per criterion (relative) for a coarse screening sweep at ``--rtol 1e-3 --t-end 1.2``
(``jaxcable sweep ... --confirm SCREENED.csv --band 1.2e-3 1.8e-2 2.9e-3``): twice the sum of the
largest deviation of such a screen from one at ``--rtol 1e-4`` (2.5e-4, 8.2e-3, 1.4e-3 on z_max,
a_max, sigma_max over section IV's 3 x 100 cases, rigid rocket, default mesh;
``experiments/results/section4_screening_coarse.md``) and the largest of the ``--rtol 1e-4``
screen from the defaults (3.3e-4, 6.7e-4, 5e-5, :data:`SCREENING_BAND`'s measurement). Every
verdict the coarse screen turned against the ``--rtol 1e-4`` screen (4 of 300) lies inside them;
they send 20-22 cases a scenario back to the defaults (``docs/sweeps.md``)."""

SCREENING_BANDS_3E4 = {"z_max_m": 7.5e-4, "a_max_g": 4.1e-3, "sigma_max_mpa": 4.6e-4}
"""Bands per criterion (relative) for a screening sweep at ``--rtol 3e-4 --t-end 1.2``: twice the sum
of the largest deviation of such a screen from one at ``--rtol 1e-4`` (4.4e-5, 1.4e-3, 1.8e-4 over
section IV's 3 x 100 cases, rigid rocket, default mesh; ``experiments/results/section4_screening_3e4.md``)
and of the ``--rtol 1e-4`` screen's from the defaults, as :data:`COARSE_SCREENING_BANDS`. A screen at
3e-4 takes about 1.4x the steps of one at 1e-3 and leaves 3-8 cases a scenario to confirm
(``docs/sweeps.md``)."""

MEASURED_BANDS = {
    1e-4: dict.fromkeys((c[0] for c in CRITERIA), SCREENING_BAND),
    3e-4: SCREENING_BANDS_3E4,
    1e-3: COARSE_SCREENING_BANDS,
}
"""The bands measured for a screening sweep's passive-phase tolerance (``--rtol`` of the screen, over
1.2 s after capture): what :func:`run_confirmation` uses when it is given no band
(:func:`measured_band`)."""

SCREENING_SETTINGS = ("t_end_s", "rtol", "passive_rtol", "max_steps")
"""The case-function settings in which a screening sweep may differ from its confirmation; every
other part of the case function's identity (level, mesh, damping, scenario, seed, ...) must agree."""


def criterion_bands(band) -> dict:
    """``band`` as one relative band per criterion (``z_max_m``, ``a_max_g``, ``sigma_max_mpa``):
    a number (> 0) for all three, or a mapping that names each of them (values > 0)."""
    names = [c[0] for c in CRITERIA]
    if isinstance(band, dict):
        unknown = sorted(set(band) - set(names))
        missing = [k for k in names if k not in band]
        if unknown or missing:
            raise ValueError(f"band must name each of {', '.join(names)}; unknown {unknown}, missing {missing}")
        out = {k: band[k] for k in names}
        for k, v in out.items():
            check_positive(f"band[{k}]", v)
    else:
        check_positive("band", band)
        out = dict.fromkeys(names, band)
    return {k: float(v) for k, v in out.items()}


def cases_to_confirm(table: dict, band: float | dict = SCREENING_BAND, criteria: LandingCriteria | None = None) -> np.ndarray:
    """Case indices of a screened sweep's table (:func:`jaxcable.studies.sweep.read_sweep_csv`)
    whose verdict a rerun at the defaults must decide: a criterion within ``band`` (relative, > 0;
    one number, or one per criterion as :func:`criterion_bands` takes them, e.g.
    :data:`COARSE_SCREENING_BANDS`) of its limit, a numerical failure, or a captured case not
    stopped by the screening's end. ``criteria``: default section IV.A's
    (:class:`~jaxcable.arresting.passive.LandingCriteria`)."""
    bands = criterion_bands(band)
    criteria = LandingCriteria() if criteria is None else criteria
    failed = np.asarray(table["failed"], dtype=bool)
    near = failed.copy()
    for name, _, _, limit_field, _ in CRITERIA:
        limit = float(getattr(criteria, limit_field))
        value = np.asarray(table[name], dtype=float)
        with np.errstate(invalid="ignore"):
            near |= ~(np.abs(value / limit - 1.0) >= bands[name])  # NaN counts as near
    captured = np.asarray(table["captured"], dtype=bool)
    near |= captured & ~np.asarray(table["stopped"], dtype=bool)
    return np.asarray(table["case"], dtype=int)[near]


def measured_band(screened_csv) -> dict:
    """The bands of :data:`MEASURED_BANDS` for the passive-phase tolerance that ``screened_csv`` (its
    sidecar) ran at. A screen at a tolerance with no measured band is refused: pass ``band``."""
    side = read_sidecar(screened_csv) or {}
    rtol = side.get("case_fn", {}).get("passive_rtol")
    if rtol is not None:
        for tol, bands in MEASURED_BANDS.items():
            if np.isclose(float(rtol), tol, rtol=1e-9, atol=0.0):
                return dict(bands)
    measured = ", ".join(f"{t:g}" for t in MEASURED_BANDS)
    raise ValueError(
        f"{screened_csv}: no band is measured for a screen at passive rtol = {rtol!r} (measured: {measured}); "
        "pass the band (--band) from a comparison of such a screen with the defaults (experiments/section4_screening.py)"
    )


def check_screened(screened_csv, identity: dict, case_fn_identity: dict, n: int) -> dict:
    """Refuse to confirm ``screened_csv`` with a sweep it was not screening for: its sidecar's
    identity (scenario, phase, seed, process slice) must equal ``identity``, its case function's
    must equal ``case_fn_identity`` but for :data:`SCREENING_SETTINGS`, and it must hold ``n``
    cases (a screening sweep still running is refused: finish it first). Returns its table."""
    side = read_sidecar(screened_csv)
    if side is None:
        raise ValueError(f"{screened_csv}: no sidecar ({screened_csv}.json); not a sweep written by jaxcable")
    if side.get("identity") != identity:
        raise ValueError(f"{screened_csv} is a sweep of {side.get('identity')}, not of {identity}")
    theirs, ours = side.get("case_fn", {}), case_fn_identity

    def strip(d):
        return {k: v for k, v in d.items() if k not in SCREENING_SETTINGS}

    differ = sorted(k for k in set(strip(theirs)) | set(strip(ours)) if strip(theirs).get(k) != strip(ours).get(k))
    if differ:
        raise ValueError(
            f"{screened_csv}: its case function differs from this sweep's in {', '.join(differ)}; a screening sweep "
            f"may differ only in {', '.join(SCREENING_SETTINGS)}"
        )
    table = read_sweep_csv(screened_csv)
    done = len(table["case"])
    if side.get("n") != n or done != n:
        raise ValueError(f"{screened_csv} holds {done} of n = {side.get('n')} cases; confirming needs all {n} (resume it first)")
    return table


def merged_path(out) -> Path:
    """Where the merged table of a confirmation written to ``out`` goes: ``<stem>_merged<suffix>``."""
    out = Path(out)
    return out.with_name(f"{out.stem}_merged{out.suffix}")


def run_confirmation(
    screened_csv,
    scenario: str,
    n: int,
    *,
    out,
    phase: str = "passive",
    fidelity: str = "rigid",
    seed: int = 0,
    band: float | dict | None = None,
    process_index: int = 0,
    process_count: int = 1,
    batch_size="auto",
    devices=None,
    progress: bool = True,
    **case_kwargs,
) -> dict:
    """Rerun the cases of ``screened_csv`` that :func:`cases_to_confirm` picks, as
    :func:`~jaxcable.arresting.sweep.run_qmc_sweep` with the same arguments would (the defaults
    unless ``case_kwargs`` say otherwise), into ``out``; then write the screened table with the
    confirmed rows in place to :func:`merged_path` (``out``). ``band``: as :func:`cases_to_confirm`
    takes it; None, the band measured for the screen's tolerance (:func:`measured_band`).

    Returns ``{"cases", "confirmed", "merged", "turned", "merged_csv", "band"}``: the confirmed case indices,
    the confirmed and merged tables (columns), and the cases whose success verdict the
    confirmation turned."""
    screened_csv = Path(screened_csv)
    if Path(out).resolve() == screened_csv.resolve():
        raise ValueError(f"out = {out} is the screened sweep itself; write the confirmation to another file")
    identity = sweep_identity(scenario, phase, seed, process_index, process_count)
    screened = check_screened(screened_csv, identity, qmc_case_fn(scenario, phase, fidelity, seed, **case_kwargs).describe(), n)
    band = measured_band(screened_csv) if band is None else band
    cases = cases_to_confirm(screened, band)
    confirmed = None
    if cases.size:
        confirmed = run_qmc_sweep(
            scenario, n, phase=phase, fidelity=fidelity, out=out, seed=seed, batch_size=batch_size,
            process_index=process_index, process_count=process_count, devices=devices, progress=progress,
            cases=cases, **case_kwargs,
        )  # fmt: skip
    path = merged_path(out)
    # merge_sweep_csvs keeps a case's first row: the confirmed file goes first
    merged = merge_sweep_csvs([out, screened_csv] if cases.size else [screened_csv], path)
    verdict = dict(zip(np.asarray(screened["case"], int).tolist(), np.asarray(screened["success"], bool).tolist()))
    turned = []
    if confirmed is not None:
        turned = [c for c, ok in zip(np.asarray(confirmed["case"], int).tolist(), np.asarray(confirmed["success"], bool).tolist()) if verdict[c] != ok]
    return {"cases": cases, "confirmed": confirmed, "merged": merged, "turned": turned, "merged_csv": str(path), "band": band}
