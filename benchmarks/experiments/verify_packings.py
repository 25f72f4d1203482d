"""Do verify's DEM cases shake packings of their own, and how calibrated is its z?

Every case of a fill shakes that fill's packings (seed ``fidelity.seed`` + index), so a
verifying case poured with the indices of the campaign's cases is the same cell as theirs: its
packings' offset is the fitted cases' too, and cancels in C_dem - C_s. This reads, in a finished
campaign's folder that ``snakemake verify`` ran in, each verifying case's packings
(``results/verify/packings/``) and says how many have the very sphere positions of a packing the
campaign shook (``results/packings/``, ``results/refine/work/packings/`` and their pools); then
the calibration of ``results/verify.csv``'s z over its distinct cases: RMS z (about 1 when the
uncertainties are right and the errors independent), and RMS of the difference in units of the
DEM's SEM alone and of the surrogate's u_s alone.

Run with the campaigns' folders (each row named by its folder):
    .venv/bin/python benchmarks/experiments/verify_packings.py DIR [DIR ...]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))   # the harness
sys.path.insert(0, str(ROOT))
from harness import record_text  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

CAMPAIGN_PACKINGS = ("results/packings", "results/packings/pool", "results/refine/work/packings",
                     "results/refine/work/packings/pool")


def positions(path: Path) -> tuple:
    """A packing's sphere positions, rounded to 0.1 um, as a hashable key."""
    data = json.loads(path.read_text(encoding="utf-8"))
    return tuple(tuple(round(float(x) * 1e7) for x in p) for p in data["positions_m"])


def shared_packings(folder: Path) -> tuple[int, int]:
    """(verifying packings, those with a campaign packing's positions) of a campaign's folder."""
    campaign = {positions(p) for name in CAMPAIGN_PACKINGS if (folder / name).is_dir()
                for p in (folder / name).glob("*.json")}
    mine = [p for name in ("results/verify/packings", "results/verify/packings/pool")
            if (folder / name).is_dir() for p in (folder / name).glob("*.json")]
    return len(mine), sum(positions(p) in campaign for p in mine)


def row(folder: Path) -> str:
    """The table's row of one campaign."""
    verify = pd.read_csv(folder / "results/verify.csv").drop_duplicates("case_id")
    verify = verify[np.isfinite(verify["z_combined"].to_numpy(dtype=float))]
    d = verify["difference_ns_m"].to_numpy(dtype=float)
    sem = verify["ceq_coupon_dem_sem_ns_m"].to_numpy(dtype=float)
    u = verify["surrogate_u_ns_m"].to_numpy(dtype=float)
    z = verify["z_combined"].to_numpy(dtype=float)
    total, same = shared_packings(folder)
    replicates = ", ".join(sorted({case_id.rsplit("_rep", 1)[1] for case_id in verify["case_id"]}))
    rms = lambda x: float(np.sqrt(np.mean(x**2)))  # noqa: E731
    return (f"| {folder.name} | {len(verify)} | {replicates} | {same} of {total} | {rms(z):.2f} | "
            f"{rms(d / sem):.2f} | {rms(d / u):.2f} | {np.median(u / sem):.2f} | "
            f"{int(np.sum(np.abs(z) > 2))} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", nargs="+", type=Path, help="finished campaigns' folders")
    args = parser.parse_args()
    lines = ["| campaign | verifying cases | replicate | packings with a campaign packing's "
             "positions | RMS z | RMS d / SEM_dem | RMS d / u_s | median u_s / SEM_dem | "
             "\\|z\\| > 2 |", "|---|---|---|---|---|---|---|---|---|"]
    lines += [row(folder) for folder in args.folders]
    record_text("Verify's packings and the calibration of its z",
                "python benchmarks/experiments/verify_packings.py "
                + " ".join(folder.name for folder in args.folders), lines)


if __name__ == "__main__":
    main()
