"""The refinement loop run on a config: at once (``pidpipe refine``) or as workflow steps.

Both write the same files under the refinement's folder (``results/refine``):

``state/``
    the loop's own files (:func:`pidpipe.refine.campaign.refine_files`): its append-only table
    ``ceq_table.csv``, ``rounds.csv``, and, once it stops, ``summary.json``,
    ``verify_points.csv`` and the convergence figure;
``work/``
    the engine's packings, case folders, records and waiting plans
    (:class:`pidpipe.steps.refine_engine.CaseEngine`);
``rounds.csv``, ``summary.json``, ``verify_points.csv``, ``convergence.png`` / ``.pdf``
    the finished loop's outputs (:func:`finish_refine`), and the design table beside the
    campaign's (``results/ceq_table_refined.csv``): what the loop's last round fitted.

``pidpipe refine`` (:func:`refine_campaign`) runs the loop in one process, a round's cases up
to ``--cores`` at a time. The workflow (``workflow/rules/refine.smk``) runs it in steps: each
step (:func:`refine_step`, a Snakemake checkpoint) asks the loop again from its saved table,
with an engine that runs nothing; the loop decides its round as before, finds the rows and
records it has, and stops at the first runs it lacks; the step names them, Snakemake runs each
as a job (:func:`run_refine_plan`, up to ``--cores`` at a time, on a cluster as jobs of their
own), and the next step continues. A round takes at most two steps (its verifying runs, then
its cases). With ``refine.run_cases: in_step`` (the DEM's default) the step runs the cases
itself, round after round, and one step is the whole loop. The loop's decisions depend only on
its table, so a killed campaign resumes with only the missing runs.
"""

from __future__ import annotations

import json
import logging
import shutil
from pathlib import Path
from typing import Callable

import pandas as pd

from pidpipe.errors import PidpipeError
from pidpipe.files import write_atomic
from pidpipe.steps.params import REFINED_TABLE
from pidpipe.steps.refine_engine import CaseEngine, Plan, RunsNeeded

logger = logging.getLogger("pidpipe.refine")

#: A step's ``status``: the loop stopped, or it waits for the runs the step names.
STEP_DONE, STEP_RUNS_NEEDED = "done", "runs needed"


def refine_campaign(config: dict, grid_table: str | Path, refine_dir: str | Path,
                    on_round: Callable | None = None, cores: int = 1):
    """Run or resume the refinement loop of a validated config in this process.

    Parameters
    ----------
    config : dict
        A validated config (:func:`pidpipe.config.load_config`); its ``engine`` runs the cases.
    grid_table : path
        The campaign's C_eq table (``results/ceq_table.csv``), read when the loop has no table
        of its own yet.
    refine_dir : path
        The refinement's folder (``results/refine``; see the module's text).
    on_round : callable, optional
        ``on_round(record)`` after each round.
    cores : int
        A round's cases run up to this many at a time (:class:`CaseEngine`).

    Returns
    -------
    (Outcome, CaseEngine)
        The loop's outcome, and the engine (its ``runs``: the cases it shook in this call).
    """
    with CaseEngine.from_config(config, Path(refine_dir) / "work", cores) as engine:
        outcome = _run_loop(config, grid_table, refine_dir, engine, on_round)
    finish_refine(refine_dir, Path(refine_dir).parent / Path(REFINED_TABLE).name)
    return outcome, engine


def refine_step(config: dict, grid_table: str | Path, refine_dir: str | Path,
                step_path: str | Path, cores: int = 1) -> dict:
    """One step of the workflow's loop: run the loop until it stops or lacks runs; say which.

    With ``refine.run_cases`` in_step (:meth:`pidpipe.config.refine.RefineSettings.runs_in_step`)
    the step runs the cases itself, ``cores`` at a time, and lacks none: one step is the whole
    loop.

    Writes ``step_path`` (JSON): ``{"status": "done", "stopped_by": ..., "open": [...]}`` or
    ``{"status": "runs needed", "runs": [case ids]}``, the plans of those runs being in
    ``refine_dir/work/plans/<case id>.json``.

    Parameters
    ----------
    config : dict
        A validated config.
    grid_table, refine_dir
        As :func:`refine_campaign`.
    step_path : path
        The step's file (``results/refine/steps/<n>.json``).
    cores : int
        Cases run at most this many at a time when the step runs them.

    Returns
    -------
    dict
        What the step wrote.
    """
    from pidpipe.config.refine import RefineSettings

    in_step = RefineSettings.from_config(config).runs_in_step(config.get("engine", "liggghts"))
    engine = CaseEngine.from_config(config, Path(refine_dir) / "work", cores,
                                    run_missing=in_step)
    try:
        with engine:
            outcome = _run_loop(config, grid_table, refine_dir, engine, _log_round)
    except RunsNeeded as needed:
        step = {"status": STEP_RUNS_NEEDED, "runs": needed.case_ids}
        logger.info("refine: %d run(s) needed: %s", len(needed.case_ids),
                    ", ".join(needed.case_ids))
    else:
        step = {"status": STEP_DONE, "stopped_by": outcome.stopped_by, "open": outcome.open}
        if in_step:
            step["runs_in_step"] = list(engine.runs)
            spent = engine.measured
            logger.info("refine: the step ran %d case(s); measured: shaking %.1f CPU-s, pours "
                        "%.1f CPU-s (%.1f s wall, summed over the workers)", len(engine.runs),
                        spent["shake_cpu_s"], spent["pour_cpu_s"], spent["pour_wall_s"])
        logger.info("refine: stopped: %s", outcome.stopped_by)
        for line in outcome.open:
            logger.info("refine: open: %s", line)
    text = json.dumps(step, indent=1) + "\n"
    write_atomic(step_path, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))
    return step


def read_step(path: str | Path) -> dict:
    """A step's file (:func:`refine_step`)."""
    try:
        step = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError) as error:
        raise PidpipeError(f"refinement step {path}: cannot be read ({error})") from error
    if step.get("status") not in (STEP_DONE, STEP_RUNS_NEEDED):
        raise PidpipeError(f"refinement step {path}: status {step.get('status')!r} is neither "
                           f"{STEP_DONE!r} nor {STEP_RUNS_NEEDED!r}")
    return step


def run_refine_plan(config: dict, refine_dir: str | Path, case_id: str) -> Path:
    """Run one waiting plan of the loop (a workflow job); return its record's path.

    Parameters
    ----------
    config : dict
        A validated config.
    refine_dir : path
        The refinement's folder; the plan is ``work/plans/<case_id>.json``.
    case_id : str
        The plan's case id.
    """
    engine = CaseEngine.from_config(config, Path(refine_dir) / "work")
    plan_path = engine.plan_path(case_id)
    if not plan_path.is_file():
        raise PidpipeError(f"refinement run {case_id}: no plan at {plan_path}; run the "
                           "refinement from its first step (snakemake refine)")
    plan = Plan.read(plan_path)
    if plan.case.case_id != case_id:
        raise PidpipeError(f"refinement plan {plan_path} is for {plan.case.case_id}, not {case_id}")
    engine.run_plan(plan)
    return engine.record_path(case_id)


def finish_refine(refine_dir: str | Path, design_table: str | Path) -> None:
    """The finished loop's outputs: its state's ``rounds.csv``, ``summary.json``,
    ``verify_points.csv`` and figure copied into ``refine_dir``, and the table its last round fitted as ``design_table`` (the
    latest row of every case, verifying runs left out; columns of ``results/ceq_table.csv``
    and the loop's, ``source`` saying where each row came from)."""
    from pidpipe.refine.outputs import read_table, write_table
    from pidpipe.refine.table import fit_table, last_round

    refine_dir = Path(refine_dir)
    state = refine_dir / "state"
    needed = ["ceq_table.csv", "rounds.csv", "summary.json", "verify_points.csv", "convergence.png",
              "convergence.pdf"]
    missing = [name for name in needed if not (state / name).is_file()]
    if missing:
        raise PidpipeError(f"the refinement in {state} has not finished: no {', '.join(missing)}; "
                           "run snakemake refine")
    for name in needed[1:]:
        write_atomic(refine_dir / name,
                     lambda tmp, source=state / name: shutil.copyfile(source, tmp))
    table = read_table(state / "ceq_table.csv")
    write_table(fit_table(table, last_round(table) + 1), design_table)


def _run_loop(config: dict, grid_table, refine_dir, engine: CaseEngine, on_round):
    """The loop of the config's settings on ``engine``, its state in ``refine_dir/state``."""
    from pidpipe.config.refine import RefineSettings
    from pidpipe.config.sections import Settings
    from pidpipe.design.surrogate import fit_surrogate
    from pidpipe.refine.campaign import refine_files
    from pidpipe.steps.design import search_settings

    settings, refine = Settings.from_config(config), RefineSettings.from_config(config)
    if not settings.environments:
        raise PidpipeError("no environments to design for (config key environments)")

    def fit(table: pd.DataFrame, start=None):
        # a fantasy's refit starts from the model before it (a few rows apart), without restarts
        return fit_surrogate(table, method="gp", allow_holes=True, source=str(grid_table),
                             kernel_start=None if start is None else start.options["kernel_theta"])

    return refine_files(grid_table, Path(refine_dir) / "state", fit, engine.measure,
                        engine.verify, engine.cost, list(settings.environments), settings.budget,
                        search_settings(settings.optimisation.as_params()), refine,
                        settings.verify.flag_z, on_round=on_round, mapper=engine.map)


def _log_round(record) -> None:
    """Log a finished round (the workflow's steps)."""
    from pidpipe.refine.report import format_round

    for line in format_round(record).splitlines():
        logger.info("refine: %s", line)
