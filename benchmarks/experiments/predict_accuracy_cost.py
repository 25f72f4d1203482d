"""What a tighter target would cost, predicted (not measured) from a campaign's case records.

For each case record (written with a target; e.g. kept by ``bench_campaign.py --keep DIR``) it
takes the case's measured variance components (:func:`pidpipe.measurement.adaptive.components_of`)
and where it ended (cells, measured cycles, planned CPU), and lets the allocation plan its steps
to each target (:func:`pidpipe.measurement.allocation.plan_next_step`, the stored LIGGGHTS cost
model, the default caps), assuming the components stay as measured. It prints, per target, the
planned CPU of all cases (the pilot included), how many would reach it, and the median
predicted relative SEM. The case's own measured CPU is printed next to its planned CPU as a check
on the cost model.

Run: .venv/bin/python benchmarks/experiments/predict_accuracy_cost.py DIR [target ...]   (default 0.10 0.05 0.02)
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # benchmarks/: the harness
from harness import record_text as append  # noqa: E402

from pidpipe.cell.scene import CellScene
from pidpipe.config import load_config
from pidpipe.config.settings import Sampling
from pidpipe.measurement.adaptive import MAX_STEPS, components_of
from pidpipe.measurement.case_record import CaseRecord
from pidpipe.measurement.allocation import Limits, plan_next_step
from pidpipe.measurement.cost_model import load_cost_model


def predict(record: dict, target: float, config: dict) -> tuple[float, float, bool]:
    """Planned CPU (s), predicted relative SEM and whether the target is reached, from the pilot on."""
    fidelity = config["fidelity"]
    model = load_cost_model("liggghts")
    per_cycle = CellScene.from_config(config).timestep(record["freq_hz"]).steps_per_cycle
    transient = Sampling.from_config(config).transient_cycles_at(record["freq_hz"])
    spheres = int(record["n_spheres"])

    def run_cpu_s(k: int, n: int) -> float:
        return model.run_cpu_s(k, spheres, per_cycle * (transient + n))

    limits = Limits(int(fidelity["max_cells_per_case"]), int(fidelity["max_measured_cycles"]),
                    float(fidelity["max_case_cpu_s"]), 24)
    components = components_of(CaseRecord.from_dict(record), record["target"]["measured_cycles"])
    cells, cycles = int(fidelity["cells_per_run"]), int(fidelity["measured_cycles"])
    spent = run_cpu_s(cells, cycles)
    value = abs(components.value)
    for _ in range(MAX_STEPS):
        step = plan_next_step(components, cells, cycles, spent, target * value, limits, run_cpu_s,
                              model.pour_cpu_s(spheres))
        if step is None:
            break
        cells, cycles, spent = cells + step.new_cells, step.cycles, spent + step.cpu_s
    sem = components.sem(cells, cycles) / value
    return spent, sem, sem <= target


def main() -> None:
    folder = Path(sys.argv[1])
    targets = [float(t) for t in sys.argv[2:]] or [0.10, 0.05, 0.02]
    config = load_config()
    records = [json.loads(p.read_text()) for p in sorted(folder.glob("*.json"))]
    records = [r for r in records if r.get("status") != "failed" and r.get("target")]
    lines = ["| target | planned CPU s, all cases | cases reaching it | median predicted rel. SEM |",
             "|---|---|---|---|"]
    for target in targets:
        results = [predict(r, target, config) for r in records]
        lines.append(f"| {target:.0%} | {sum(r[0] for r in results):.0f} | "
                     f"{sum(r[2] for r in results)} of {len(results)} | "
                     f"{np.median([r[1] for r in results]):.1%} |")
        print(lines[-1], flush=True)
    lines += ["", "| case | measured CPU s | planned CPU s | rel. SEM | packing std / C_eq | cell SEM over 40 cycles / C_eq |",
              "|---|---|---|---|---|---|"]
    for r in records:
        c = components_of(CaseRecord.from_dict(r))
        lines.append(f"| {r['case_id']} | {r['target']['cpu_time_s']:.1f} | {r['target']['planned_cpu_s']:.1f} | "
                     f"{r['ceq_cell_sem_ns_m'] / r['ceq_cell_ns_m']:.1%} | "
                     f"{np.sqrt(c.packing_var) / c.value:.1%} | {np.sqrt(c.cycle_noise_var / 40) / c.value:.1%} |")
    lines += ["", f"{len(records)} case records from {folder}; predicted with the default caps of "
              "config.yaml and the stored LIGGGHTS cost model, components as measured: a "
              "prediction, not a measurement."]
    append("What a target would cost, predicted from measured variance components",
           "python benchmarks/experiments/predict_accuracy_cost.py " + " ".join(sys.argv[1:]), lines)


if __name__ == "__main__":
    main()
