"""The Snakemake campaign's steps: one function per workflow script, and the C_eq aggregation.

Each workflow script (``workflow/scripts/*.py``) calls :func:`run_step` with one of the step
functions below. :func:`run_step` logs to the rule's log file and to stderr and turns a
:class:`~pidpipe.errors.PidpipeError` into its message and exit status 1, without a traceback.

Failure policy (see also the Snakefile header)
----------------------------------------------
- A case whose LIGGGHTS run fails (:class:`~pidpipe.errors.EngineError` or
  :class:`~pidpipe.errors.ParseError` from the run or its output) is run once more; if it fails
  again it does not stop the campaign: :func:`simulate_case` writes a record with ``status: failed`` and the message (which names
  the case, the LIGGGHTS screen file and the rule's log), logs it and returns normally, so every
  other case still runs and the C_eq table is still written. The table keeps the failed row with
  NaN values; the surrogate refuses the hole that it leaves (it never interpolates over it) and
  names the case. To retry a failed case, delete its record and run again.
- A missing LIGGGHTS binary, a packing that does not fit or has not settled
  (:class:`~pidpipe.errors.PackingError`), a bad config (:class:`~pidpipe.errors.ConfigError`)
  and every later stage's error fail the step (exit status 1) with the message.

Resume
------
Outputs are written atomically (temporary file, then rename), so an interrupted step leaves
no half-written output. The parameters each rule receives are the parts of the config it
depends on (:func:`stage_config`), with sorted keys, so an edit elsewhere in the config does
not rerun it.
"""

from __future__ import annotations

import json
import logging
import math
import os
import sys
from dataclasses import fields
from pathlib import Path
from typing import Callable, Iterable

import numpy as np
import pandas as pd

from pidpipe.cases import NUMBER_PATTERN, CaseSpec, grid_cases, regime
from pidpipe.ceq_table import COORDINATE_COLUMNS, signal_quality
from pidpipe.config import budget_spheres, full_cell_spheres, validate_config
from pidpipe.errors import ConfigError, EngineError, PackingError, ParseError, PidpipeError

logger = logging.getLogger("pidpipe.campaign")

#: Snakemake wildcard constraint of a number in a case id (as written by ``format_number``).
WILDCARD_NUMBER = NUMBER_PATTERN
#: Snakemake wildcard constraint of a replicate index.
WILDCARD_REPLICATE = r"[0-9]+"

#: Config keys each stage depends on: top-level key -> list of sub-keys (None: all of it).
#: ``materials`` and ``pairs`` are cut down to the particle and wall materials.
_STAGE_KEYS: dict[str, dict[str, list[str] | None]] = {
    "packing": {
        "geometry": ["cell_inscribed_diameter_m", "core_height_m"],
        "fill": None,
        "fidelity": ["timestep_rayleigh_fraction", "youngs_modulus_scale", "settle_time_s", "seed",
                     "rotation", "friction"],
    },
    "case": {
        "geometry": ["cell_inscribed_diameter_m", "core_height_m", "coupon_n_cells"],
        "fidelity": ["timestep_rayleigh_fraction", "youngs_modulus_scale", "transient_cycles",
                     "transient_min_time_s", "measured_cycles", "sem_block_cycles", "rotation", "friction",
                     "target_relative_sem", "max_measured_cycles", "cells_per_run"],
    },
}

#: LIGGGHTS runs of a case before it is recorded as failed: one unexplained MPI_ABORT in about
#: 40 runs did not reproduce (notes/liggghts-3.8.md), so one retry saves a campaign from holes.
ENGINE_ATTEMPTS = 2

#: Statuses a table row can have, from the most to the least usable.
_STATUS_ORDER = ("ok", "flagged", "failed", "missing")


# --------------------------------------------------------------------------------------------
# Config for the workflow


def workflow_config(raw: dict) -> dict:
    """Validate the workflow's config; also check what only the workflow needs.

    Besides :func:`pidpipe.config.validate_config` (whose schema also lists the surrogate
    methods): an external C_eq table must exist (paths are relative to the working directory),
    so that the run does not fail after the simulations.

    Raises
    ------
    ConfigError
    """
    config = validate_config(raw)
    external = config["optimisation"]["external_ceq_table"]
    if external is not None and not Path(external).is_file():
        raise ConfigError(f"config key optimisation.external_ceq_table = {external!r} is not allowed: "
                          f"no such file (relative paths start at {Path.cwd()})")
    return config


def campaign_cases(config: dict) -> list[CaseSpec]:
    """Every case of the campaign: the grid times ``grid.replicates`` runs."""
    return grid_cases(config, replicates=int(config["grid"].get("replicates", 1)))


def case_packing_ids(config: dict, case: CaseSpec) -> list[str]:
    """The packings a case shakes: one per cell of its run (``fidelity.cells_per_run``)."""
    return case.packing_ids(int(config["fidelity"]["cells_per_run"]))


def campaign_packing_ids(config: dict) -> list[str]:
    """Every packing the campaign's cases shake, sorted."""
    return sorted({packing_id for case in campaign_cases(config)
                   for packing_id in case_packing_ids(config, case)})


def _sorted(value):
    """A copy with dict keys sorted at every level, so that its repr is stable."""
    if isinstance(value, dict):
        return {k: _sorted(value[k]) for k in sorted(value)}
    if isinstance(value, (list, tuple)):
        return [_sorted(v) for v in value]
    return value


def stage_config(config: dict, stage: str) -> dict:
    """The part of a validated config that a stage's results depend on.

    A rule passes this as its parameter, so that Snakemake reruns it when (and only when) one
    of these values changes. The result is still a config (same layout) that the stage's
    functions accept; a key they read that is not listed here raises KeyError, so the list
    cannot silently fall behind the code.

    Parameters
    ----------
    config : dict
        Validated config.
    stage : {"packing", "case"}

    Returns
    -------
    dict
        Keys sorted at every level.
    """
    keys = _STAGE_KEYS[stage]
    particle, wall = config["particle_material"], config["wall_material"]
    used = {particle, wall}
    part = {
        "particle_material": particle,
        "wall_material": wall,
        "materials": {name: config["materials"][name] for name in used},
        "pairs": [p for p in config["pairs"] if set(p["materials"]) <= used],
    }
    for top, subkeys in keys.items():
        section = config[top]
        part[top] = dict(section) if subkeys is None else {k: section[k] for k in subkeys}
    return _sorted(part)


def budget_params(config: dict) -> dict:
    """What the optimiser's particle budget depends on: n_b, spheres per full cell, N."""
    return {"n_spheres": budget_spheres(config), "full_cell_spheres": full_cell_spheres(config),
            "n_cells_coupon": int(config["geometry"]["coupon_n_cells"])}


def environment_params(config: dict) -> list[dict]:
    """The operating environments as plain, key-sorted dicts."""
    return _sorted(config["environments"])


# --------------------------------------------------------------------------------------------
# Running a step


def run_step(func: Callable, log_path: str | os.PathLike, /, **kwargs) -> None:
    """Run one workflow step, logging to ``log_path`` and stderr.

    A :class:`~pidpipe.errors.PidpipeError` is written (message only) to the log and to stderr,
    and the process exits with status 1; any other exception is a bug and keeps its traceback.

    Parameters
    ----------
    func : callable
        The step; called as ``func(**kwargs)``.
    log_path : path
        The rule's log file.
    """
    Path(log_path).parent.mkdir(parents=True, exist_ok=True)
    root = logging.getLogger("pidpipe")
    root.setLevel(logging.INFO)
    file_handler = logging.FileHandler(log_path, mode="a", encoding="utf-8")
    file_handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(message)s"))
    stderr_handler = logging.StreamHandler(sys.stderr)
    stderr_handler.setLevel(logging.WARNING)
    stderr_handler.setFormatter(logging.Formatter("pidpipe %(levelname)s: %(message)s"))
    root.addHandler(file_handler)
    root.addHandler(stderr_handler)
    try:
        func(**kwargs)
    except PidpipeError as exc:
        logger.error("%s (log: %s)", exc, log_path)
        raise SystemExit(1) from None
    finally:
        root.removeHandler(file_handler)
        root.removeHandler(stderr_handler)
        file_handler.close()


def _write_atomic(path: str | os.PathLike, write: Callable[[Path], None]) -> Path:
    """Call ``write(tmp)``, flush it to disk and rename the temporary file to ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.part")
    try:
        write(tmp)
        sync_file(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path


def sync_file(path: str | os.PathLike) -> None:
    """Flush a written file to disk (so that a power loss after the rename cannot leave it empty)."""
    with open(path, "rb") as handle:
        os.fsync(handle.fileno())


# --------------------------------------------------------------------------------------------
# Packings


def pour_packing(config: dict, fill_pct: float, replicate: int, packing_path: str,
                 workdir: str) -> None:
    """Pour and settle the packing of one fill level and replicate; save it (JSON).

    A packing that does not fit is saved as well: :func:`check_packings` refuses it, with every
    other one that does not fit, in one message.
    """
    from pidpipe.packing import pour, save_packing

    fill_pct, replicate = float(fill_pct), int(replicate)
    packing = pour(config, fill_pct, replicate, workdir)
    Path(packing_path).parent.mkdir(parents=True, exist_ok=True)
    save_packing(packing, packing_path)
    logger.info("packing r=%g %% replicate %d: %d spheres, seed %d, pile %.2f mm (lid %.2f mm), "
                "fastest sphere %.2g m/s; LIGGGHTS files in %s", fill_pct, replicate,
                packing.n_spheres, packing.seed, packing.pile_height_m * 1e3,
                packing.lid_height_m * 1e3, packing.max_speed_m_s, workdir)


def check_packings(packing_paths: list[str], case_ids: list[str], report_path: str,
                   cells_per_run: int = 1) -> None:
    """Check every packing before any case is shaken; refuse all misfits in one message.

    Parameters
    ----------
    packing_paths : list of path
        The packings (JSON), one per fill level and replicate.
    case_ids : list of str
        The campaign's cases; the message lists those that use a refused packing.
    report_path : path
        A tab-separated summary of every packing, written when all pass.
    cells_per_run : int
        Cells (packings) per case (``fidelity.cells_per_run``).

    Raises
    ------
    PackingError
        One message naming every refused packing, why, and its cases.
    """
    from pidpipe.packing import check_packing, load_packing

    cases_of: dict[str, list[str]] = {}
    for case_id in case_ids:
        for packing_id in CaseSpec.from_id(case_id).packing_ids(cells_per_run):
            cases_of.setdefault(packing_id, []).append(case_id)
    rows, problems = [], []
    for path in packing_paths:
        packing = load_packing(path)
        packing_id = Path(path).stem
        try:
            check_packing(packing, packing_id)
            verdict = "ok"
        except PackingError as exc:
            verdict = "refused"
            cases = cases_of.get(packing_id, [])
            problems.append(f"{exc} [{len(cases)} case(s): {', '.join(cases)}]")
        rows.append({"packing_id": packing_id, "fill_pct": packing.fill_pct,
                     "n_spheres": packing.n_spheres, "seed": packing.seed,
                     "pile_height_mm": round(packing.pile_height_m * 1e3, 3),
                     "lid_height_mm": round(packing.lid_height_m * 1e3, 3),
                     "max_speed_m_s": packing.max_speed_m_s,
                     "settle_time_s": packing.settle_time_s, "verdict": verdict})
        logger.info("%s: %d spheres, pile %.2f mm, lid %.2f mm: %s", packing_id, packing.n_spheres,
                    packing.pile_height_m * 1e3, packing.lid_height_m * 1e3, verdict)
    if problems:
        raise PackingError(f"{len(problems)} of {len(packing_paths)} packing(s) refused, so no case "
                           "is run:\n  " + "\n  ".join(problems))
    _write_atomic(report_path, lambda tmp: pd.DataFrame(rows).to_csv(tmp, sep="\t", index=False))


# --------------------------------------------------------------------------------------------
# Cases


def simulate_case(config: dict, case_id: str, packing_paths: list[str], record_path: str,
                  workdir: str, log_path: str) -> dict:
    """Run one case and write its record; a LIGGGHTS failure gives a ``failed`` record.

    A run that fails is tried again once (:data:`ENGINE_ATTEMPTS`); when every attempt fails
    the record has status ``failed`` and the last message.

    Parameters
    ----------
    config : dict
        The case stage's config (:func:`stage_config`).
    case_id : str
    packing_paths : list of path
        The packings to shake (JSON), one per cell of the run (:func:`case_packing_ids`).
    record_path : path
        The record to write (JSON, atomically).
    workdir : path
        The case's folder for the deck, the mesh and LIGGGHTS' files.
    log_path : path
        The rule's log, named in a failure's message.

    Returns
    -------
    dict
        The record written.

    Raises
    ------
    EngineError
        LIGGGHTS is not installed (no case could run: not a failure of this case).
    PackingError
        The packing does not fit or has not settled.
    """
    from pidpipe.adaptive import run_to_target
    from pidpipe.case import run_case, write_record
    from pidpipe.engine import find_liggghts
    from pidpipe.packing import load_packing

    case = CaseSpec.from_id(case_id)
    find_liggghts()
    packings = [load_packing(path) for path in packing_paths]
    failures = []
    for attempt in range(1, ENGINE_ATTEMPTS + 1):
        try:
            record = run_to_target(config, case, packings, workdir, run=run_case)
        except (EngineError, ParseError) as exc:
            failures.append(str(exc))
            logger.warning("case %s, attempt %d of %d: %s", case_id, attempt, ENGINE_ATTEMPTS, exc)
            continue
        record["engine_attempts"] = attempt
        logger.info("case %s: status %s%s, C_eq(coupon) = %.6g +- %.2g N*s/m over %d cycles, "
                    "wall time %.1f s (attempt %d); LIGGGHTS files in %s", case_id, record["status"],
                    f" ({', '.join(record['flags'])})" if record["flags"] else "",
                    record["ceq_coupon_ns_m"], record["ceq_coupon_sem_ns_m"], record["n_cycles"],
                    record["wall_time_s"], attempt, workdir)
        break
    else:
        message = (f"case {case_id} failed after {ENGINE_ATTEMPTS} attempt(s): {failures[-1]}; "
                   f"rule log: {log_path}")
        logger.error("%s", message)
        logger.error("the record %s is written with status failed so that the other cases and "
                     "the C_eq table go on; delete it to run the case again", record_path)
        record = failed_record(config, case, packings[0].n_spheres,
                               [packing.seed for packing in packings], message)
        record["engine_attempts"] = ENGINE_ATTEMPTS
    write_record(record, record_path)
    return record


def failed_record(config: dict, case: CaseSpec, n_spheres: int, seeds: list[int],
                  message: str) -> dict:
    """The record of a case whose run failed: its coordinates, the settings it ran with, no values.

    ``seeds`` are those of its packings, one per cell of the run.
    """
    from pidpipe.fidelity import plan_timestep, transient_cycles_for

    fidelity = config["fidelity"]
    seeds = [int(seed) for seed in seeds]
    nan = float("nan")
    return {
        "solver": "liggghts", "case_id": case.case_id, "freq_hz": case.freq_hz,
        "accel_g": case.accel_g, "fill_pct": case.fill_pct, "replicate": case.replicate,
        "n_spheres": n_spheres, "status": "failed", "flags": [], "message": message,
        "ceq_coupon_ns_m": nan, "ceq_coupon_sem_ns_m": nan, "ceq_cell_ns_m": nan,
        "ceq_cell_sem_ns_m": nan, "ed_cycle_mean_j": nan, "ed_cycle_sem_j": nan, "n_cycles": 0,
        "fidelity": {
            **plan_timestep(config, case.freq_hz).as_record(),
            "timestep_rayleigh_fraction_config": fidelity["timestep_rayleigh_fraction"],
            "youngs_modulus_scale": fidelity["youngs_modulus_scale"],
            "transient_cycles": transient_cycles_for(config, case.freq_hz),
            "measured_cycles": int(fidelity["measured_cycles"]),
            "sem_block_cycles": int(fidelity["sem_block_cycles"]),
            "rotation": bool(fidelity["rotation"]), "friction": bool(fidelity["friction"]),
            "cells_per_run": len(seeds),
            "seed": seeds[0],
            "seeds": seeds,
        },
        "engine": {},
        "wall_time_s": nan,
    }


# --------------------------------------------------------------------------------------------
# The C_eq table

#: (table column, where it is in a record): values averaged over replicates with their SEM.
_MEAN_WITH_SEM = (
    ("ceq_coupon_ns_m", "ceq_coupon_sem_ns_m"),
    ("ceq_cell_ns_m", "ceq_cell_sem_ns_m"),
    ("ed_cycle_mean_j", "ed_cycle_sem_j"),
)
#: table column -> key path in a record, for settings that are the same for every replicate.
_SETTING_COLUMNS = {
    "n_spheres": ("n_spheres",),
    "dt_s": ("fidelity", "timestep_s"),
    "dt_rayleigh_fraction": ("fidelity", "rayleigh_fraction"),
    "steps_per_cycle": ("fidelity", "steps_per_cycle"),
    "youngs_modulus_scale": ("fidelity", "youngs_modulus_scale"),
    "transient_cycles": ("fidelity", "transient_cycles"),
    "measured_cycles": ("fidelity", "measured_cycles"),
    "sem_block_cycles": ("fidelity", "sem_block_cycles"),
    "rotation": ("fidelity", "rotation"),
    "friction": ("fidelity", "friction"),
    "seed": ("fidelity", "seed"),
    "cells_per_run": ("fidelity", "cells_per_run"),
    "liggghts_version": ("engine", "liggghts_version"),
}
#: Columns of the campaign's C_eq table, in order (see :mod:`pidpipe.ceq_table`).
TABLE_COLUMNS: tuple[str, ...] = (
    "case_id", "freq_hz", "accel_g", "fill_pct", "status", "flags", "regime", "signal",
    "n_replicates", "ceq_coupon_ns_m", "ceq_coupon_sem_ns_m", "ceq_relative_sem",
    "ceq_cell_ns_m", "ceq_cell_sem_ns_m",
    "ed_cycle_mean_j", "ed_cycle_sem_j", "n_cycles",
    "n_spheres", "dt_s", "dt_rayleigh_fraction", "steps_per_cycle", "youngs_modulus_scale",
    "transient_cycles", "measured_cycles", "sem_block_cycles", "rotation", "friction", "seed",
    "cells_per_run", "liggghts_version", "wall_time_s", "liggghts_wall_time_s", "message",
)


def _get(record: dict, keys: tuple[str, ...], default=None):
    value = record
    for key in keys:
        if not isinstance(value, dict) or key not in value:
            return default
        value = value[key]
    return value


def combine_replicates(values, sems) -> tuple[float, float]:
    """Mean of replicate estimates and its standard error.

    With k estimates x_i of standard errors s_i (each from one run's cycle-to-cycle scatter),
    the mean's error propagated from the runs is sqrt(sum s_i^2) / k. It misses the scatter
    between packings, which the spread of the x_i measures, std(x, ddof=1) / sqrt(k), but
    that estimate is itself poor for few replicates. The larger of the two is returned.

    Parameters
    ----------
    values, sems : array_like, shape (k,)

    Returns
    -------
    (float, float)
        mean and standard error; (nan, nan) for k = 0; (x_1, s_1) for k = 1.
    """
    values, sems = np.asarray(values, dtype=float), np.asarray(sems, dtype=float)
    k = values.size
    if k == 0:
        return math.nan, math.nan
    mean = float(values.mean())
    propagated = float(np.sqrt(np.sum(sems**2)) / k)
    if k == 1:
        return mean, propagated
    between = float(values.std(ddof=1) / math.sqrt(k))
    return mean, max(propagated, between)


def missing_record(case: CaseSpec) -> dict:
    """Stand-in for a case that has no record."""
    return {"case_id": case.case_id, "freq_hz": case.freq_hz, "accel_g": case.accel_g,
            "fill_pct": case.fill_pct, "replicate": case.replicate, "status": "missing",
            "flags": [], "message": "no record"}


def records_to_table(records: Iterable[dict], expected: Iterable[CaseSpec] | None = None) -> pd.DataFrame:
    """The C_eq table: one row per grid point (f, G, r), replicates averaged.

    Parameters
    ----------
    records : iterable of dict
        Case records (:func:`pidpipe.case.run_case`, :func:`failed_record`).
    expected : iterable of CaseSpec, optional
        The campaign's cases; one without a record gives a ``missing`` replicate.

    Returns
    -------
    pandas.DataFrame
        Columns :data:`TABLE_COLUMNS`, rows sorted by (f, G, r). A point's status is ``ok`` if
        any replicate is ok, and its values are then the mean over the ok replicates
        (:func:`combine_replicates`), the others being listed in ``flags``
        (``rep1:failed``). Without an ok replicate, the status is ``flagged`` if any is
        flagged (values over the flagged ones, kept for inspection, never fitted), else
        ``failed``, else ``missing`` (values NaN). ``case_id`` joins the replicates' ids
        with ``;`` (just the one id without replicates); ``n_replicates`` counts those averaged.
    """
    by_id: dict[str, dict] = {}
    for record in records:
        by_id[record["case_id"]] = record
    for case in expected or ():
        by_id.setdefault(case.case_id, missing_record(case))
    groups: dict[tuple[float, float, float], list[dict]] = {}
    for record in by_id.values():
        key = tuple(float(record[c]) for c in COORDINATE_COLUMNS)
        groups.setdefault(key, []).append(record)
    rows = [_table_row(point, sorted(group, key=lambda r: int(r.get("replicate", 0))))
            for point, group in sorted(groups.items())]
    table = pd.DataFrame(rows, columns=list(TABLE_COLUMNS))
    return table


def _table_row(point: tuple[float, float, float], replicates: list[dict]) -> dict:
    """One grid point's row from its replicates' records."""
    status_of = [r.get("status", "missing") for r in replicates]
    best = min(status_of, key=_STATUS_ORDER.index)
    used = [r for r, s in zip(replicates, status_of) if s == best and best in ("ok", "flagged")]
    flags: list[str] = []
    for record, status in zip(replicates, status_of):
        rep = f"rep{record.get('replicate', 0)}"
        prefix = f"{rep}:" if len(replicates) > 1 else ""
        flags.extend(f"{prefix}{flag}" for flag in record.get("flags", []))
        if status != best:
            flags.append(f"{rep}:{status}")
    row = dict(zip(COORDINATE_COLUMNS, point))
    row.update(case_id=";".join(r["case_id"] for r in replicates), status=best,
               flags=";".join(flags), n_replicates=len(used),
               message=" | ".join(r["message"] for r in replicates if r.get("message")))
    for value_key, sem_key in _MEAN_WITH_SEM:
        row[value_key], row[sem_key] = combine_replicates(
            [_number(r.get(value_key)) for r in used], [_number(r.get(sem_key)) for r in used])
    row["n_cycles"] = int(sum(int(r.get("n_cycles") or 0) for r in used))
    row["regime"] = regime(point[1])
    row["ceq_relative_sem"], row["signal"] = signal_quality(row["ceq_coupon_ns_m"],
                                                            row["ceq_coupon_sem_ns_m"])
    timed = [r for r in replicates if r.get("status") in ("ok", "flagged")]
    row["wall_time_s"] = float(sum(_number(r.get("wall_time_s")) for r in timed)) if timed else math.nan
    row["liggghts_wall_time_s"] = (float(sum(_number(_get(r, ("engine", "liggghts_wall_time_s")))
                                             for r in timed)) if timed else math.nan)
    reference = (used or replicates)[0]
    for column, keys in _SETTING_COLUMNS.items():
        row[column] = _get(reference, keys)
    return row


def _number(value) -> float:
    return math.nan if value is None else float(value)


def read_record(path: str | os.PathLike) -> dict:
    """Read a case record (JSON).

    Raises
    ------
    ParseError
        The file cannot be read or is not a case record.
    """
    try:
        record = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise ParseError(f"case record {path} cannot be read: {exc}") from None
    if not isinstance(record, dict) or "case_id" not in record or "status" not in record:
        raise ParseError(f"case record {path} is not a case record (no case_id or status)")
    return record


def collect_table(record_paths: list[str], table_path: str, case_ids: list[str] | None = None) -> pd.DataFrame:
    """Aggregate case records into the C_eq table (CSV, written atomically).

    Parameters
    ----------
    record_paths : list of path
        Case records; a path that does not exist gives a ``missing`` row.
    table_path : path
        The CSV to write.
    case_ids : list of str, optional
        The campaign's cases; one without a record path is ``missing`` too.

    Returns
    -------
    pandas.DataFrame
    """
    records = [read_record(p) for p in record_paths if Path(p).is_file()]
    expected = [CaseSpec.from_id(c) for c in case_ids or []]
    expected += [CaseSpec.from_id(Path(p).stem) for p in record_paths if not Path(p).is_file()]
    table = records_to_table(records, expected)
    _write_atomic(table_path, lambda tmp: table.to_csv(tmp, index=False))
    counts = table["status"].value_counts().to_dict()
    logger.info("C_eq table %s: %d grid points (%s)", table_path, len(table),
                ", ".join(f"{v} {k}" for k, v in sorted(counts.items())))
    bad = table[table["status"] != "ok"]
    for _, row in bad.iterrows():
        logger.warning("grid point f=%g Hz, G=%g g, r=%g %% (%s) is %s%s; it is not fitted",
                       row["freq_hz"], row["accel_g"], row["fill_pct"], row["case_id"],
                       row["status"], f": {row['message']}" if row["message"] else
                       (f" ({row['flags']})" if row["flags"] else ""))
    if not bad.empty:
        logger.warning("to rerun a failed or flagged case, delete its record in results/cases/ "
                       "(and change what made it fail) and run snakemake again")
    return table


# --------------------------------------------------------------------------------------------
# Surrogate, optimisation, figures


def validate_against_dem(config: dict, cases: list[dict], packing_paths: list[str],
                         table_path: str, plot_path: str, workdir: str) -> None:
    """Run chosen cases in LIGGGHTS and in the NumPy DEM; write the comparison table and plot.

    Parameters
    ----------
    config : dict
        The case stage's config (:func:`stage_config`).
    cases : list of dict
        ``{"freq_hz", "accel_g", "fill_pct"}`` each (``validation.cases``).
    packing_paths : list of path
        The replicate-0 packings of the cases' fills.
    table_path, plot_path : path
        The comparison CSV and PNG.
    workdir : path
        Scratch folder for both solvers.
    """
    import shutil

    from pidpipe.packing import load_packing
    from pidpipe.validation import run_validation

    specs = [CaseSpec(float(c["freq_hz"]), float(c["accel_g"]), float(c["fill_pct"])) for c in cases]
    packings = {Path(path).stem: load_packing(path) for path in packing_paths}
    table = run_validation(config, specs, packings, workdir)
    _write_atomic(table_path, lambda tmp: table.to_csv(tmp, index=False))
    shutil.copyfile(Path(workdir) / "validation.png", plot_path)
    logger.info("validation: %d of %d cases agree within 2 combined standard errors",
                int(table["agree"].sum()), len(table))


def fit_table_surrogate(table_path: str, method: str, surrogate_path: str,
                        allow_holes: bool = False) -> None:
    """Fit the configured surrogate to a C_eq table and save it (JSON).

    With ``allow_holes`` grid points without an ok result are bridged by the RBF and listed in
    the log; without it the fit stops and names them.
    """
    from pidpipe.ceq_table import read_ceq_table
    from pidpipe.surrogate import fit_surrogate, save_surrogate

    table = read_ceq_table(table_path)
    surrogate = fit_surrogate(table, method=method, source=str(table_path), allow_holes=allow_holes)
    if surrogate.holes:
        logger.warning("surrogate bridges %d grid point(s) without an ok result (f Hz, G g, r %%): %s",
                       len(surrogate.holes), surrogate.holes)
    _write_atomic(surrogate_path, lambda tmp: save_surrogate(surrogate, tmp))
    logger.info("surrogate %s (%s target) on %d rows of %s; %d left out; domain %s", method,
                surrogate.target, len(surrogate.training), table_path, len(surrogate.excluded),
                surrogate.domain)


def cross_validate_table(table_path: str, cv_path: str) -> None:
    """Leave-one-out cross-validation of every surrogate method on a C_eq table (CSV)."""
    from pidpipe.ceq_table import read_ceq_table
    from pidpipe.surrogate import cross_validate, select_surrogate

    cv = cross_validate(read_ceq_table(table_path))
    _write_atomic(cv_path, lambda tmp: cv.to_csv(tmp, index=False))
    method, target = select_surrogate(cv)
    logger.info("cross-validation of %s: %d (method, target, scheme) rows; best by the plane "
                "scheme (or the default without one): %s, %s target", table_path, len(cv),
                method, target)


def optimise_surrogate(surrogate_path: str, environments: list[dict], budget: dict, starts: int,
                       seed: int, results_csv: str, history_csv: str, results_json: str) -> None:
    """Optimise every environment on a saved surrogate; write the results and histories."""
    from pidpipe.optimisation import (Budget, Environment, optimise_environments,
                                      write_history_csv, write_results_csv, write_results_json)
    from pidpipe.surrogate import load_surrogate

    surrogate = load_surrogate(surrogate_path)
    envs = [Environment(e["name"], tuple(e["freq_hz"]), tuple(e["accel_g"])) for e in environments]
    results = optimise_environments(surrogate, envs, Budget(**budget), starts=int(starts),
                                    seed=int(seed))
    for res in results:
        d = res.design
        logger.info("%s: r = %.2f %%, n_c = %d cells, f = %g Hz, G = %g g, total C_eq = %.6g N*s/m "
                    "(%d of %d starts converged)", res.environment.name, d.fill_pct, d.n_cells,
                    d.freq_hz, d.accel_g, d.total_ceq_ns_m, res.n_converged, len(res.starts))
    _write_atomic(results_csv, lambda tmp: write_results_csv(results, tmp))
    _write_atomic(history_csv, lambda tmp: write_history_csv(results, tmp))
    _write_atomic(results_json, lambda tmp: write_results_json(results, tmp))


def read_results_json(path: str | os.PathLike) -> list:
    """Read the optimisation results written by ``write_results_json`` back into dataclasses."""
    from pidpipe.optimisation import (Budget, Design, Environment, LocalOptimum,
                                      OptimisationResult, StartRun)

    def build(cls, data):
        return cls(**{f.name: data[f.name] for f in fields(cls) if f.name in data})

    try:
        document = json.loads(Path(path).read_text(encoding="utf-8"))
        results = []
        for item in document:
            env = item["environment"]
            results.append(OptimisationResult(
                environment=Environment(env["name"], tuple(env["freq_hz"]), tuple(env["accel_g"])),
                budget=build(Budget, item["budget"]),
                bounds={k: tuple(v) for k, v in item["bounds"].items()},
                clipped=item["clipped"], seed=item["seed"],
                optimum=build(LocalOptimum, item["optimum"]),
                local_optima=[build(LocalOptimum, o) for o in item["local_optima"]],
                design=build(Design, item["design"]),
                starts=[build(StartRun, s) for s in item["starts"]]))
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ParseError(f"optimisation results {path} cannot be read: {exc}") from None
    return results


def plot_surrogate_maps(surrogate_path: str, freq_fill_png: str, freq_accel_png: str) -> None:
    """The C_eq(f, r) and C_eq(f, G) maps of a saved surrogate, each as PNG and PDF.

    Parameters
    ----------
    surrogate_path : path
    freq_fill_png, freq_accel_png : path
        The PNG files; the PDF goes next to each, with the same stem.
    """
    from pidpipe.figures import plot_ceq_freq_accel, plot_ceq_freq_fill
    from pidpipe.surrogate import load_surrogate

    surrogate = load_surrogate(surrogate_path)
    plot_ceq_freq_fill(surrogate, stem=Path(freq_fill_png).with_suffix(""))
    plot_ceq_freq_accel(surrogate, stem=Path(freq_accel_png).with_suffix(""))
    logger.info("surrogate maps: %s, %s (and PDF)", freq_fill_png, freq_accel_png)


def plot_optimisation_convergence(results_json: str, png: str) -> None:
    """Objective against SLSQP iteration of every start, per environment, as PNG and PDF.

    Parameters
    ----------
    results_json : path
        Written by :func:`optimise_surrogate`.
    png : path
        The PNG file; the PDF goes next to it, with the same stem.
    """
    from pidpipe.figures import plot_convergence

    plot_convergence(read_results_json(results_json), stem=Path(png).with_suffix(""))
    logger.info("convergence figure: %s (and PDF)", png)


__all__ = [
    "TABLE_COLUMNS", "WILDCARD_NUMBER", "WILDCARD_REPLICATE", "budget_params", "campaign_cases",
    "check_packings", "collect_table", "combine_replicates", "cross_validate_table",
    "environment_params", "failed_record", "fit_table_surrogate", "missing_record",
    "optimise_surrogate", "plot_optimisation_convergence", "plot_surrogate_maps", "pour_packing",
    "read_record", "read_results_json", "records_to_table", "run_step", "simulate_case",
    "stage_config", "workflow_config",
]
