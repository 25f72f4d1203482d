"""Does the GP's covariance of cases that share packings explain verify's flags? The DEM verify's
z at every design point, from the campaign's table fitted with independent SEMs and with the
packings' covariance.

Every case of a fill is shaken on the same packings, so the errors of a fill's cases are
correlated (:mod:`pidpipe.design.packing_noise`). This refits the campaign's fitted table
(``results/ceq_table_refined.csv`` after the loop, else ``results/ceq_table.csv``) with the GP
both ways and compares each with the DEM verify's values (``results/verify.csv``: DEM cases to
a 5 % standard error on packings of their own, ``benchmarks/verify_dem_5pct.yaml``), with the
t verify computes (:func:`pidpipe.loop.verify.t_combined`); the surrogate is read at the
design's (mean) fill, and, third, at the whole-sphere fill the DEM case poured, as verify reads
it. What it prints as z is that t itself, not the normal score of its tail probability under
its degrees of freedom that verify logs: where a DEM case ended at a few cells (1 g), verify's z
is the smaller. A table written before rows carried
``packing_loads`` gets them from the cases' records (:func:`pidpipe.design.records.record_loads`).

Run, in a finished campaign's folder that ``snakemake verify`` ran in:
    .venv/bin/python <repo>/benchmarks/experiments/shared_packings_verify.py
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))   # the harness
sys.path.insert(0, str(ROOT))
from harness import record_text  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from pidpipe.design.packing_noise import LOADS_COLUMN, SharedPackings, pair_correlations  # noqa: E402
from pidpipe.design.records import read_record, replicates_loads  # noqa: E402
from pidpipe.design.surrogate import fit_surrogate  # noqa: E402
from pidpipe.loop.verify import surrogate_uncertainty, t_combined  # noqa: E402

RECORD_FOLDERS = (Path("results/cases"), Path("results/refine/work/cases"))

#: Edges of the distance bins of the pairs' table (ln units).
DISTANCE_BINS = (0.0, 0.2, 0.5, 1.0, 2.0, np.inf)


def fitted_table() -> tuple[pd.DataFrame, str]:
    """The table the campaign's designs were fitted to, and its name."""
    for name in ("results/ceq_table_refined.csv", "results/ceq_table.csv"):
        if Path(name).is_file():
            return pd.read_csv(name), name
    raise SystemExit("no results/ceq_table*.csv here: run in a finished campaign's folder")


def loads_from_records(table: pd.DataFrame) -> list[str]:
    """Each row's loads rebuilt from its records (replicates averaged with equal weights)."""
    texts = []
    for ids in table["case_id"].fillna(""):
        paths = [next((folder / f"{case_id}.json" for folder in RECORD_FOLDERS
                       if (folder / f"{case_id}.json").is_file()), None)
                 for case_id in str(ids).split(";")]
        texts.append(replicates_loads([read_record(path) for path in paths if path is not None]))
    return texts


def main() -> None:
    table, name = fitted_table()
    rebuilt = LOADS_COLUMN not in table.columns or table[LOADS_COLUMN].isna().all()
    if rebuilt:
        table[LOADS_COLUMN] = loads_from_records(table)
    verify = pd.read_csv("results/verify.csv")
    points = verify[verify["dem_status"].isin(["ok", "flagged"])].reset_index(drop=True)
    shared = SharedPackings.of(table)
    t = {}
    at_design = points.assign(fill_pct=points["design_fill_pct"])   # the design's mean fill
    for model, fitted, at in (("independent SEMs", table.drop(columns=LOADS_COLUMN), at_design),
                              ("packings' covariance", table, at_design),
                              ("packings' covariance, read at the poured fill", table, points)):
        surrogate = fit_surrogate(fitted, method="gp", allow_holes=True, source=name)
        predicted = surrogate_uncertainty(surrogate, at, draws=0, seed=0)
        t[model] = t_combined(points["ceq_coupon_dem_ns_m"].to_numpy(dtype=float),
                              points["ceq_coupon_dem_sem_ns_m"].to_numpy(dtype=float),
                              predicted["ceq_coupon_surrogate_ns_m"].to_numpy(dtype=float),
                              predicted["surrogate_u_ns_m"].to_numpy(dtype=float))
        points[f"u/C {model}"] = (predicted["surrogate_u_ns_m"]
                                  / predicted["ceq_coupon_surrogate_ns_m"]).to_numpy()
    lines = [f"Table `{name}`, {len(table)} rows"
             + (" (loads rebuilt from the records)" if rebuilt else "")
             + (f"; {shared.describe()}" if shared else "; no shared packings")
             + f". {len(points)} verify points.", "",
             "| environment | GP noise | worst \\|z\\| (design, point) | median u / C |",
             "|---|---|---|---|"]
    for environment, rows in points.groupby("environment", sort=False):
        for model, values in t.items():
            at = rows.index[np.argmax(np.abs(values[rows.index]))]
            lines.append(f"| {environment} | {model} | {abs(values[at]):.2f} "
                         f"({points.at[at, 'design']}, {points.at[at, 'point']}) | "
                         f"{np.median(rows[f'u/C {model}']):.1%} |")
    if shared:
        lines += ["", "Pairs of rows sharing packings, by the distance d between their conditions in "
                  "(ln f, ln G): the mean correlation of their cells' deviations, and the fit's.", "",
                  "| d | pairs | mean r | fitted rho |", "|---|---|---|---|"]
        i, j, r = pair_correlations(shared.weights, shared.loads)
        d = shared.distance[i, j]
        for lo, hi in zip(DISTANCE_BINS[:-1], DISTANCE_BINS[1:]):
            inside = (d >= lo) & (d < hi)
            if inside.any():
                lines.append(f"| {lo:g}-{hi:g} | {int(inside.sum())} | {np.mean(r[inside]):.2f} | "
                             f"{np.mean(shared.correlation(d[inside])):.2f} |")
    lines.append("")
    for model, values in t.items():
        lines.append(f"- {model}: RMS z {np.sqrt(np.mean(values**2)):.2f}, |z| > 2 at "
                     f"{int(np.sum(np.abs(values) > 2))} of {len(values)} points")
    record_text("Verify's z with and without the packings' covariance",
                "python benchmarks/experiments/shared_packings_verify.py", lines)


if __name__ == "__main__":
    main()
