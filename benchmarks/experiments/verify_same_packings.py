"""Is a verify flag an engine difference or the packings? The loop's own LIGGGHTS verifying
runs replayed in the compiled DEM on the same packings, beside the DEM verify's value.

The LIGGGHTS loop campaign of docs/explanation/refine.md passed its own check (LIGGGHTS runs
at each design's points, 7 cells each), yet the separate DEM verify (each point to a 5 % SEM on
packings of its own, ``benchmarks/verify_dem_5pct.yaml``) put the 750-800 Hz peak design's two
4 g corners at |z| 3.4 and 3.8, the DEM about 8 % above the surrogate. This shakes each named
verifying run of the loop (``results/refine/work/cases/<case>.json``) in the DEM on the very
packings LIGGGHTS shook (:func:`pidpipe.steps.validate.check_case_with_dem`, a paired check) and
prints, per case: LIGGGHTS, the DEM on the same packings, and from ``results/verify.csv`` the DEM
verify's value and the surrogate's, each with its standard error.

Run, in a finished loop campaign's folder that ``snakemake verify`` ran in:
    .venv/bin/python <repo>/benchmarks/experiments/verify_same_packings.py CASE [CASE ...]
e.g. f750Hz_G4_r33.333pct_rep200 f800Hz_G4_r33.333pct_rep200.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))   # the harness
sys.path.insert(0, str(ROOT))
from harness import record_text  # noqa: E402

import pandas as pd  # noqa: E402

from pidpipe.cases import CaseSpec, format_number  # noqa: E402
from pidpipe.config import load_config  # noqa: E402
from pidpipe.config.stages import stage_config  # noqa: E402
from pidpipe.steps.validate import check_case_with_dem  # noqa: E402

WORK = Path("results/refine/work")


def _paired(case_id: str, part: dict, scratch: Path) -> tuple[dict, object]:
    """The loop's LIGGGHTS record of ``case_id`` and the DEM's on its packings."""
    plan = json.loads((WORK / "plans" / f"{case_id}.json").read_text(encoding="utf-8"))
    fill = format_number(plan["fill_pct"])
    packings = [str(WORK / "packings" / f"r{fill}pct_rep{index}.json") for index in plan["packings"]]
    liggghts_path = WORK / "cases" / f"{case_id}.json"
    dem = check_case_with_dem(part, str(liggghts_path), packings, str(scratch / f"{case_id}.json"))
    return json.loads(liggghts_path.read_text(encoding="utf-8")), dem


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("cases", nargs="+", help="verifying runs of the loop (case ids)")
    args = parser.parse_args()
    part = stage_config(load_config("config.yaml"), "case")
    verify = pd.read_csv("results/verify.csv")
    lines = ["| case | LIGGGHTS (loop) | DEM, same packings | DEM / LIGGGHTS | DEM verify, own "
             "packings | surrogate | z of DEM verify |", "|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as scratch:
        for case_id in args.cases:
            liggghts, dem = _paired(case_id, part, Path(scratch))
            case = CaseSpec.from_id(case_id)
            rows = verify[(verify["freq_hz"] == case.freq_hz) & (verify["accel_g"] == case.accel_g)
                          & ((verify["fill_pct"] - case.fill_pct).abs() < 1e-3)]
            l_value, l_sem = liggghts["ceq_coupon_ns_m"], liggghts["ceq_coupon_sem_ns_m"]
            ratio = dem.ceq_coupon_ns_m / l_value
            ratio_sem = ratio * math.hypot(dem.ceq_coupon_sem_ns_m / dem.ceq_coupon_ns_m, l_sem / l_value)
            if rows.empty:
                verify_text = surrogate_text = z_text = "-"
            else:
                row = rows.iloc[0]
                verify_text = f"{row['ceq_coupon_dem_ns_m']:.1f} ± {row['ceq_coupon_dem_sem_ns_m']:.1f}"
                surrogate_text = f"{row['ceq_coupon_surrogate_ns_m']:.1f} ± {row['surrogate_u_ns_m']:.1f}"
                z_text = f"{row['z_combined']:+.2f}"
            lines.append(f"| {case_id} | {l_value:.1f} ± {l_sem:.1f} | {dem.ceq_coupon_ns_m:.1f} ± "
                         f"{dem.ceq_coupon_sem_ns_m:.1f} | {ratio:.3f} ± {ratio_sem:.3f} | "
                         f"{verify_text} | {surrogate_text} | {z_text} |")
    record_text("A verify flag: the engines on the same packings (C_eq, N·s/m)",
                "python benchmarks/experiments/verify_same_packings.py " + " ".join(args.cases),
                lines)


if __name__ == "__main__":
    main()
