"""Which rows of a C_eq table a noise-aware surrogate fits, and which it drops.

The policy (:func:`split_for_fit`), row by row, for a value column and its SEM column:

Dropped (the row says nothing trustworthy about the response):

- ``status`` is ``failed`` or ``missing`` (the case did not run or produced no value);
- the value or its SEM is not finite, or the SEM is negative;
- a flag of a **failed check** (:data:`DROP_FLAGS`): ``sphere_below_floor`` and
  ``sphere_above_lid`` (spheres escaped or tunnelled through the cell: the scene is not the
  one asked for), ``timestep_check`` (LIGGGHTS warned that the timestep is too large: the
  contacts are not resolved), ``ledger_mismatch`` (the cells' energy does not add up to the
  mesh's: the dissipation is not measured correctly), ``negative_dissipation`` (the mean lies
  more than the allowed number of SEMs below zero: dissipation cannot be negative, so the
  measurement is wrong, not merely noisy);
- a flag this module does not know (a new check must be classed here before its rows are used).

Fitted with the SEM the case reports (the flag is about **precision**, not validity,
:data:`SPREAD_FLAGS`): ``target_not_reached`` (the case stopped above its SEM target: its SEM is
larger than asked, and honest), ``not_resolved`` (the mean is within a few SEMs of zero: a small
value with its noise, typically at 1 g where the spheres barely lift off), ``not_steady`` and
``not_stationary`` (the steady-state checks: a transient not clearly over, or the two halves of
the measured window differ), and ``ledger_force_energy`` (the force-based C_eq, from the first
harmonic of the spheres' force, and the energy-based one differ by more than 3 combined SEM,
:mod:`pidpipe.measurement.harmonics`: the bed's stored energy drifted over the window, as in
``not_stationary``; both ledgers are over the same cycles, so the difference is the drift's,
not a failed measurement). Such rows used to leave holes (at the 5 % target 20 of the 60
default cases, nearly all at 1 g), which the surrogate bridged from 5 g; fitted with their
noise they pull the fit toward what was measured as strongly as their noise allows, no more.
A drifting series' SEM may understate its uncertainty; the GP's fitted excess noise
(:mod:`pidpipe.design.gaussian_process`) absorbs scatter that the SEMs do not hold. On the
default campaign's DEM table (17 of 60 cases flagged, all for precision; ``benchmarks/
compare_surrogates.py``) the GP's leave-one-out z-scores of the flagged cases have a standard
deviation of 0.96 (0.84 for the ok ones): their SEMs are not understated, so they are fitted
with them as reported, not widened further.

Replicated points carry flags prefixed by their replicate (``rep1:not_stationary``); the prefix
is ignored. ``repN:failed`` / ``repN:missing`` / ``repN:flagged`` only say that a replicate was
not averaged into the row's value (:func:`pidpipe.design.records.build_table`): they neither
drop nor widen the row.

A table without ``status`` and ``flags`` columns has every row with finite values fitted.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

#: Flags of a failed check: the row is dropped.
DROP_FLAGS: tuple[str, ...] = ("sphere_below_floor", "sphere_above_lid", "timestep_check",
                               "ledger_mismatch", "negative_dissipation")
#: Flags about precision only: the row is fitted with its reported SEM.
SPREAD_FLAGS: tuple[str, ...] = ("target_not_reached", "not_resolved", "not_steady",
                                 "not_stationary", "ledger_force_energy")
#: Statuses whose rows are dropped whatever their flags.
DROP_STATUSES: tuple[str, ...] = ("failed", "missing")
#: Replicate notes (``repN:<status>``) that say only which replicates were averaged.
_REPLICATE_NOTES: tuple[str, ...] = ("ok", "flagged", "failed", "missing")


def row_flags(text) -> list[str]:
    """The flags of one ``flags`` cell (``;``-separated), replicate prefixes and notes removed."""
    if text is None or (isinstance(text, float) and not np.isfinite(text)):
        return []
    flags = []
    for item in str(text).split(";"):
        item = item.strip()
        if not item:
            continue
        prefix, _, name = item.rpartition(":")
        if prefix.startswith("rep") and name in _REPLICATE_NOTES:
            continue
        flags.append(name)
    return flags


def classify_row(status: str, flags: list[str], value: float, sem: float) -> str:
    """Why a row is dropped, or ``""`` if it is fitted (policy of the module docstring)."""
    if status in DROP_STATUSES:
        return f"status {status}"
    if not np.isfinite(value):
        return "value not finite"
    if not (np.isfinite(sem) and sem >= 0.0):
        return "SEM not finite"
    failed = [f for f in flags if f in DROP_FLAGS]
    if failed:
        return "failed check: " + ", ".join(failed)
    unknown = [f for f in flags if f not in SPREAD_FLAGS]
    if unknown:
        return "unknown flag: " + ", ".join(unknown)
    return ""


def split_for_fit(table: pd.DataFrame, value_column: str,
                  sem_column: str) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Split a table into the rows a noise-aware fit uses and the rows it drops.

    Parameters
    ----------
    table : pandas.DataFrame
        A C_eq table (:func:`pidpipe.design.ceq_table.read_ceq_table`), n rows, with the value
        and SEM columns; ``status`` and ``flags`` are optional.
    value_column, sem_column : str
        The fitted quantity and its standard error, same unit (e.g. ``ceq_coupon_ns_m`` and
        ``ceq_coupon_sem_ns_m``, or ``m_eff_cell_kg`` and ``m_eff_cell_sem_kg``).

    Returns
    -------
    fitted : pandas.DataFrame
        The rows to fit, original index kept.
    dropped : pandas.DataFrame
        The other rows, original index kept, with a column ``drop_reason``.

    Raises
    ------
    KeyError
        The value or the SEM column is missing.
    """
    for column in (value_column, sem_column):
        if column not in table.columns:
            raise KeyError(column)
    status = (table["status"].astype(str).str.strip().str.lower() if "status" in table.columns
              else pd.Series("ok", index=table.index))
    flags = table["flags"] if "flags" in table.columns else pd.Series("", index=table.index)
    value = pd.to_numeric(table[value_column], errors="coerce").to_numpy(dtype=float)
    sem = pd.to_numeric(table[sem_column], errors="coerce").to_numpy(dtype=float)
    reasons = np.array([classify_row(s, row_flags(f), v, e)
                        for s, f, v, e in zip(status, flags, value, sem)], dtype=object)
    keep = reasons == ""
    dropped = table.loc[~keep].copy()
    dropped["drop_reason"] = reasons[~keep]
    return table.loc[keep], dropped
