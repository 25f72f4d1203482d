"""The designs' check: DEM at each verifying point against the surrogate, in combined standard
errors judged by their degrees of freedom.

At a point, the DEM's value is the mean of every verifying run of that case so far, pooled as
the campaign pools a case's replicates (:func:`pidpipe.design.records.combine_replicates`:
equal weights, the SEM the larger of the runs' propagated one and the spread between them). A
point that failed is run again and its runs pooled, rather than the failing run dropped. Inverse
variance would weigh most the run whose SEM, estimated from a few cells, happens to be the
smallest. The pooled SEM has nu_dem = sum (cells_i - 1) degrees of freedom: each run's SEM is
its cells' spread (:func:`pidpipe.measurement.cells.mean_of_cells`); the spread between runs
only ever enlarges it. A run without a ``cells`` count (or of one cell) leaves nu_dem unknown,
taken as infinite.

The surrogate's value is its predictive mean and standard deviation sigma_s at the point's
poured fill, its degrees of freedom taken as infinite (a Gaussian process's posterior). Then

    t = (C_dem - C_s) / sqrt(SEM_dem^2 + sigma_s^2),
    nu = (SEM_dem^2 + sigma_s^2)^2 / (SEM_dem^4 / nu_dem)        (Welch-Satterthwaite),
    z = Phi^-1(F_nu(t)),

z being the standard normal score with the same tail probability as t under Student's t of nu
degrees of freedom (z = t when nu is infinite). A 7-cell run's t has 6 degrees of freedom, whose
tails are heavier than the normal's: judged as if normal, |t| > 2 would fail a calibrated
surrogate at twice the rate ``flag_z`` = 2 means. The point passes when |z| <= ``flag_z``; a
point without a DEM value, or without a surrogate value (outside a domain the surrogate refuses
to leave, :func:`pidpipe.refine.predict.predict_or_nan`), does not pass. Verifying rows never
enter a fit (:func:`pidpipe.refine.table.fit_table`), so z is an out-of-sample check in every
round.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from pidpipe.design.ceq_table import SEM_COLUMN, VALUE_COLUMN
from pidpipe.design.records import combine_replicates
from pidpipe.measurement.agreement import normal_score
from pidpipe.refine.predict import predict_or_nan

#: Columns of :func:`pooled`.
POOLED_COLUMNS = ("case_key", "dem_ns_m", "dem_sem_ns_m", "dem_dof", "runs")


def pooled(rows: pd.DataFrame) -> pd.DataFrame:
    """One row per ``case_key``: the runs' mean C_eq and its SEM (N*s/m), the SEM's degrees of
    freedom ``dem_dof`` (inf when unknown), ``runs`` (see the module's text)."""
    out = []
    for key, part in rows.groupby("case_key", sort=True):
        v = part[VALUE_COLUMN].to_numpy(dtype=float)
        s = part[SEM_COLUMN].to_numpy(dtype=float)
        good = np.isfinite(v) & np.isfinite(s) & (s > 0)
        if good.any():
            value, sem = combine_replicates(v[good], s[good])
            cells = (part["cells"].to_numpy(dtype=float)[good] if "cells" in part
                     else np.full(int(good.sum()), np.nan))
            dof = float(np.sum(cells - 1.0)) if np.all(cells >= 2) else math.inf
        else:
            value, sem, dof = math.nan, math.nan, math.nan
        out.append({"case_key": key, "dem_ns_m": value, "dem_sem_ns_m": sem, "dem_dof": dof,
                    "runs": len(part)})
    return pd.DataFrame(out, columns=list(POOLED_COLUMNS))


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
        ``points``' columns and ``dem_ns_m``, ``dem_sem_ns_m``, ``dem_dof``, ``runs``,
        ``surrogate_ns_m``, ``surrogate_std_ns_m``, ``t``, ``z``, ``passes`` (False also where
        there is no DEM value).
    """
    table = points.merge(pooled(verify_rows), on="case_key", how="left")
    if table.empty:
        return table.assign(surrogate_ns_m=[], surrogate_std_ns_m=[], t=[], z=[], passes=[])
    mean, std = predict_or_nan(model, table["freq_hz"], table["accel_g"], table["fill_pct"])
    table["surrogate_ns_m"] = np.asarray(mean, dtype=float)
    table["surrogate_std_ns_m"] = np.asarray(std, dtype=float)
    combined = np.sqrt(table["dem_sem_ns_m"] ** 2 + table["surrogate_std_ns_m"] ** 2)
    table["t"] = (table["dem_ns_m"] - table["surrogate_ns_m"]) / combined
    table["z"] = normal_score(table["t"], table["dem_sem_ns_m"], table["dem_dof"],
                              table["surrogate_std_ns_m"])
    table["passes"] = np.abs(table["z"].to_numpy(dtype=float)) <= flag_z
    return table


def worst_abs_z(comparison: pd.DataFrame, design: str) -> float:
    """The largest |z| of one design's points (NaN when none has a DEM value)."""
    z = comparison.loc[comparison["design"] == design, "z"].to_numpy(dtype=float)
    z = np.abs(z[np.isfinite(z)])
    return float(z.max()) if z.size else float("nan")
