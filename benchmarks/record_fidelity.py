"""How close does each cheaper fidelity come to the reference, and at what CPU (issue 5)?

Reads what ``snakemake --cores 2 fidelity`` wrote (results/fidelity/fidelity.csv and
fidelity_summary.csv, in the working directory) and prints the summary per variant, the
cases that were flagged and the CPU time; it records them, with the machine and the date, in
``benchmarks/records/record_fidelity.json`` (:mod:`harness`). It runs nothing.

Run, after the study: .venv/bin/python benchmarks/record_fidelity.py [--results results/fidelity]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd
from harness import record

from pidpipe.studies.fidelity import REFERENCE, summary_markdown


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", default="results/fidelity",
                        help="the folder snakemake's fidelity target wrote")
    args = parser.parse_args()
    folder = Path(args.results)
    table = pd.read_csv(folder / "fidelity.csv", keep_default_na=False, na_values=[""])
    summary = pd.read_csv(folder / "fidelity_summary.csv", keep_default_na=False, na_values=[""])
    reference = table[table["variant"] == REFERENCE]
    lines = summary_markdown(summary)
    not_steady = reference[reference["status"] != "ok"]
    lines += ["", f"{len(reference)} reference cases; reference not steady (left out of every "
              f"summary): " + (", ".join(f"{r.case_id} ({r.flags or r.status})"
                                         for r in not_steady.itertuples()) or "none") + "."]
    flagged = table[(table["variant"] != REFERENCE) & (table["status"] != "ok")]
    lines.append(f"Variant runs flagged or failed: {len(flagged)} of "
                 f"{int((table['variant'] != REFERENCE).sum())}.")
    lines.append(f"CPU time (LIGGGHTS, summed over every run): {table['cpu_time_s'].sum():.0f} s "
                 f"({table['cpu_time_s'].sum() / 60:.1f} min), of which the reference "
                 f"{reference['cpu_time_s'].sum():.0f} s; wall time of a run / its CPU time: "
                 f"median {(table['wall_time_s'] / table['cpu_time_s']).median():.2f} (machine load).")
    versions = table["record_version"].value_counts().sort_index()
    if len(versions) > 1:
        old = table[table["record_version"] < versions.index.max()]
        counts = {int(k): int(v) for k, v in versions.items()}
        lines.append(f"Mixed record versions {counts} (version: runs): written by older code: "
                     + ", ".join(f"{r.variant}/{r.case_id} ({r.status})" for r in old.itertuples())
                     + ".")
    lines.append("Errors are C_var / C_ref - 1 of the cell's C_eq over the steady cases (reference "
                 "and variant both ok), ± the standard error of the case(s) the statistic comes "
                 "from; CPU / baseline is the variant's total over all its cases.")
    print("\n".join(lines))
    figures = {"reference_cases": len(reference), "reference_not_steady": len(not_steady),
               "variant_runs_flagged": len(flagged),
               "cpu_s": round(float(table["cpu_time_s"].sum()), 1),
               "reference_cpu_s": round(float(reference["cpu_time_s"].sum()), 1)}
    for r in summary.itertuples():
        figures.update({f"{r.variant}_steady_cases_used": int(r.n_used), f"{r.variant}_flagged": int(r.n_flagged),
                        f"{r.variant}_median_abs_error_pct": round(100 * float(r.median_abs_error), 2),
                        f"{r.variant}_max_abs_error_pct": round(100 * float(r.max_abs_error), 2),
                        f"{r.variant}_cpu_s": round(float(r.cpu_time_s), 1),
                        f"{r.variant}_cpu_over_baseline": round(float(r.cpu_rel_baseline), 3),
                        f"{r.variant}_meets_target": bool(r.meets_target)})
    record("record_fidelity", figures, notes=lines[-1])


if __name__ == "__main__":
    main()
