"""Why the panel check's DEM dissipates less than the C_eq model at 3-4 g: the coupon at the
coupled mode's own states, against the surrogate the panel model reads.

The panel's DEM check (benchmarks/panel_check.py, docs/explanation/panel.md) found the panel
model's particle loss factor 43-52 % above the coupled DEM's at 3.1-3.8 g (241-246 Hz), read at
the coupled states' own f and G. Either the surrogate is off there (it interpolates between the
grid's 100 and 500 Hz and its 2 and 5 g), or a cell on the mode dissipates less than the coupon
the surrogate was fitted to. This runs the coupon itself, in the compiled DEM with the default
config's pilot (cells_per_run x measured_cycles, packings poured by the DEM), at those states,
and prints its C_eq with its SEM beside the surrogate's prediction with its uncertainty (the GP
of the panel check, fitted to tests/fixtures/ceq_table_dem_default_100.csv) and their z.

Run: .venv/bin/python benchmarks/experiments/panel_states_coupon.py [--fill-pct 90]
         [--state F:G ...]
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))   # the harness
sys.path.insert(0, str(ROOT))
from harness import record_text  # noqa: E402

from pidpipe.config import load_config  # noqa: E402
from pidpipe.design.ceq_table import read_ceq_table  # noqa: E402
from pidpipe.design.surrogate import fit_surrogate  # noqa: E402
from pidpipe.refine.candidates import Request  # noqa: E402
from pidpipe.steps.refine_engine import CaseEngine  # noqa: E402

TABLE = ROOT / "tests" / "fixtures" / "ceq_table_dem_default_100.csv"
#: The coupled up sweep's states where the model was highest, and its peak (docs/explanation/panel.md).
STATES = ("241.7:3.15", "246:3.5", "251:4.1", "256:4.3", "262.7:4.76")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fill-pct", type=float, default=90.0)
    parser.add_argument("--state", action="append", help="F:G (Hz, g); repeatable")
    args = parser.parse_args()
    states = [tuple(float(v) for v in s.split(":")) for s in (args.state or STATES)]
    config = load_config(ROOT / "config.yaml")
    config["engine"] = "dem"
    config["fidelity"]["pour_engine"] = "dem"
    table = read_ceq_table(TABLE)
    surrogate = fit_surrogate(table, method="gp", allow_holes=True, source=str(TABLE))
    lines = ["| f (Hz) | G (g) | coupon DEM C_eq (N·s/m) | surrogate (N·s/m) | surrogate / DEM | z |",
             "|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as work:
        engine = CaseEngine.from_config(config, Path(work))
        rows = engine.measure([Request(f, g, args.fill_pct) for f, g in states], [])
    for (f, g), (_, row) in zip(states, rows.iterrows()):
        value, sem = float(row["ceq_coupon_ns_m"]), float(row["ceq_coupon_sem_ns_m"])
        mean, u = (float(x[0]) for x in surrogate.predict_with_uncertainty([f], [g], [args.fill_pct]))
        z = (mean - value) / math.hypot(u, sem)
        lines.append(f"| {f:g} | {g:g} | {value:.4g} ± {sem:.2g} | {mean:.4g} ± {u:.2g} | "
                     f"{mean / value:.3f} | {z:+.2f} |")
    record_text(f"The coupon at the panel check's coupled states ({args.fill_pct:g} % fill)",
                "python benchmarks/experiments/panel_states_coupon.py", lines)


if __name__ == "__main__":
    main()
