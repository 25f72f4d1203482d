"""The refinement loop's engine: ``measure``, ``verify`` and ``cost`` on the configured engine.

:class:`CaseEngine` gives :func:`pidpipe.refine.loop.refine` the three callables it needs, on
the config's engine (LIGGGHTS or the compiled DEM). Every request is run as one case of the
campaign is (:func:`pidpipe.steps.cases.measure_case`): packings poured with
``fidelity.pour_engine`` and checked (:func:`pidpipe.cell.packing.check_packing`), then
shaken; its record is turned into a table row by the campaign's row builder
(:func:`pidpipe.design.records.records_to_table`).

What each request runs (:meth:`CaseEngine.plan`)
    ``new``
        The case's pilot, as configured: ``fidelity.cells_per_run`` cells x ``measured_cycles``,
        on the campaign's pilot packings of that fill (indices 0 .. k0 - 1). The loop, not
        ``fidelity.target_relative_sem``, decides whether the case gets more: the uniform
        target's steps could not be planned before the case runs, and the loop's budget counts
        planned CPU.
    ``extend``
        A further replicate of the case with (factor - 1) x the base row's cells, each over the
        base row's measured cycles (those its allocation reached), so that the pooled row has
        factor x the base's effort in the same proportion of cells to cycles, and its SEM is
        about the base's / sqrt(factor), as the loop's choice expects
        (:mod:`pidpipe.refine.choice`); on packings no campaign case shakes (replicate
        100 + q of the pool, :func:`pidpipe.steps.cases.extra_packing_index`, q the base row's
        replicate count). ``fidelity.max_cells_per_case`` does not cap it: the loop's budget
        and the cost of the cells (the choice weighs gain per planned CPU second) do. Its row
        is pooled with the base row (:func:`pool_rows`) and supersedes it.
    ``verify`` / ``reverify``
        The point's pilot on packings of their own (replicate 200 + run), so that a verifying
        run is never a rerun of a fitted case at the same point.

The cost (:meth:`CaseEngine.cost`) is the cost models' (``cost_models.json``,
:mod:`pidpipe.measurement.cost_model`) for exactly that plan: the engine's run of k cells x
(transient + measured cycles) x steps per cycle at the fill's spheres, plus one pour per packing
on ``fidelity.pour_engine``. Every request is charged its packings' pours, although the pool
pours a packing once and every later case of that fill and replicate reads it (a design's five
verifying points share theirs): the planned CPU over-states a round whose cases share
packings, so the budget is never overrun, and it depends only on the request, so a resumed loop
plans the same. :attr:`CaseEngine.measured` keeps what was spent.

Every record is written under ``work_dir/cases/<case id>.json``; a request whose record is
there (made with the same plan) is read, not run again, so that a loop killed inside a round's
``measure`` resumes without rerunning the cases it finished. Two ways to run the rest:

- in this process (``pidpipe refine``, or a workflow step with ``refine.run_cases: in_step``):
  the requests of one call run up to ``cores`` at a time in worker processes that live as long
  as the engine (:meth:`close`), so Python starts and the engine loads once per loop, not per
  case; the packings they lack are poured first, shared among the workers
  (:meth:`CaseEngine._pour_ahead`), so that one extension's many fresh packings do not pour on
  one core;
- as workflow jobs (``snakemake refine``, ``run_missing=False``): the engine runs nothing; when a
  call lacks records it writes each missing plan to ``work_dir/plans/<case id>.json``
  (:meth:`Plan.write`) and raises :class:`RunsNeeded` naming them, and the workflow runs each
  plan as a job of its own (:func:`run_plan`) before it asks the loop again.
"""

from __future__ import annotations

import json
import logging
import math
import multiprocessing
import os
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd

from pidpipe.cases import CaseSpec
from pidpipe.config.settings import PourSettings, ShakeSettings
from pidpipe.design.ceq_table import SEM_COLUMN, VALUE_COLUMN, signal_quality
from pidpipe.design.packing_noise import LOADS_COLUMN, combine_loads, format_loads, parse_loads
from pidpipe.errors import PidpipeError
from pidpipe.files import write_atomic
from pidpipe.refine.candidates import Request

logger = logging.getLogger("pidpipe.refine")

#: Replicate numbers of the loop's own runs: extensions from 101 (100 + the replicates of the
#: row extended), verifying runs from 200 (the campaign's replicates stay below 100,
#: :mod:`pidpipe.steps.cases`; 100 is the verify step's,
#: :data:`pidpipe.loop.verify.VERIFY_REPLICATE`).
EXTEND_REPLICATES_FROM, VERIFY_REPLICATES_FROM = 100, 200


@dataclass(frozen=True)
class Plan:
    """What the engine runs for one request.

    Attributes
    ----------
    case : CaseSpec
        The case (its replicate says which run of the loop it is).
    packings : tuple of int
        Packing indices of the fill, one per cell (seed ``fidelity.seed`` + index).
    measured_cycles : int
        Measured cycles of the run (after ``fidelity.transient_cycles_at(f)``).
    n_spheres : int
        Spheres per cell.
    """

    case: CaseSpec
    packings: tuple[int, ...]
    measured_cycles: int
    n_spheres: int

    @property
    def cells(self) -> int:
        return len(self.packings)

    def to_dict(self) -> dict:
        """The plan as plain data (:meth:`from_dict` reads it back)."""
        return {"freq_hz": self.case.freq_hz, "accel_g": self.case.accel_g,
                "fill_pct": self.case.fill_pct, "replicate": self.case.replicate,
                "packings": list(self.packings), "measured_cycles": self.measured_cycles,
                "n_spheres": self.n_spheres}

    @classmethod
    def from_dict(cls, data: dict) -> "Plan":
        return cls(CaseSpec(float(data["freq_hz"]), float(data["accel_g"]),
                            float(data["fill_pct"]), int(data["replicate"])),
                   tuple(int(i) for i in data["packings"]), int(data["measured_cycles"]),
                   int(data["n_spheres"]))

    def write(self, path: str | Path) -> Path:
        """Write the plan as JSON, atomically."""
        text = json.dumps(self.to_dict(), indent=1) + "\n"
        return write_atomic(path, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))

    @classmethod
    def read(cls, path: str | Path) -> "Plan":
        try:
            return cls.from_dict(json.loads(Path(path).read_text(encoding="utf-8")))
        except (OSError, ValueError, KeyError, TypeError) as error:
            raise PidpipeError(f"refinement plan {path}: cannot be read ({error}); run the "
                               "refinement's step again (snakemake refine)") from error


class RunsNeeded(Exception):
    """The loop needs runs that have no record yet (an engine with ``run_missing=False``).

    Attributes
    ----------
    case_ids : list of str
        The missing plans' case ids, in the order asked; each plan is in
        ``work_dir/plans/<case id>.json``.
    """

    def __init__(self, case_ids: list[str]):
        super().__init__(f"{len(case_ids)} run(s) needed: {', '.join(case_ids)}")
        self.case_ids = list(case_ids)


class CaseEngine:
    """``measure``, ``verify`` and ``cost`` of the loop on the config's engine.

    Parameters
    ----------
    pour : PourSettings
        How packings are poured (``fidelity.pour_engine``, the fill's spheres).
    shake : ShakeSettings
        The cases' settings (``engine``: ``liggghts`` or ``dem``).
    work_dir : path
        ``results/refine/work``: packings in ``packings/``, case folders and records in
        ``cases/``, plans in ``plans/``.
    cores : int
        Requests of one call run up to this many at a time, each in a worker process (cases of
        one fill share their packings through the pool's locks); 1: one after another here.
    run_missing : bool
        True: run what has no record. False: run nothing; write the missing plans and raise
        :class:`RunsNeeded` (the workflow runs them as jobs).

    Attributes
    ----------
    runs : list of str
        Case ids the engine shook (records read from ``work_dir`` are not counted).
    measured : dict
        What those runs spent: ``shake_cpu_s`` (the engine's CPU from their records),
        ``pour_cpu_s`` and ``pour_wall_s`` (the pools' pours, this process's CPU and its child
        processes', e.g. LIGGGHTS'), s.
    """

    def __init__(self, pour: PourSettings, shake: ShakeSettings, work_dir: str | Path,
                 cores: int = 1, run_missing: bool = True):
        from pidpipe.measurement.cost_model import load_cost_model

        if isinstance(cores, bool) or not isinstance(cores, int) or cores < 1:
            raise PidpipeError(f"cores {cores!r} is not allowed: it must be a whole number >= 1")
        self.pour, self.work_dir, self.cores = pour, Path(work_dir), cores
        self.run_missing = run_missing
        self.shake = replace(shake, sampling=replace(shake.sampling, target_relative_sem=None))
        self.run_model = load_cost_model(shake.engine)
        self.pour_model = load_cost_model(pour.pouring.engine)
        for engine, model in ((shake.engine, self.run_model),
                              (pour.pouring.engine, self.pour_model)):
            if model is None:
                raise PidpipeError(f"the refinement plans with the stored cost model of the "
                                   f"{engine} engine; pidpipe/measurement/cost_models.json lacks "
                                   f"it: run benchmarks/bench_cells.py --cost --engine {engine}")
        self.runs: list[str] = []
        self.measured = {"shake_cpu_s": 0.0, "pour_cpu_s": 0.0, "pour_wall_s": 0.0}
        self._pool: ProcessPoolExecutor | None = None

    def _workers(self) -> ProcessPoolExecutor:
        """The worker processes, started at the first call that needs them and kept until
        :meth:`close`: each starts Python and loads the engine once for the whole loop."""
        if self._pool is None:
            context = multiprocessing.get_context("spawn")
            self._pool = ProcessPoolExecutor(self.cores, mp_context=context)
        return self._pool

    def map(self, function: Callable, items) -> list:
        """``function`` over ``items``, in order: up to ``cores`` at a time in the worker
        processes (``function`` and the items picklable), else here. The loop optimises a
        round's designs so (:func:`pidpipe.design.designs.optimise_designs`), while the
        workers would otherwise wait for the next runs."""
        items = list(items)
        if self.cores > 1 and len(items) > 1:
            return list(self._workers().map(function, items))
        return [function(item) for item in items]

    def close(self) -> None:
        """Stop the worker processes (a later call starts new ones)."""
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None

    def __enter__(self) -> "CaseEngine":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __getstate__(self) -> dict:
        """What a worker receives: everything but the workers."""
        state = dict(self.__dict__)
        state["_pool"] = None
        return state

    @classmethod
    def from_config(cls, config: dict, work_dir: str | Path, cores: int = 1,
                    run_missing: bool = True) -> "CaseEngine":
        """The engine of a validated config (its ``engine``, ``fidelity.pour_engine``)."""
        return cls(PourSettings.from_config(config), ShakeSettings.from_config(config), work_dir,
                   cores, run_missing)

    # -- plans and their cost ------------------------------------------------------------------

    def plan(self, request: Request) -> Plan:
        """What the engine runs for ``request`` (see the module's text)."""
        from pidpipe.steps.cases import EXTRA_PACKINGS_PER_REPLICATE, extra_packing_index

        sampling = self.shake.sampling
        spheres = self.pour.fill.spheres(request.fill_pct)
        k0, cycles = sampling.cells_per_run, sampling.measured_cycles
        point = (request.freq_hz, request.accel_g, request.fill_pct)
        if request.action == "new":
            return Plan(CaseSpec(*point, 0), tuple(range(k0)), cycles, spheres)
        if request.action == "extend":
            base = request.base
            q = max(1, _integer(base.get("n_replicates"), 1))
            cycles = _integer(base.get("measured_cycles"), cycles)
            cells = int(math.ceil((request.factor - 1.0) * _cells_of(base, k0) - 1e-9))
            cells = min(max(cells, 1), EXTRA_PACKINGS_PER_REPLICATE)
            replicate = EXTEND_REPLICATES_FROM + q
            return Plan(CaseSpec(*point, replicate),
                        tuple(extra_packing_index(replicate, j) for j in range(cells)),
                        cycles, spheres)
        if request.action in ("verify", "reverify"):
            replicate = VERIFY_REPLICATES_FROM + int(request.run)
            return Plan(CaseSpec(*point, replicate),
                        tuple(extra_packing_index(replicate, j) for j in range(k0)),
                        cycles, spheres)
        raise ValueError(f"request action {request.action!r}: new, extend, verify or reverify")

    def plan_cpu_s(self, plan: Plan) -> float:
        """Planned CPU of a plan, s: the run, and one pour per packing."""
        from pidpipe.cell.scene import CellScene

        steps_per_cycle = CellScene.of(self.shake).timestep(plan.case.freq_hz).steps_per_cycle
        transient = self.shake.sampling.transient_cycles_at(plan.case.freq_hz)
        steps = (transient + plan.measured_cycles) * steps_per_cycle
        return (self.run_model.run_cpu_s(plan.cells, plan.n_spheres, steps)
                + plan.cells * self.pour_model.pour_cpu_s(plan.n_spheres))

    def cost(self, request: Request) -> float:
        """``cost(request)``: the planned engine CPU of what ``request`` runs, s."""
        return self.plan_cpu_s(self.plan(request))

    # -- runs ----------------------------------------------------------------------------------

    def measure(self, cases, more) -> pd.DataFrame:
        """``measure(cases, more)``: one row per request, new cases then extensions.

        An extension's row is its runs' row pooled with the row it extends (:func:`pool_rows`).
        """
        cases, more = list(cases), list(more)
        records = self._records([self.plan(request) for request in cases + more])
        full = self.pour.fill.full_cell_spheres
        rows = [_row(record, full) for record in records[:len(cases)]]
        rows += [pool_rows(request.base, _row(record, full))
                 for request, record in zip(more, records[len(cases):])]
        return pd.DataFrame(rows)

    def verify(self, points) -> pd.DataFrame:
        """``verify(points)``: one row per verifying request."""
        records = self._records([self.plan(request) for request in points])
        return pd.DataFrame([_row(record, self.pour.fill.full_cell_spheres) for record in records])

    def _records(self, plans: list[Plan]) -> list:
        """The plans' records, in order: up to ``cores`` at a time in worker processes (with
        ``run_missing`` False: the stored ones, else :class:`RunsNeeded`)."""
        if not self.run_missing:
            return [record for record, _ in self._stored_or_planned(plans)]
        if self.cores > 1:
            self._pour_ahead(plans)
        if self.cores > 1 and len(plans) > 1:
            done = list(self._workers().map(self._record, plans))
        else:
            done = [self._record(plan) for plan in plans]
        for record, spent in done:
            if spent is not None:
                self.runs.append(record.case_id)
                for key, value in spent.items():
                    self.measured[key] += value
                logger.info("refine: shook %s: %.1f engine CPU-s, pours %.1f s", record.case_id,
                            spent["shake_cpu_s"], spent["pour_wall_s"])
        return [record for record, _ in done]

    def _pour_ahead(self, plans: list[Plan]) -> None:
        """Pour the packings the plans without a record lack, shared among the workers, before
        any of them runs: a case pours its missing packings one after another, so an extension
        of many cells on fresh packings would otherwise pour them all on one core while the
        other waits. Each fill's missing packings are split into ``cores`` batches (the DEM
        pours a batch in one call); the runs then read them from the pool."""
        from pidpipe.steps.cases import pool_packing_path

        folder = self.work_dir / "packings"
        missing: dict[float, dict[int, None]] = {}           # per fill, the indices in order
        for plan in plans:
            if self._stored(plan) is None:
                fill = plan.case.fill_pct
                missing.setdefault(fill, {}).update(
                    (index, None) for index in plan.packings
                    if not pool_packing_path(folder, fill, index).is_file())
        missing = {fill: list(indices) for fill, indices in missing.items() if indices}
        batches = [(fill, indices[k::self.cores]) for fill, indices in sorted(missing.items())
                   for k in range(self.cores) if indices[k::self.cores]]
        if len(batches) < 2:
            return
        for spent in self._workers().map(self._pour_batch, batches):
            for key, value in spent.items():
                self.measured[key] += value
        logger.info("refine: poured %d packing(s) ahead in %d batch(es)",
                    sum(len(indices) for _, indices in batches), len(batches))

    def _pour_batch(self, batch: tuple[float, list[int]]) -> dict:
        """Pour one fill's packings into the pool (a worker's task); what it spent, s."""
        return self._pool_packings(*batch)[1]

    def _pool_packings(self, fill_pct: float, indices) -> tuple[list, dict]:
        """The pool's packings ``indices`` of a fill (poured when missing), and what pouring them
        spent: ``pour_wall_s`` and ``pour_cpu_s`` (this process's CPU and its children's), s."""
        from pidpipe.steps.cases import pool_packings

        before, wall = os.times(), time.perf_counter()
        packings = pool_packings(self.pour, fill_pct, list(indices), self.work_dir / "packings")
        after = os.times()
        return packings, {"pour_wall_s": time.perf_counter() - wall,
                          "pour_cpu_s": sum(after[:4]) - sum(before[:4])}

    def _stored_or_planned(self, plans: list[Plan]) -> list:
        """The plans' stored records (as ``(record, None)``); when some are missing, write their
        plans to ``work_dir/plans`` and raise :class:`RunsNeeded`."""
        stored = [self._stored(plan) for plan in plans]
        missing = [plan for plan, record in zip(plans, stored) if record is None]
        if missing:
            for plan in missing:
                plan.write(self.plan_path(plan.case.case_id))
            raise RunsNeeded([plan.case.case_id for plan in missing])
        return [(record, None) for record in stored]

    def record_path(self, case_id: str) -> Path:
        """Where the record of a plan's case is kept."""
        return self.work_dir / "cases" / f"{case_id}.json"

    def plan_path(self, case_id: str) -> Path:
        """Where a plan waiting for its run is written."""
        return self.work_dir / "plans" / f"{case_id}.json"

    def _stored(self, plan: Plan):
        """The plan's record when ``work_dir`` has it (made by that plan), else None."""
        from pidpipe.measurement.case_record import CaseRecord

        path = self.record_path(plan.case.case_id)
        if path.is_file():
            record = CaseRecord.read(path)
            if _made_by(record, plan):
                return record
        return None

    def run_plan(self, plan: Plan):
        """Run one plan (a workflow job): its record, written to :meth:`record_path`."""
        return self._record(plan)[0]

    def _record(self, plan: Plan) -> tuple:
        """The plan's case record, and what making it spent (None when ``work_dir`` had it)."""
        from pidpipe.cell.packing import check_packing
        from pidpipe.steps.cases import measure_case

        case = plan.case
        path = self.record_path(case.case_id)
        stored = self._stored(plan)
        if stored is not None:
            return stored, None
        base = self.shake.sampling
        sampling = replace(base, cells_per_run=plan.cells, measured_cycles=plan.measured_cycles,
                           max_cells_per_case=max(plan.cells, base.max_cells_per_case))
        settings = replace(self.shake, sampling=sampling)
        packings, spent = self._pool_packings(case.fill_pct, plan.packings)
        for packing in packings:
            check_packing(packing, case.case_id)
        logger.info("refine: shaking %s: %d cell(s) of %d spheres x %d measured cycles (%s)",
                    case.case_id, plan.cells, plan.n_spheres, plan.measured_cycles,
                    self.shake.engine)
        record = measure_case(settings, case, packings, self.work_dir / "cases" / case.case_id)
        record.write(path)
        spent["shake_cpu_s"] = _record_cpu_s(record)
        return record, spent


def _row(record, full_cell_spheres: int) -> dict:
    """The table row of a record (:func:`pidpipe.design.records.records_to_table`, at the fill
    its ``full_cell_spheres``-sphere cells hold), with the
    cells it measured (``cells``) and its measured engine CPU (``engine_cpu_s``, s)."""
    from pidpipe.design.records import records_to_table

    row = records_to_table([record], full_cell_spheres=full_cell_spheres).iloc[0].to_dict()
    row["cells"] = len(record.cells or ()) or 1
    row["engine_cpu_s"] = _record_cpu_s(record)
    return row


def pool_rows(base: dict, new: dict) -> dict:
    """An extension's row: ``new`` (the extension's runs) pooled with ``base`` (the row extended).

    C_eq (coupon and cell) is the inverse-variance mean of the two, with SEM
    1 / sqrt(1 / SEM_base^2 + 1 / SEM_new^2), and loads on the packings of both parts, each
    part's with its weight (:mod:`pidpipe.design.packing_noise`); ``cells`` and ``n_replicates`` add up, flags are
    united (the extension's prefixed ``extN:``), the status is the less usable of the two
    (``ok`` only when both are). When either part has no finite SEM > 0 (a failed run), the row
    is the usable part's, the other noted in ``flags``.

    Parameters
    ----------
    base, new : dict
        Table rows (columns of :data:`pidpipe.design.records.TABLE_COLUMNS`, ``cells``).

    Returns
    -------
    dict
        ``new``'s columns, with the pooled values.
    """
    row = dict(new)
    tag = f"ext{max(1, _integer(base.get('n_replicates'), 1))}"
    new_flags = [f"{tag}:{flag}" for flag in str(new.get("flags") or "").split(";") if flag]
    base_flags = [flag for flag in str(base.get("flags") or "").split(";") if flag]
    usable = [_usable(base), _usable(new)]
    if not all(usable):
        keep = base if usable[0] or not usable[1] else new
        row.update({k: v for k, v in keep.items() if k in row or k in base})
        other = f"{tag}:{new.get('status')}" if keep is base else f"base:{base.get('status')}"
        row["flags"] = ";".join(base_flags + new_flags + [other]) if keep is base else \
            ";".join(new_flags + [other])
        return row
    for value, sem in ((VALUE_COLUMN, SEM_COLUMN), ("ceq_cell_ns_m", "ceq_cell_sem_ns_m")):
        v = np.array([float(base[value]), float(new[value])])
        s = np.array([float(base[sem]), float(new[sem])])
        w = 1.0 / s ** 2
        row[value], row[sem] = float(np.sum(w * v) / np.sum(w)), float(1.0 / math.sqrt(np.sum(w)))
        if value == VALUE_COLUMN:
            row[LOADS_COLUMN] = format_loads(combine_loads(
                [parse_loads(base.get(LOADS_COLUMN)), parse_loads(new.get(LOADS_COLUMN))],
                w / np.sum(w)))
    row["ceq_relative_sem"], row["signal"] = signal_quality(row[VALUE_COLUMN], row[SEM_COLUMN])
    row["status"] = "ok" if base.get("status") == new.get("status") == "ok" else "flagged"
    row["flags"] = ";".join(base_flags + new_flags)
    row["cells"] = _cells_of(base, 1) + _integer(new.get("cells"), 1)
    row["n_replicates"] = _integer(base.get("n_replicates"), 1) + 1
    row["case_id"] = f"{base.get('case_id')};{new.get('case_id')}"
    return row


def _usable(row: dict) -> bool:
    """A row with a value and a finite SEM > 0, not failed or missing."""
    try:
        value, sem = float(row[VALUE_COLUMN]), float(row[SEM_COLUMN])
    except (KeyError, TypeError, ValueError):
        return False
    return (row.get("status") in ("ok", "flagged") and math.isfinite(value)
            and math.isfinite(sem) and sem > 0)


def _cells_of(row: dict, default: int) -> int:
    """Cells a row measured: its ``cells``, else the counts of ``regime_cells``
    (``bouncing_bed:5;irregular:2``), else ``cells_per_run``, else ``default``."""
    cells = _integer(row.get("cells"), 0)
    if cells > 0:
        return cells
    text = row.get("regime_cells")
    if isinstance(text, str) and text:
        counts = [_integer(part.rpartition(":")[2], 0) for part in text.split(";")]
        if sum(counts) > 0:
            return sum(counts)
    return max(1, _integer(row.get("cells_per_run"), default))


def _integer(value, default: int) -> int:
    """``value`` as an int, ``default`` when it is missing or not a number."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        return default
    return int(number) if math.isfinite(number) else default


def _made_by(record, plan: Plan) -> bool:
    """Whether a stored record is the plan's: its cells' seeds and measured cycles."""
    return (len(record.fidelity.seeds) == plan.cells
            and int(record.fidelity.get("measured_cycles") or -1) == plan.measured_cycles)


def _record_cpu_s(record) -> float:
    """Measured engine CPU of a record, s (NaN when it does not say)."""
    return float(record.cpu_time_s)
