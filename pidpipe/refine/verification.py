"""The designs' check: DEM at each verifying point against the surrogate, in combined standard
errors.

At a point, the DEM's value is the inverse-variance mean of every verifying run of that case so
far (a point that failed is run again, and its runs pooled, rather than the failing run
dropped), with SEM 1 / sqrt(sum 1 / SEM_i^2); the surrogate's is its predictive mean and
standard deviation at the point's poured fill. Then

    z = (C_dem - C_s) / sqrt(SEM_dem^2 + sigma_s^2),

and the point passes when |z| <= ``flag_z``; a point without a DEM value, or without a
surrogate value (outside a domain the surrogate refuses to leave,
:func:`pidpipe.refine.predict.predict_or_nan`), does not pass. Verifying rows never enter a fit
(:func:`pidpipe.refine.table.fit_table`), so z is an out-of-sample check in every round.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from pidpipe.design.ceq_table import SEM_COLUMN, VALUE_COLUMN
from pidpipe.refine.predict import predict_or_nan


def pooled(rows: pd.DataFrame) -> pd.DataFrame:
    """One row per ``case_key``: inverse-variance mean C_eq and its SEM (N*s/m), ``runs``."""
    out = []
    for key, part in rows.groupby("case_key", sort=True):
        v = part[VALUE_COLUMN].to_numpy(dtype=float)
        s = part[SEM_COLUMN].to_numpy(dtype=float)
        good = np.isfinite(v) & np.isfinite(s) & (s > 0)
        if good.any():
            w = 1.0 / s[good] ** 2
            value, sem = float(np.sum(w * v[good]) / np.sum(w)), float(1.0 / np.sqrt(np.sum(w)))
        else:
            value, sem = float("nan"), float("nan")
        out.append({"case_key": key, "dem_ns_m": value, "dem_sem_ns_m": sem, "runs": len(part)})
    return pd.DataFrame(out, columns=["case_key", "dem_ns_m", "dem_sem_ns_m", "runs"])


def compare(points: pd.DataFrame, verify_rows: pd.DataFrame, model, flag_z: float) -> pd.DataFrame:
    """z at every verifying point that has a DEM value.

    Parameters
    ----------
    points : pandas.DataFrame
        :func:`pidpipe.refine.candidates.verify_points`.
    verify_rows : pandas.DataFrame
        Verifying rows of the table (every run; pooled here).
    model
        Has ``predict_with_uncertainty``.
    flag_z : float

    Returns
    -------
    pandas.DataFrame
        ``points``' columns and ``dem_ns_m``, ``dem_sem_ns_m``, ``runs``, ``surrogate_ns_m``,
        ``surrogate_std_ns_m``, ``z``, ``passes`` (False also where there is no DEM value).
    """
    table = points.merge(pooled(verify_rows), on="case_key", how="left")
    if table.empty:
        return table.assign(surrogate_ns_m=[], surrogate_std_ns_m=[], z=[], passes=[])
    mean, std = predict_or_nan(model, table["freq_hz"], table["accel_g"], table["fill_pct"])
    table["surrogate_ns_m"] = np.asarray(mean, dtype=float)
    table["surrogate_std_ns_m"] = np.asarray(std, dtype=float)
    combined = np.sqrt(table["dem_sem_ns_m"] ** 2 + table["surrogate_std_ns_m"] ** 2)
    table["z"] = (table["dem_ns_m"] - table["surrogate_ns_m"]) / combined
    table["passes"] = np.abs(table["z"].to_numpy(dtype=float)) <= flag_z
    return table


def worst_abs_z(comparison: pd.DataFrame, design: str) -> float:
    """The largest |z| of one design's points (NaN when none has a DEM value)."""
    z = comparison.loc[comparison["design"] == design, "z"].to_numpy(dtype=float)
    z = np.abs(z[np.isfinite(z)])
    return float(z.max()) if z.size else float("nan")
