"""Resources that a cluster job of one case asks for: its time limit from the planned steps.

A case's pilot run takes ``steps = cycles x steps_per_cycle`` time steps (the timestep plan of
:meth:`pidpipe.cell.scene.CellScene.timestep`; cycles = transient + measured). With
``fidelity.target_relative_sem`` set, :func:`pidpipe.measurement.adaptive.run_to_target` plans
further runs (more cells, more cycles) only while their planned CPU stays within
``fidelity.max_case_cpu_s``; the limit adds that cap, so it covers the worst case, since a job
that SLURM stops at its limit loses all of its work.

Wall time of the job, s: ``SETUP_S + steps * (US_PER_STEP_FIRST_CELL + (cells - 1) *
US_PER_STEP_EXTRA_CELL) * 1e-6`` (+ ``max_case_cpu_s`` with a target), times :data:`MARGIN`,
times the attempt (a job killed at its limit is retried with a longer one), in whole minutes
(SLURM's ``--time``).
"""

from __future__ import annotations

import math

from pidpipe.cases import CaseSpec
from pidpipe.cell.scene import CellScene
from pidpipe.config.settings import ShakeSettings

#: Seconds of a case job besides its time steps: Python and pidpipe start-up, deck and mesh,
#: LIGGGHTS start-up and the parse. Measured Dec 2026 on the reduced campaign (2 cores shared):
#: job time (Snakemake benchmark) minus LIGGGHTS wall time was 2.3 to 4.5 s per case.
SETUP_S = 10.0
#: Microseconds of LIGGGHTS wall time per step of a one-cell run (5 or 11 spheres): 35 to 48 us on
#: the reduced campaign (Dec 2026, 2 shared cores; benchmarks/bench_slurm.py prints it).
US_PER_STEP_FIRST_CELL = 50.0
#: Microseconds per step that each further cell of the run adds: the default campaign (7 cells)
#: took 102 to 126 us per planned step per case, start-up included (benchmarks/results.md,
#: "Whole campaign", 2026-11-23 05:40), so (126 - 48) / 6 = 13 us.
US_PER_STEP_EXTRA_CELL = 13.0
#: Factor on the estimate: a fuller cell or a busier node is slower than the measured means.
MARGIN = 2.0


def case_planned_steps(settings: ShakeSettings, case: CaseSpec) -> int:
    """Time steps of a case's pilot run (its only run without a target SEM).

    Parameters
    ----------
    settings : ShakeSettings
        The case's settings (the scene's timestep and the sampling are read).
    case : CaseSpec

    Returns
    -------
    int
        (transient + measured) x steps_per_cycle.
    """
    sampling = settings.sampling
    steps_per_cycle = CellScene.of(settings).timestep(case.freq_hz).steps_per_cycle
    transient = sampling.transient_cycles_at(case.freq_hz)
    return steps_per_cycle * (transient + sampling.measured_cycles)


def case_wall_time_s(settings: ShakeSettings, case: CaseSpec) -> float:
    """Longest expected wall time of a case job, s (no margin): start-up, the pilot's planned
    steps and, with a target SEM, the CPU cap of its further runs."""
    cells = settings.sampling.cells_per_run
    us_per_step = US_PER_STEP_FIRST_CELL + (cells - 1) * US_PER_STEP_EXTRA_CELL
    further = settings.sampling.max_case_cpu_s if settings.sampling.target_relative_sem else 0.0
    return SETUP_S + case_planned_steps(settings, case) * us_per_step * 1e-6 + further


def case_runtime_min(settings: ShakeSettings, case: CaseSpec, attempt: int = 1) -> int:
    """The time limit of a case job, whole minutes: :func:`case_wall_time_s` x MARGIN x attempt.

    Parameters
    ----------
    settings : ShakeSettings
    case : CaseSpec
    attempt : int
        Snakemake's attempt of the job (1 first; a retry gets a longer limit).

    Returns
    -------
    int
        At least 1.
    """
    if attempt < 1:
        raise ValueError(f"attempt must be at least 1, got {attempt}")
    return max(1, math.ceil(case_wall_time_s(settings, case) * MARGIN * attempt / 60.0))


def refine_run_runtime_min(planned_cpu_s: float, attempt: int = 1) -> int:
    """The time limit of a refinement run's job, whole minutes: (SETUP_S + the planned engine
    CPU of its plan, s, pours included) x MARGIN x attempt (:meth:`pidpipe.steps.refine_engine.
    CaseEngine.plan_cpu_s`; a job runs one plan on one core, so its CPU is its wall time)."""
    if attempt < 1:
        raise ValueError(f"attempt must be at least 1, got {attempt}")
    if not math.isfinite(planned_cpu_s) or planned_cpu_s < 0:
        raise ValueError(f"planned CPU must be a finite number >= 0 s, got {planned_cpu_s!r}")
    return max(1, math.ceil((SETUP_S + planned_cpu_s) * MARGIN * attempt / 60.0))


#: Minutes a refinement step allows per fit and optimisation of a round (measured 4-12 s on the
#: DEM's default campaign, docs/explanation/refine.md).
ROUND_FIT_MIN = 1.0


def refine_step_runtime_min(max_cpu_s: float, max_rounds: int, threads: int, runs_cases: bool,
                            attempt: int = 1) -> int:
    """The time limit of a refinement step's job, whole minutes.

    A step that only decides refits once: (SETUP_S x MARGIN / 60 + ROUND_FIT_MIN) x attempt. One
    that runs the loop's cases (``refine.run_cases: in_step``) may spend the loop's whole budget
    of planned CPU on ``threads`` cores and refit every round: (SETUP_S + max_cpu_s / threads) x
    MARGIN x attempt / 60 + max_rounds x ROUND_FIT_MIN x attempt.

    Parameters
    ----------
    max_cpu_s : float
        The loop's budget of planned engine CPU (``refine.max_cpu_s``), s.
    max_rounds : int
        The loop's rounds at most (``refine.max_rounds``).
    threads : int
        The step's cores.
    runs_cases : bool
        Whether the step runs the cases itself.
    attempt : int
        Snakemake's attempt (1 at first).
    """
    if attempt < 1:
        raise ValueError(f"attempt must be at least 1, got {attempt}")
    if threads < 1:
        raise ValueError(f"threads must be at least 1, got {threads}")
    if not runs_cases:
        return max(1, math.ceil((SETUP_S * MARGIN / 60.0 + ROUND_FIT_MIN) * attempt))
    minutes = ((SETUP_S + max_cpu_s / threads) * MARGIN / 60.0 + max_rounds * ROUND_FIT_MIN)
    return max(1, math.ceil(minutes * attempt))
