"""How much of a DEM pour's settling finds its spheres already still? (issue 28)

A pour simulates ``fidelity.settle_time_s`` of settling, the tapping (20 cycles at 100 Hz) and
the settle time again (:mod:`pidpipe.cell.pour_protocol`): 0.5 s at the default 0.15 s, about
four pilot cells' worth of stepping, and the refinement loop of the default DEM campaign pours
some 240 packings. This runs the compiled DEM's pour (:mod:`pidpipe.dem.pour`, the default
config's scenes and timestep) step for step, but in chunks of ``--chunk-s`` seconds, and prints
for each fill and seed when the fastest sphere fell below the settled speed
(:data:`pidpipe.cell.packing.SETTLED_SPEED_M_S`) for good in each settling, and the pour's
simulated time had each settling ended there. It changes no packing: the pour runs its full
protocol.

Run: .venv/bin/python benchmarks/experiments/pour_settle_times.py [--seeds 3] [--chunk-s 0.005]
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from harness import record_text  # noqa: E402

FILLS = (25.0, 50.0, 75.0, 90.0)


def still_from(scene, state, workspace, steps: int, chunk: int, timestep_s: float) -> float:
    """Run ``steps`` steps in chunks; the time (s, from the settling's start) after which the
    fastest sphere stayed at or below the settled speed at every chunk's end (NaN: never)."""
    from pidpipe.cell.packing import SETTLED_SPEED_M_S
    from pidpipe.dem.pour import _max_speeds
    from pidpipe.dem.run import advance

    done, still = 0, float("nan")
    while done < steps:
        k = min(chunk, steps - done)
        advance(scene, state, workspace, k)
        done += k
        if _max_speeds(state)[0] <= SETTLED_SPEED_M_S:
            still = done * timestep_s if np.isnan(still) else still
        else:
            still = float("nan")
    return still


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3, help="replicates per fill")
    parser.add_argument("--chunk-s", type=float, default=0.005, help="check interval, s")
    args = parser.parse_args()
    from pidpipe.cell.pour_protocol import plan_pour
    from pidpipe.config import load_config
    from pidpipe.config.settings import PourSettings
    from pidpipe.dem.pour import _tap, pour_scenes
    from pidpipe.dem.run import start

    config = load_config()
    config["fidelity"]["pour_engine"] = "dem"
    settings = PourSettings.from_config(config)
    lines = ["| fill % | replicate | spheres | 1st settling still after s | 2nd settling still after s "
             "| pour s as run | pour s ended when still |", "|---|---|---|---|---|---|---|"]
    full, early = [], []
    for fill in FILLS:
        for replicate in range(args.seeds):
            plan = plan_pour(settings, fill, replicate)
            still, tapping, shift = pour_scenes(plan)
            scene, state, workspace = start(still, plan.start_m[None] + shift)
            tapping = dataclasses.replace(tapping, accel_g=np.repeat(tapping.accel_g, state.n_batch))
            dt = plan.timestep.timestep_s
            chunk = max(1, round(args.chunk_s / dt))
            first = still_from(scene, state, workspace, plan.settle_steps, chunk, dt)
            _tap(tapping, scene, state, workspace, plan.tap_steps)
            second = still_from(scene, state, workspace, plan.settle_steps, chunk, dt)
            as_run = 2 * plan.settle_period_s + plan.tap_steps * dt
            ended = (np.nan_to_num(first, nan=plan.settle_period_s) + plan.tap_steps * dt
                     + np.nan_to_num(second, nan=plan.settle_period_s))
            full.append(as_run)
            early.append(ended)
            lines.append(f"| {fill:g} | {replicate} | {plan.n_spheres} | {first:.3f} | {second:.3f} "
                         f"| {as_run:.3f} | {ended:.3f} |")
    lines += ["", f"Settled speed checked every {args.chunk_s:g} s; a settling never still counts "
              f"in full. Simulated time, all pours: {sum(early):.2f} s ended when still against "
              f"{sum(full):.2f} s as run ({sum(early) / sum(full):.2f})."]
    record_text("When a DEM pour's spheres are still", "python benchmarks/experiments/pour_settle_times.py"
                + (f" --seeds {args.seeds}" if args.seeds != 3 else "")
                + (f" --chunk-s {args.chunk_s:g}" if args.chunk_s != 0.005 else ""), lines)


if __name__ == "__main__":
    main()
