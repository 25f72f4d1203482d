"""CPU cost of the optimisation stage with the default settings, on a synthetic reference-grid table.

The table is the reference grid (5 f x 3 G x 4 r = 60 cases) of a smooth C_eq with a 5 % SEM on
every case; the three default environments, 40 starts per design, 200 bootstrap draws with 2
extra starts each, and the maps' 50 refits. CPU time is the process's (``time.process_time``),
so other jobs on the machine do not inflate it.

    .venv/bin/python benchmarks/bench_optimise.py
"""

from __future__ import annotations

import itertools
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _record import append  # noqa: E402

from pidpipe.config import load_config  # noqa: E402
from pidpipe.design.bootstrap import (  # noqa: E402
    bootstrap_designs,
    loo_rel_error,
    resampled_surrogates,
)
from pidpipe.design.designs import optimise_designs  # noqa: E402
from pidpipe.design.optimisation import Budget  # noqa: E402
from pidpipe.design.surrogate import fit_surrogate  # noqa: E402
from pidpipe.figures.maps import plot_ceq_freq_accel, plot_ceq_freq_fill  # noqa: E402
from pidpipe.steps.design import (  # noqa: E402
    bootstrap_settings,
    environment_objects,
    search_settings,
)
from pidpipe.steps.params import MAP_DRAWS, budget_params  # noqa: E402


def table() -> pd.DataFrame:
    rows = pd.DataFrame(list(itertools.product((50.0, 100.0, 500.0, 750.0, 1000.0), (1.0, 5.0, 10.0),
                                               (25.0, 50.0, 75.0, 90.0))),
                        columns=["freq_hz", "accel_g", "fill_pct"])
    rows["ceq_coupon_ns_m"] = (2.0 * (rows.freq_hz / 100) ** 1.1 * (1 - np.exp(-(rows.accel_g - 0.5) / 3))
                               * (rows.fill_pct / 100) * np.exp(-rows.fill_pct / 60))
    rows["ceq_coupon_sem_ns_m"] = 0.05 * rows["ceq_coupon_ns_m"]
    return rows


def main() -> None:
    config = load_config()
    surrogate = fit_surrogate(table())
    envs = environment_objects(config["environments"])
    budget = Budget(**budget_params(config))
    search = search_settings(config["optimisation"])
    settings = bootstrap_settings(config["optimisation"]["bootstrap"])
    timings = []

    def timed(label, call):
        start = time.process_time()
        value = call()
        timings.append((label, time.process_time() - start))
        return value

    results = timed(f"3 designs x {len(envs)} environments, {search.starts} starts each",
                    lambda: optimise_designs(surrogate, envs, budget, search))
    loo = timed("surrogate leave-one-out error (60 refits)", lambda: loo_rel_error(surrogate))
    draws = timed(f"bootstrap, {settings.draws} draws x {len(results)} designs",
                  lambda: bootstrap_designs(surrogate, results, budget, search, settings, loo=loo))
    timed(f"maps with their uncertainty ({MAP_DRAWS} refits)", lambda: (
        plot_ceq_freq_fill(surrogate, draws=list(resampled_surrogates(surrogate, MAP_DRAWS, 11))),
        plot_ceq_freq_accel(surrogate, draws=list(resampled_surrogates(surrogate, MAP_DRAWS, 11)))))
    lines = ["| part | CPU, s |", "|---|---|"] + [f"| {label} | {cpu:.1f} |" for label, cpu in timings]
    lines += ["", f"{int(draws['ok'].sum())} of {len(draws)} draw optimisations converged; "
              f"surrogate leave-one-out error {100 * loo:.1f} % RMS."]
    append("Optimisation stage: designs and bootstrap at the default settings",
           ".venv/bin/python benchmarks/bench_optimise.py", lines)


if __name__ == "__main__":
    main()
