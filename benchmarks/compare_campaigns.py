"""The design-driven loop against the uniform target, on one machine (issue 28): what each
campaign cost and how good its designs are.

Reads two finished campaigns, each run by ``bench_campaign.py --workdir DIR`` (its
``bench_campaign.json`` has the wall and engine CPU) and then ``snakemake --cores 2 verify``
in DIR (``results/verify.csv``): the uniform one (``refine.enabled: false`` and
``fidelity.target_relative_sem: 0.05``) and the loop's (``refine.enabled: true``, the grid's
pilots only). For each it prints

- the wall time on the cores it had and the CPU of every process (pours too), from
  ``bench_campaign.json``; the engine CPU of every case it ran, the loop's runs included, from
  the records (``results/cases``, ``results/refine/work/cases``);
- each design's total C_eq with its 95 % interval, computed the same way for both: the GP
  fitted to the table the designs rest on (``ceq_table_refined.csv`` when the loop ran, else
  ``ceq_table.csv``), the designs optimised on it, the interval from its predictive
  uncertainty (:func:`pidpipe.refine.intervals.design_intervals`);
- verify's worst |z| per environment (``results/verify.csv``: the same verify stage on both);
- for the loop, what stopped it and what it left open (``results/refine/summary.json``).

``--reused-pilots``: the campaigns' downstream stages were rerun on their finished cases
(``snakemake --forcerun collect_table`` with a changed code, the loop's folder
``results/refine`` removed so that the loop reran all its rounds): the engine CPU, from the
records, is still every case's, but ``bench_campaign.json``'s wall and CPU of every process are
of the first run, so they are left out.

Run: .venv/bin/python benchmarks/compare_campaigns.py UNIFORM_DIR LOOP_DIR [--reused-pilots]
Writes benchmarks/records/compare_campaigns.json.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd
from harness import record


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("uniform", type=Path, help="the uniform-target campaign's folder")
    parser.add_argument("loop", type=Path, help="the refinement loop's campaign's folder")
    parser.add_argument("--reused-pilots", action="store_true",
                        help="stages rerun on finished cases: leave out the first run's wall and "
                             "CPU of every process")
    args = parser.parse_args()
    # the first run's timings, left out when only the stages after the cases were rerun
    first_run = {"cpu_all_processes_s", "wall_s"} if args.reused_pilots else set()
    figures, lines = {}, []
    summaries = {}
    for name, work in (("uniform", args.uniform), ("loop", args.loop)):
        summary = campaign_summary(work)
        summaries[name] = summary
        for key, value in summary["figures"].items():
            if key not in first_run:
                figures[f"{name}_{key}"] = value
    for key in ("engine_cpu_s", "cpu_all_processes_s", "wall_s"):
        if key in first_run:
            continue
        u, l = summaries["uniform"]["figures"][key], summaries["loop"]["figures"][key]
        figures[f"loop_over_uniform_{key.removesuffix('_s')}_ratio"] = round(l / u, 3)
    lines.append("| | uniform target | refinement loop | loop / uniform |")
    lines.append("|---|---|---|---|")
    for key, label in (("wall_s", "wall, s"), ("engine_cpu_s", "engine CPU of the cases, s"),
                       ("cpu_all_processes_s", "CPU of every process, s"),
                       ("cases_run", "cases run")):
        if key in first_run:
            continue
        u, l = summaries["uniform"]["figures"][key], summaries["loop"]["figures"][key]
        lines.append(f"| {label} | {u:g} | {l:g} | {l / u:.2f} |")
    lines += ["", "| environment | design | uniform: total C_eq N s/m (95 % half-width) | "
              "loop: total C_eq N s/m (95 % half-width) |", "|---|---|---|---|"]
    uniform, loop = summaries["uniform"]["designs"], summaries["loop"]["designs"]
    for key in uniform:
        u, l = uniform[key], loop.get(key)
        lines.append(f"| {key[0]} | {key[1]} | {u['total']:.4g} (+-{100 * u['half']:.1f} %) | "
                     + (f"{l['total']:.4g} (+-{100 * l['half']:.1f} %) |" if l else "- |"))
    narrower = sum(loop[k]["half"] <= uniform[k]["half"] for k in uniform if k in loop)
    figures["loop_designs_at_least_as_narrow"] = int(narrower)
    figures["designs"] = len(uniform)
    lines += ["", f"Designs whose interval is at least as narrow with the loop: {narrower} of "
              f"{len(uniform)}.", "", "| environment | uniform: worst verify abs z | "
              "loop: worst verify abs z |", "|---|---|---|"]
    for env in summaries["uniform"]["verify"]:
        u = summaries["uniform"]["verify"][env]
        l = summaries["loop"]["verify"].get(env, float("nan"))
        lines.append(f"| {env} | {u:.2f} | {l:.2f} |")
    ratio, pairs = same_run_cpu_ratio(args.uniform, args.loop)
    figures["same_runs_uniform_over_loop_cpu_ratio"] = ratio
    figures["same_runs"] = pairs
    lines += ["", f"The machine was the same for both: {pairs} grid runs made identically in both "
              f"campaigns (same case, cells and measured cycles) cost uniform / loop = {ratio:.2f} "
              f"engine CPU (median)."]
    stop = summaries["loop"].get("refine")
    if stop:
        lines += ["", f"The loop stopped: {stop['stopped_by']} after rounds "
                  f"{stop['rounds_run'][0]}-{stop['rounds_run'][-1]}, planned CPU "
                  f"{stop['planned_cpu_s']:.0f} s."]
        lines += [f"- open: {line}" for line in stop["open"]]
    print("\n".join(lines))
    record("compare_campaigns", figures, notes=f"uniform {args.uniform.name}, loop "
           f"{args.loop.name}; each campaign's own bench_campaign.json gives its load average"
           + ("; downstream stages rerun on the finished pilots (--reused-pilots): no wall"
              if args.reused_pilots else ""))


def campaign_summary(work: Path) -> dict:
    """A finished campaign's cost, design intervals and verify z."""
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
    from pidpipe.config import load_config
    from pidpipe.config.sections import Settings
    from pidpipe.design.ceq_table import read_ceq_table
    from pidpipe.design.designs import optimise_designs
    from pidpipe.design.surrogate import fit_surrogate
    from pidpipe.refine.intervals import design_intervals
    from pidpipe.steps.design import search_settings

    bench = json.loads((work / "bench_campaign.json").read_text())
    config = load_config(work / "config.yaml")
    settings = Settings.from_config(config)
    refined = work / "results" / "ceq_table_refined.csv"
    table_path = refined if refined.is_file() else work / "results" / "ceq_table.csv"
    model = fit_surrogate(read_ceq_table(table_path), method="gp", allow_holes=True,
                          source=str(table_path))
    search = search_settings(settings.optimisation.as_params())
    results = optimise_designs(model, list(settings.environments), settings.budget, search)
    designs = {(i.environment, i.kind): {"total": i.total_ceq_ns_m,
                                          "half": i.half_width_fraction}
               for i in design_intervals(model, results, search.rule)}
    verify = pd.read_csv(work / "results" / "verify.csv")
    worst = {env: float(np.nanmax(np.abs(group["z_combined"].to_numpy(dtype=float))))
             for env, group in verify.groupby("environment", sort=False)}
    # engine CPU from the records themselves: a loop resumed after the benchmark (a larger
    # budget) adds runs that bench_campaign.json does not count
    from bench_campaign import case_row

    records = [json.loads(p.read_text()) for folder in ("cases", "refine/work/cases")
               for p in (work / "results" / folder).glob("*.json")]
    engine_cpu = round(float(sum(case_row(r)["cpu_s"] for r in records
                                 if r.get("status") != "failed")), 1)
    figures = {"wall_s": bench["wall_s"], "engine_cpu_s": engine_cpu,
               "cpu_all_processes_s": bench["cpu_all_processes_s"],
               "cases_run": len(records),
               "verify_worst_abs_z": round(max(worst.values()), 2),
               "design_half_width_max_pct": round(100 * max(d["half"] for d in designs.values()),
                                                  1)}
    for (env, kind), d in designs.items():
        figures[f"{_slug(env)}_{kind}_half_width_pct"] = round(100 * d["half"], 1)
    for env, z in worst.items():
        figures[f"{_slug(env)}_verify_worst_abs_z"] = round(z, 2)
    summary_path = work / "results" / "refine" / "summary.json"
    refine = json.loads(summary_path.read_text()) if summary_path.is_file() else None
    return {"figures": figures, "designs": designs, "verify": worst, "refine": refine}


def same_run_cpu_ratio(uniform: Path, loop: Path) -> tuple[float, int]:
    """The median ratio of engine CPU between the two campaigns' grid records of the same case
    made with the same seeds and measured cycles (the uniform target's pilots that it did not
    extend, against the loop's full pilots), and how many there were: a check that the two
    campaigns ran on equally fast cores."""
    from bench_campaign import case_row

    ratios = []
    for path in (uniform / "results" / "cases").glob("*.json"):
        other = loop / "results" / "cases" / path.name
        if not other.is_file():
            continue
        u, l = json.loads(path.read_text()), json.loads(other.read_text())
        same = (u["fidelity"].get("seeds") == l["fidelity"].get("seeds")
                and u.get("n_cycles") == l.get("n_cycles"))
        if same and u.get("status") != "failed" and l.get("status") != "failed":
            ratios.append(case_row(u)["cpu_s"] / case_row(l)["cpu_s"])
    return (round(float(np.median(ratios)), 2) if ratios else float("nan")), len(ratios)


def _slug(text: str) -> str:
    """An environment's name as part of a figure's name."""
    return "".join(c if c.isalnum() else "_" for c in text).strip("_").replace("__", "_")


if __name__ == "__main__":
    main()
