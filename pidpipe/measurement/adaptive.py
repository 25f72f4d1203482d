"""Measure until a target standard error is reached (with a cap), instead of a fixed cycle count.

With ``fidelity.target_relative_sem`` set, a case first runs the configured ``measured_cycles``
(the pilot). If C_eq's standard error is still above the target, the case is run again with
n = n_pilot * (SEM / target)^2 * :data:`SAFETY` measured cycles (the SEM falls as 1/sqrt(n)),
capped at ``fidelity.max_measured_cycles``, and so on until the target or the cap is reached.
The same seed and packing make every stage's first cycles identical to the previous stage's
(LIGGGHTS is deterministic on one machine), so a stage only adds cycles; the pilot's CPU time is
the price of not guessing. A C_eq that is not above zero cannot reach a relative target and is
not extended. The record says which stages ran and whether the target was reached, and its CPU
time is the sum over the stages.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Callable, Sequence

from pidpipe.cases import CaseSpec
from pidpipe.cell.packing import Packing
from pidpipe.config.settings import ShakeSettings

SAFETY = 1.2
"""Margin on the cycles that the 1/sqrt(n) law says are needed."""

MAX_STAGES = 4
"""Runs of one case at most (the pilot included)."""


def cycles_for_target(measured_cycles: int, relative_sem: float, target: float, cap: int) -> int:
    """Measured cycles that should bring the relative SEM down to ``target``, at most ``cap``.

    Parameters
    ----------
    measured_cycles : int
        Cycles measured so far.
    relative_sem : float
        SEM / C_eq after them.
    target : float
        Target SEM / C_eq.
    cap : int
        Largest number of measured cycles.

    Returns
    -------
    int
        At least ``measured_cycles + 1`` (unless already at the cap), at most ``cap``.
    """
    wanted = math.ceil(measured_cycles * (relative_sem / target) ** 2 * SAFETY)
    return min(cap, max(wanted, measured_cycles + 1))


def run_to_target(settings: ShakeSettings, case: CaseSpec, packings: Packing | Sequence[Packing],
                  workdir: str | Path,
                  run: Callable[[ShakeSettings, CaseSpec, Packing | Sequence[Packing], Path], dict]
                  ) -> dict:
    """Run a case, extending its measured window until the target relative SEM (if any) is met.

    Parameters
    ----------
    settings : ShakeSettings
        The case's settings; ``sampling.target_relative_sem`` (None: one run, as configured)
        and ``sampling.max_measured_cycles``.
    case, packings, workdir
        As for ``run``.
    run : callable
        ``run(settings, case, packings, workdir) -> record``
        (:func:`pidpipe.liggghts.shake.run_case` or :func:`pidpipe.dem.case.run_dem_case`).

    Returns
    -------
    dict
        The last stage's record, with ``target`` = {relative_sem, reached, stages (measured
        cycles of each run), cpu_time_s (all stages)}.
    """
    sampling = settings.sampling
    target = sampling.target_relative_sem
    record = run(settings, case, packings, Path(workdir))
    if target is None:
        return record
    cap = sampling.max_measured_cycles
    stages = [sampling.measured_cycles]
    cpu = [record["engine"]["cpu_time_s"]]
    while len(stages) < MAX_STAGES:
        value, sem = record["ceq_cell_ns_m"], cycle_sem(record)
        if not (value > 0.0 and math.isfinite(sem)) or sem <= target * value or stages[-1] >= cap:
            break
        stages.append(cycles_for_target(stages[-1], sem / value, target, cap))
        staged = replace(settings, sampling=replace(sampling, measured_cycles=stages[-1]))
        record = run(staged, case, packings, Path(workdir))
        cpu.append(record["engine"]["cpu_time_s"])
    value, sem = record["ceq_cell_ns_m"], record["ceq_cell_sem_ns_m"]
    record["target"] = {"relative_sem": target, "reached": bool(value > 0.0 and sem <= target * value),
                        "stages": stages, "cpu_time_s": float(sum(cpu))}
    record["fidelity"]["measured_cycles"] = stages[-1]
    return record


def cycle_sem(record: dict) -> float:
    """The part of a record's standard error that more cycles reduce, N s/m.

    For k cells in one run the reported error may be the spread between the cells' packings
    (:func:`pidpipe.measurement.cells.summarise_cells`), which longer runs do not shrink; the
    target extends a run by its cycle-to-cycle error only, and ``reached`` is judged on the
    reported one.
    """
    return record["ceq_cell_cycle_sem_ns_m"]
