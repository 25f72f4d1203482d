"""How does one cell's effective mass change with the acceleration, and do the two C_eq ledgers agree?

Reads a finished campaign's case records (``<workdir>/results/cases/*.json``), builds the C_eq
table with the current code (:func:`pidpipe.design.records.records_to_table`, so that records
of a campaign run before the table had m_eff columns are read too), and prints:

- per acceleration level: the cases, m_eff / bed mass (mean, min, max) and how many cases the
  force-energy ledger check flagged;
- every case below lift-off (G < 1) with its m_eff / bed mass and SEM;
- over the ``ok`` cases: |z| of the force-based against the energy-based C_eq.

Run: .venv/bin/python benchmarks/m_eff_by_level.py WORKDIR
(WORKDIR as written by ``benchmarks/bench_campaign.py --workdir``.)
"""

from __future__ import annotations

import argparse
import glob

import numpy as np
import pandas as pd

from harness import record
from pidpipe.design.records import read_record, records_to_table


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("workdir", help="a campaign's working directory")
    args = parser.parse_args()
    paths = sorted(glob.glob(f"{args.workdir}/results/cases/*.json"))
    table = records_to_table([read_record(path) for path in paths])
    levels = table.groupby("accel_g")
    summary = pd.DataFrame({
        "cases": levels.size(), "m_eff_ratio_mean": levels["m_eff_ratio"].mean().round(3),
        "min": levels["m_eff_ratio"].min().round(3), "max": levels["m_eff_ratio"].max().round(3),
        "ledger_flagged": levels["flags"].apply(
            lambda flags: int(flags.fillna("").str.contains("ledger_force_energy").sum()))})
    print(summary.to_string())
    resting = table[table["accel_g"] < 1.0]
    print(resting[["freq_hz", "accel_g", "fill_pct", "regime", "m_eff_ratio",
                   "m_eff_ratio_sem"]].to_string(index=False))
    ok = table[table["status"] == "ok"]
    z = ((ok["ceq_force_cell_ns_m"] - ok["ceq_cell_ns_m"])
         / np.hypot(ok["ceq_force_cell_sem_ns_m"], ok["ceq_cell_sem_ns_m"])).abs()
    print(f"ok cases {len(ok)}: force vs energy C_eq |z| median {z.median():.2f}, "
          f"max {z.max():.2f}, beyond 2: {int((z > 2).sum())}")
    figures = {f"G{g:g}_m_eff_ratio_mean": float(row["m_eff_ratio_mean"])
               for g, row in summary.iterrows()}
    figures.update({f"G{g:g}_m_eff_ratio_range": f"{row['min']:g} to {row['max']:g}"
                    for g, row in summary.iterrows()})
    figures.update(ok_cases=len(ok), ledger_abs_z_median=round(float(z.median()), 2),
                   ledger_abs_z_max=round(float(z.max()), 2), ledger_beyond_2=int((z > 2).sum()))
    record("m_eff_by_level", figures, notes=f"{len(table)} cases of the campaign in the workdir")


if __name__ == "__main__":
    main()
