"""Realisations of the same packings: how far apart can runs of identical physics land? (issue 5)

bench_scene.py compares the same replicate packings shaken alone and in patches. Runs of the
same physics differ only in rounding, and DEM trajectories diverge from there, so their
averages differ by "realisation noise". To tell that apart from any effect of the scene, this
shakes replicate packings 0-18 of the scene study alone three more times, each a different
rounding of the same physics:

- ``nudged``: the cell moved by 1 nm in x;
- ``translated``: the cell moved to the position of the 7-cell patch's cell 1;
- ``flipped``: at the origin, with every wall triangle reversed (LIGGGHTS' walls must act from
  both sides: a shared wall of a patch faces only one of its cells);

and tabulates the mean C_eq over the 19 packings of each realisation next to those of
bench_scene.py (alone at the origin, the 19-cell patch, the coupon's first 19 cells), with the
paired differences (mean +- SE over packings). Run bench_scene.py first.

Run: .venv/bin/python benchmarks/experiments/bench_scene_realisations.py [--case 500:5]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # benchmarks/: the harness
from harness import record_text as append  # noqa: E402

from pidpipe.cell.patch import ring_centres
from pidpipe.cell.scene import CellScene
from pidpipe.config import load_config
from pidpipe.config.settings import PourSettings, ShakeSettings
from pidpipe.liggghts.patch_run import run_patch
from pidpipe.dem.pouring import replicate_packings
from pidpipe.studies.scene import usable_packings

WORK = Path(__file__).resolve().parents[2] / "results" / "work" / "scene"
PACKINGS = 19


def _ceq(record: dict, n: int) -> np.ndarray:
    return np.array([cell["ceq_cell_ns_m"] for cell in record["cells"][:n]])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", default="500:5", help="freq:accel")
    args = parser.parse_args(argv)
    freq, accel = (float(v) for v in args.case.split(":"))
    tag = f"f{freq:g}Hz_G{accel:g}"
    config = load_config()
    records = WORK / "records"
    poured, _ = replicate_packings(PourSettings.from_config(config), float(config["scene"]["fill_pct"]), PACKINGS,
                                   WORK / "packings")
    packings, refused = usable_packings(poured)
    if refused or len(packings) < PACKINGS:
        raise SystemExit(f"replicates {[k for k, _ in refused]} are refused; this check needs the "
                         f"first {PACKINGS} to be usable, as bench_scene.py's cells 0-{PACKINGS - 1}")
    realisations = {
        "alone at the origin (bench_scene)": np.array(
            [json.loads((records / f"{tag}_single{k}.json").read_text())["cells"][0]["ceq_cell_ns_m"]
             for k in range(PACKINGS)]),
        "19-cell patch (bench_scene)": _ceq(json.loads((records / f"{tag}_patch19.json").read_text()), PACKINGS),
        "coupon, cells 0-18 (bench_scene)": _ceq(json.loads((records / f"{tag}_coupon.json").read_text()), PACKINGS),
    }
    cell = CellScene.from_config(config).cell
    variants = {"alone, nudged by 1 nm": (np.array([[1e-9, 0.0]]), False),
                "alone, at the 7-cell patch's cell 1": (ring_centres(cell, 1)[1:2], False),
                "alone at the origin, walls flipped": (np.zeros((1, 2)), True)}
    contained = True
    for name, (centre, flip) in variants.items():
        key = name.split(",")[-1].strip().split()[0]
        runs = [run_patch(ShakeSettings.from_config(config), freq, accel, [packings[k]], centre,
                          WORK / "runs" / tag / f"realisation_{key}" / f"single{k}",
                          f"{tag}_{key}{k}", flip_normals=flip) for k in range(PACKINGS)]
        contained &= all(run["contained"] for run in runs)
        realisations[name] = np.array([run["cells"][0]["ceq_cell_ns_m"] for run in runs])
    base = realisations["alone at the origin (bench_scene)"]
    lines = ["| realisation of packings 0-18 | mean C_eq per cell (N s/m) | minus alone at the origin, "
             "paired (mean +- SE) | identical cells |", "|---|---|---|---|"]
    for name, values in realisations.items():
        diff = values - base
        se = diff.std(ddof=1) / math.sqrt(diff.size)
        lines.append(f"| {name} | {values.mean():.4f} | {diff.mean():+.4f} +- {se:.4f} | "
                     f"{int(np.sum(diff == 0.0))} |")
    table = np.array(list(realisations.values()))
    within = float(np.sqrt(np.mean(table.var(axis=0, ddof=1))))
    lines += ["", f"{freq:g} Hz, {accel:g} g, fidelity of config.yaml. Spread of one packing's C_eq over "
              f"the {len(realisations)} realisations (rms over packings): {within:.4f} N s/m, so a "
              f"mean over {PACKINGS} packings should scatter by about {within / math.sqrt(PACKINGS):.4f}; "
              f"the realisation means scatter by {table.mean(axis=1).std(ddof=1):.4f}. Spheres in their "
              f"cells at every cycle end in every run: {'yes' if contained else 'NO'}."]
    append(f"Scene: realisations of the same packings at {freq:g} Hz, {accel:g} g (issue 5)",
           "python benchmarks/experiments/bench_scene_realisations.py " + " ".join(sys.argv[1:] if argv is None else argv),
           lines)


if __name__ == "__main__":
    main()
