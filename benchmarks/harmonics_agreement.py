"""Effective mass and the force- against the energy-based C_eq on a few cases, both engines (issue 26).

One packing of each fill (poured by LIGGGHTS, replicate 0) shaken as one cell for ``--transient``
+ ``--cycles`` cycles (the transient a floor, as in every case), in LIGGGHTS and in the compiled
DEM. Printed per
case and engine: m_eff / bed mass with its SEM, the force-based C_eq (S_s / (pi W)) and the
energy-based one (the balance in LIGGGHTS, the contacts' dissipation in the DEM) with their SEMs,
z = their difference over the combined SEM, and the case's flags
(:mod:`pidpipe.measurement.harmonics`).

Run: .venv/bin/python benchmarks/harmonics_agreement.py [--cycles 40] [--transient 3]
     [--cases 100:0.3:50 500:5:50 ...]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from pidpipe.cases import CaseSpec
from pidpipe.config import load_config
from pidpipe.config.settings import PourSettings, ShakeSettings
from pidpipe.dem.case import run_dem_case
from pidpipe.liggghts.pour import pour
from pidpipe.liggghts.shake import run_case

CASES = ("100:0.3:50", "500:5:50", "1000:10:50", "100:5:50", "500:5:25", "1000:10:90")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--cycles", type=int, default=40, help="measured cycles")
    parser.add_argument("--transient", type=int, default=3, help="configured transient cycles")
    parser.add_argument("--cases", nargs="+", default=list(CASES), help="freq:accel_g:fill_pct")
    args = parser.parse_args()
    config = load_config()
    config["fidelity"].update(transient_cycles=args.transient, transient_min_time_s=0.0,
                              measured_cycles=args.cycles)
    settings = ShakeSettings.from_config(config)
    print(f"{'case':26s} {'engine':8s} {'m_eff/bed':>16s} {'C_eq force':>18s} "
          f"{'C_eq energy':>18s} {'z':>6s}  flags")
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        packings = {}
        for text in args.cases:
            freq, accel, fill = (float(x) for x in text.split(":"))
            case = CaseSpec(freq, accel, fill)
            if fill not in packings:
                packings[fill] = pour(PourSettings.from_config(config), fill, 0,
                                      scratch / f"pour{fill:g}")
            for engine, record in (
                    ("liggghts", run_case(settings, case, packings[fill], scratch / case.case_id)),
                    ("dem", run_dem_case(settings, case, packings[fill]))):
                h = record.harmonics
                print(f"{case.case_id:26s} {engine:8s} {h['m_eff_ratio']:8.4f} +- "
                      f"{h['m_eff_ratio_sem']:6.4f} {h['ceq_force_cell_ns_m']:9.4g} +- "
                      f"{h['ceq_force_cell_sem_ns_m']:6.2g} {record.ceq_cell_ns_m:9.4g} +- "
                      f"{record.ceq_cell_sem_ns_m:6.2g} {h['ledger_z']:6.2f}  "
                      f"{','.join(record.flags) or '-'}", flush=True)


if __name__ == "__main__":
    main()
