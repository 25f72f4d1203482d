"""Measure a case until its C_eq has the standard error asked for, at the least CPU.

With ``fidelity.target_relative_sem`` set (0.05 by default), a case first runs its pilot: the
configured k0 = ``cells_per_run`` cells x n0 = ``measured_cycles`` cycles. From the pilot's
cells the two variance components of the case's SEM are estimated (the spread between packings
and the cells' cycle noise, :func:`pidpipe.measurement.cells.mean_of_cells`); then
:func:`pidpipe.measurement.allocation.plan_next_step` chooses, from the engine's cost model,
the cheapest next step: more cells (new packings, new runs), more cycles on the cells already
shaken, or both. More cycles continue each run from where it ended when the engine can
(the compiled DEM: ``extend``, and the cost of only the cycles added); otherwise the same runs
are made again, longer (LIGGGHTS: they replay the shorter ones cycle for cycle).
After each step the components are estimated again from all the cells, and so on until the SEM
is at most the target, or a cap stops it (``max_cells_per_case``, ``max_measured_cycles``,
``max_case_cpu_s``, :data:`MAX_STEPS`): then the record is flagged ``target_not_reached`` and
keeps the SEM it got. A C_eq not resolved from zero is not chased (no step), nor is a pilot
at G <= 1 whose bed never lifted off (:data:`RESTING_BED`), nor a pilot
that fails a steady-state check (:data:`UNSTEADY_FLAGS`): such a case is flagged and not
fitted, and more cells or cycles did not clear the flag in any of the 10 cases measured. A case
whose later run fails one is chased no further, for the same reason (the flag is the union of
the runs' own).

The CPU cap is checked against the cost model's CPU of the runs (their planned cost), not the
measured one, so that a loaded machine does not change which runs a case makes: the same config
gives the same record. The record lists every run that made it (``target.runs``), the measured
CPU and wall time of each, and the sums.

:func:`measure_to_target` is the engine-free core (callables and numbers);
:func:`run_to_target` binds it to a case's settings and an engine's ``run``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import replace
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from pidpipe.config.settings import ShakeSettings
from pidpipe.measurement.allocation import Components, Limits, Step, plan_next_step
from pidpipe.measurement.case_record import CaseRecord, Fidelity
from pidpipe.measurement.cells import summarise_cells
from pidpipe.measurement.harmonics import LEDGER_FLAG, combine_harmonics
from pidpipe.measurement.regime import NO_LIFT_OFF
from pidpipe.measurement.steady_state import NOT_RESOLVED_SEMS, SIGN_FLAGS, sign_flags

MAX_STEPS = 4
"""Steps after the pilot, at most."""

PRIOR_PACKING_RELATIVE_STD = 0.06
"""Spread between packings assumed, as a fraction of C_eq, when the pilot has one cell (no
spread to measure): 4.9-6.7 % was measured beyond the cycle noise (docs/explanation/scene.md)."""

UNSTEADY_FLAGS = ("not_steady", "not_stationary")
"""A pilot with one of these flags is not chased: in the default campaign at 5 % (2026-12-01,
``benchmarks/results.md``) 10 pilots failed a steady-state check, the steps after them cost 953
of the campaign's 5123 LIGGGHTS CPU-s, and none of the 10 cases ended unflagged (a flagged case
is never fitted). Nor is a case after a step whose run has one: in the DEM campaign of
2026-12-01 18:13 UTC (``benchmarks/results.md``, "Whole campaign", 18:18) 8 cases had a run
flagged so after the pilot, and all 8 ended flagged; run with and without this rule (the
sections of 19:50 and 20:07 UTC, the same code otherwise), it marked 9 cases not chased, and
each of the 9 ended flagged both ways (one had reached its target at that step: such a case is
no longer marked)."""

RESTING_BED = "the bed rests on the floor (regime no_lift_off)"
"""Why a case at G <= 1 whose pilot's bed never lifted off is not chased. Below lift-off the bed
rides the floor: its C_eq is the contacts' small residual, whose relative SEM no number of cells
brings down (f50Hz_G0.5_r50pct: 1.4e-5 +- 3.5e-6 N s/m per cell after 28 cells, 2 runs,
``target_not_reached``), while its effective mass, the part a structure feels, is the bed's
mass. Such a case keeps its pilot and is flagged ``target_not_reached``. Above 1 g the regime
can read no_lift_off too (a full cell at 500-1000 Hz and 2 g, where the wall moves by a fraction
of a micrometre), but there C_eq is resolved (5-13 % relative SEM from the pilot in the default
DEM campaign) and the case is chased as any other."""

TARGET_NOT_REACHED = "target_not_reached"
"""The flag of a case that ended above its target. It is a note on precision, not a failed
check: the case keeps its status and is fitted with the SEM it reports."""


def components_of(record: CaseRecord, measured_cycles: int | None = None) -> Components:
    """The variance components of a (combined) case record (:func:`combine_runs`).

    Parameters
    ----------
    record : CaseRecord
    measured_cycles : int, optional
        The measured cycles its runs were made with (as configured). The cells keep fewer when
        the steady-state test found a longer transient than the configured one; the difference
        becomes :attr:`Components.lost_cycles`, chosen so that the components give, at the
        record's cells and cycles, the cycle part of the SEM the record reports (a plan made
        with the configured cycles would see a SEM below the reported one, and could stop a
        case short of its target). None: none lost.
    """
    value = record.ceq_cell_ns_m
    packing_std = _number(record.ceq_cell_packing_std_ns_m)
    if not math.isfinite(packing_std):
        packing_std = PRIOR_PACKING_RELATIVE_STD * abs(value)
    noise_var = record.cycle_noise_ns_m_sqrt_cycle ** 2
    return Components(value, packing_std ** 2, noise_var,
                      _lost_cycles(record, noise_var, measured_cycles))


def _number(value: float | None) -> float:
    """A record's optional value, NaN when the record has none."""
    return float("nan") if value is None else float(value)


def _lost_cycles(record: CaseRecord, noise_var: float, measured_cycles: int | None) -> float:
    """Configured measured cycles minus the cycles the record's cells kept in effect: tau^2 over
    the mean of the cells' squared cycle SEMs (the cells' own count when they agree), >= 0."""
    cells = max(len(record.cells or ()), 1)
    cycle_var = cells * _number(record.ceq_cell_cycle_sem_ns_m) ** 2
    if measured_cycles is None or not (math.isfinite(cycle_var) and cycle_var > 0.0):
        return 0.0
    return max(0.0, float(measured_cycles) - noise_var / cycle_var)


def measure_to_target(pilot: Sequence, pilot_cycles: int, relative_sem: float | None,
                      limits: Limits, shake: Callable[[list, int, int], CaseRecord],
                      new_packings: Callable[[int, int], list],
                      costs: Callable[[CaseRecord], tuple],
                      combine: Callable[[list[CaseRecord]], CaseRecord],
                      extend: Callable[[int, int], CaseRecord] | None = None) -> CaseRecord:
    """Run the pilot, then the planned steps, and return the case's combined record.

    Parameters
    ----------
    pilot : sequence of packings
        The pilot's cells (one run).
    pilot_cycles : int
        The pilot's measured cycles, n0.
    relative_sem : float or None
        Target SEM / C_eq; None: the pilot alone, as configured.
    limits : Limits
    shake : callable
        ``shake(packings, measured_cycles, run_index) -> record`` of one run; the same packings
        and index again must replay the earlier run (a longer run extends it).
    new_packings : callable
        ``new_packings(first, count)``: the packings of the case's cells first .. first+count-1
        (cells 0 .. k0-1 are the pilot's).
    costs : callable
        ``costs(pilot_record) -> (run_cpu_s, pour_cpu_s)``: the cost of one run of k cells x n
        measured cycles (s) and the CPU charged per new packing (s); with ``extend``, a third
        element ``extend_cpu_s(k, n, n_new)``: the cost of taking a run of k cells on from n to
        n_new measured cycles (s).
    combine : callable
        ``combine(records) -> record``: the case record of the runs' cells together (:func:`combine_runs`).
    extend : callable, optional
        ``extend(run_index, measured_cycles) -> record``: take the run made as ``run_index`` on
        to ``measured_cycles`` and return its record, the record of one run that long. With it,
        more cycles continue the runs (each run keeps its index, its entries in ``runs`` are
        ``continued``); without, they make them again.

    Returns
    -------
    CaseRecord
        The combined record; with a target, ``target`` = {relative_sem, reached, cells,
        measured_cycles, not_chased (why the case was not chased, or not further; None when
        it ran to the target or a cap), runs (every
        run, and every continuation of one: index, kind, continued, from_measured_cycles,
        seeds, measured cycles, used, cpu_time_s, planned_cpu_s, wall_time_s), steps (each
        planned step), cpu_time_s, planned_cpu_s, wall_time_s}, and ``target_not_reached``
        in ``flags`` when it was missed.
    """
    groups = [list(pilot)]                       # packings of each current run, by run index
    records = [shake(groups[0], pilot_cycles, 0)]
    if relative_sem is None:
        return records[0]
    run_cpu_s, pour_cpu_s, *more = costs(records[0])
    extend_cpu_s = more[0] if extend is not None else None
    runs = Runs(shake, extend, run_cpu_s, extend_cpu_s, pour_cpu_s)
    cycles = pilot_cycles
    history = [_run_entry(records[0], 0, "pilot", groups[0], run_cpu_s(len(groups[0]), cycles))]
    planned_steps = []
    current = {0: records[0]}
    case = combine(list(current.values()))
    unsteady_pilot = _unsteady_flags(records[0])
    not_chased = f"the pilot is flagged {', '.join(unsteady_pilot)}" if unsteady_pilot else None
    if not_chased is None and records[0].regime == NO_LIFT_OFF and records[0].accel_g <= 1.0:
        not_chased = RESTING_BED
    for _ in range(0 if not_chased else MAX_STEPS):
        value, sem = case.ceq_cell_ns_m, case.ceq_cell_sem_ns_m
        if not (math.isfinite(sem) and value > NOT_RESOLVED_SEMS * sem):
            not_chased = "C_eq is not resolved from zero"
            break
        if _at_target(case, relative_sem):
            break
        cells = _cells(groups, current)
        spent = sum(entry["planned_cpu_s"] for entry in history)
        continue_cpu_s = None if extend is None else functools.partial(
            _continue_cpu_s, [len(groups[i]) for i in current], cycles, extend_cpu_s)
        step = plan_next_step(components_of(case, cycles), cells, cycles, spent, relative_sem * value,
                              limits, run_cpu_s, pour_cpu_s, continue_cpu_s)
        if step is None:
            break
        planned_steps.append(step.as_record())
        current = _take_step(step, cycles, groups, current, runs, new_packings,
                             limits.cells_per_run, history)
        cycles = step.cycles
        case = combine([current[i] for i in sorted(current)])
        unsteady = _unsteady_flags(case)
        if unsteady and not _at_target(case, relative_sem):
            # flagged, so never fitted: its SEM is not worth more CPU
            not_chased = (f"flagged {', '.join(unsteady)} after step {len(planned_steps)} "
                          f"({_cells(groups, current)} cells x {cycles} cycles)")
            break
    reached = _at_target(case, relative_sem)
    _mark_used(history, current)
    target = {
        "relative_sem": relative_sem, "reached": reached,
        "cells": _cells(groups, current), "measured_cycles": cycles,
        "limits": {"max_cells": limits.max_cells, "max_measured_cycles": limits.max_cycles,
                   "max_case_cpu_s": limits.max_cpu_s, "cells_per_run": limits.cells_per_run},
        "not_chased": not_chased, "runs": history, "steps": planned_steps,
        "cpu_time_s": float(sum(entry["cpu_time_s"] for entry in history)),
        "planned_cpu_s": float(sum(entry["planned_cpu_s"] for entry in history)),
        "wall_time_s": float(sum(entry["wall_time_s"] for entry in history)),
    }
    flags = case.flags if reached else case.flags + (TARGET_NOT_REACHED,)
    return case.with_(target=target, flags=flags)


def _at_target(case: CaseRecord, relative_sem: float) -> bool:
    """Whether the case's C_eq is positive and its SEM at most ``relative_sem`` of it."""
    value, sem = case.ceq_cell_ns_m, case.ceq_cell_sem_ns_m
    return bool(sem <= relative_sem * value and value > 0.0)


def _unsteady_flags(record: CaseRecord) -> list[str]:
    """The record's flags among :data:`UNSTEADY_FLAGS`."""
    return [flag for flag in record.flags if flag in UNSTEADY_FLAGS]


def _cells(groups: list[list], current: dict) -> int:
    """Cells of the current runs."""
    return sum(len(groups[i]) for i in current)


@dataclasses.dataclass(frozen=True)
class Runs:
    """How a case's runs are made and priced: ``shake`` and ``extend`` as for
    :func:`measure_to_target` (``extend`` None: runs are not continued), ``run_cpu_s(k, n)``,
    ``extend_cpu_s(k, n, n_new)`` and ``pour_cpu_s`` the planned CPU of each (s)."""

    shake: Callable
    extend: Callable | None
    run_cpu_s: Callable
    extend_cpu_s: Callable | None
    pour_cpu_s: float


def _continue_cpu_s(run_cells: list[int], cycles: int, extend_cpu_s: Callable,
                    new_cycles: int) -> float:
    """Planned CPU of taking every run (of these cells each) on from ``cycles`` to ``new_cycles``, s."""
    return float(sum(extend_cpu_s(k, cycles, new_cycles) for k in run_cells))


def _take_step(step: Step, cycles: int, groups: list[list], current: dict[int, CaseRecord],
               runs: Runs, new_packings: Callable, cells_per_run: int,
               history: list[dict]) -> dict[int, CaseRecord]:
    """Make the runs of ``step`` (from ``cycles`` measured cycles); return the records now
    current, by run index. Each new run's ``planned_cpu_s`` includes the pours charged for the
    new packings it shakes; a continued run's is that of the cycles added."""
    cells = sum(len(groups[i]) for i in current)
    added = new_packings(cells, step.new_cells) if step.new_cells else []
    current = dict(current)
    for index in sorted(current) if step.continued_cells else []:   # the runs go on
        record = runs.extend(index, step.cycles)
        current[index] = record
        history.append(_run_entry(record, index, step.kind, groups[index],
                                  runs.extend_cpu_s(len(groups[index]), cycles, step.cycles),
                                  continued_from=cycles))
    if step.kind == "more_cycles" and not step.continued_cells:   # the same runs, longer (they replay)
        plan = [(i, groups[i]) for i in sorted(current)]
        current = {}
    elif step.kind == "more_cells" or step.continued_cells:
        plan = [(len(groups) + j, chunk) for j, chunk in enumerate(_chunks(added, cells_per_run))]
    else:                                         # both: every cell, in new runs
        everything = [p for i in sorted(current) for p in groups[i]] + added
        plan = [(len(groups) + j, chunk) for j, chunk in enumerate(_chunks(everything, cells_per_run))]
        current = {}
    fresh = {id(packing) for packing in added}
    for index, packings in plan:
        if index == len(groups):
            groups.append(packings)
        record = runs.shake(packings, step.cycles, index)
        current[index] = record
        pours = sum(id(packing) in fresh for packing in packings)
        history.append(_run_entry(record, index, step.kind, packings,
                                  runs.run_cpu_s(len(packings), step.cycles) + pours * runs.pour_cpu_s))
    return current


def _mark_used(history: list[dict], current: dict[int, CaseRecord]) -> None:
    """Set each entry's ``used``: its cells' cycles are in the case record (its run is current
    and it is the run's last entry, or one that the later, continued, entries took on)."""
    for entry in history:
        entry["used"] = False
    for run in current:
        for entry in reversed([entry for entry in history if entry["run"] == run]):
            entry["used"] = True
            if not entry["continued"]:
                break


def _chunks(items: list, size: int) -> list[list]:
    """``items`` in as few chunks of at most ``size`` as possible, of near-equal lengths."""
    count = math.ceil(len(items) / size)
    bounds = np.linspace(0, len(items), count + 1).round().astype(int)
    return [items[a:b] for a, b in zip(bounds[:-1], bounds[1:])]


def _run_entry(record: CaseRecord, index: int, kind: str, packings: list, planned_cpu_s: float,
               continued_from: int | None = None) -> dict:
    """One entry of ``target.runs``: a run, or the part of it that a continuation added (its
    ``continued`` true, ``from_measured_cycles`` the measured cycles it went on from, 0 for a
    run from the pour; its CPU that of the continuation alone)."""
    return {"run": index, "kind": kind, "continued": continued_from is not None,
            "from_measured_cycles": int(continued_from or 0), "seeds": [int(p.seed) for p in packings],
            "cells": len(packings), "measured_cycles": record.fidelity.measured_cycles,
            "transient_cycles": record.fidelity.transient_cycles,
            "status": record.status, "flags": list(record.flags),
            "ceq_cell_ns_m": record.ceq_cell_ns_m, "ceq_cell_sem_ns_m": record.ceq_cell_sem_ns_m,
            "cpu_time_s": record.engine_cpu_s, "planned_cpu_s": float(planned_cpu_s),
            "wall_time_s": float(record.wall_time_s)}


def cell_series(record: CaseRecord) -> list[dict]:
    """Each cell of one run record: its measured E_d series (after the run's transient) and packing.

    Returns
    -------
    list of dict
        ``dissipated_j`` (ndarray, shape (n_measured,), J), ``seed``, ``n_spheres``,
        ``pile_height_m``, ``dissipated_all_j`` (the whole series, transient included).
    """
    transient = record.fidelity.transient_cycles
    if record.cells:
        return [{"dissipated_j": np.asarray(cell["dissipated_j"][transient:], dtype=float),
                 "dissipated_all_j": cell["dissipated_j"], "seed": cell["seed"],
                 "n_spheres": cell["n_spheres"], "pile_height_m": cell["pile_height_m"]}
                for cell in record.cells]
    series = record.cycles["dissipated_j"]
    return [{"dissipated_j": np.asarray(series[transient:], dtype=float), "dissipated_all_j": series,
             "seed": record.fidelity.seed, "n_spheres": record.n_spheres,
             "pile_height_m": record.fidelity.pile_height_m}]


def combine_runs(records: list[CaseRecord], freq_hz: float, accel_g: float,
                 n_cells_coupon: int) -> CaseRecord:
    """The case record of several runs' cells together: one estimate over all of them.

    Parameters
    ----------
    records : list of CaseRecord
        Run records (:func:`pidpipe.liggghts.shake.run_case`, :func:`pidpipe.dem.case.run_dem_case`),
        each with its cells' series; the cells of all are distinct packings.
    freq_hz, accel_g : float
    n_cells_coupon : int

    Returns
    -------
    CaseRecord
        The last record, with the mean cell, its standard errors and ``cells`` from
        :func:`pidpipe.measurement.cells.summarise_cells` over every run's cells (each cell
        also names its ``run``); ``flags`` the union of the runs' own, with the sign flags
        (:func:`pidpipe.measurement.steady_state.sign_flags`) decided on the combined C_eq and
        SEM, and the force-energy ledger flag on the combined ``harmonics``
        (:func:`pidpipe.measurement.harmonics.combine_harmonics`, when every run has them);
        ``status`` from them; ``fidelity.seeds`` every cell's seed and ``fidelity.cells``
        their number. ``cycles`` and the steady-state fields stay the last run's.
    """
    last = records[-1]
    cells = [(index, cell) for index, record in enumerate(records) for cell in cell_series(record)]
    block = last.fidelity.sem_block_cycles
    summary = summarise_cells([cell["dissipated_j"] for _, cell in cells], freq_hz, accel_g,
                              n_cells_coupon, block)
    own = summary["cells"] or [{key: summary[key] for key in
                                ("ceq_cell_ns_m", "ceq_cell_sem_ns_m", "ed_cycle_mean_j", "n_cycles")}]
    if len(cells) > 1:
        for entry, (index, cell) in zip(own, cells):
            entry.update(run=index, seed=cell["seed"], n_spheres=cell["n_spheres"],
                         pile_height_m=cell["pile_height_m"], dissipated_j=cell["dissipated_all_j"])
        summary["cells"] = own
    harmonics = (combine_harmonics(records, summary["ceq_cell_ns_m"], summary["ceq_cell_sem_ns_m"])
                 if all(record.harmonics is not None for record in records) else last.harmonics)
    flags = [flag for record in records for flag in record.flags
             if flag not in SIGN_FLAGS and flag != LEDGER_FLAG]
    flags = list(dict.fromkeys(flags + sign_flags(summary["ceq_cell_ns_m"], summary["ceq_cell_sem_ns_m"])
                               + list((harmonics or {}).get("flags", []))))
    fidelity = Fidelity(last.fidelity, seeds=[int(cell["seed"]) for _, cell in cells], cells=len(cells))
    return last.with_(**summary, flags=flags, status="flagged" if flags else "ok", fidelity=fidelity,
                      harmonics=harmonics)


def run_to_target(settings: ShakeSettings, case, packings, workdir: str | Path,
                  run: Callable[[ShakeSettings, object, list, Path], CaseRecord] | None = None,
                  new_packings: Callable[[int, int], list] | None = None,
                  cost_model=None, steps_per_cycle: int | None = None,
                  transient_cycles: int | None = None,
                  start: Callable[[ShakeSettings, object, list, Path], object] | None = None,
                  pour_model=None) -> CaseRecord:
    """A case measured to ``sampling.target_relative_sem`` with ``run`` (:func:`measure_to_target`).

    Parameters
    ----------
    settings : ShakeSettings
        The case's settings: ``sampling`` target_relative_sem, measured_cycles (the pilot's),
        max_measured_cycles, max_cells_per_case, max_case_cpu_s; ``coupon_n_cells``.
    case : CaseSpec
    packings : Packing or sequence of Packing
        The pilot's cells.
    workdir : path
        Run 0 is made here, run i in ``workdir/run<i>``.
    run : callable
        ``run(settings, case, packings, workdir) -> record`` of one run
        (:func:`pidpipe.liggghts.shake.run_case` or :func:`pidpipe.dem.case.run_dem_case`); its
        measured cycles are ``settings.sampling.measured_cycles``.
    new_packings : callable, optional
        As for :func:`measure_to_target`; None: the case cannot add cells (cells cap = pilot).
    cost_model : CostModel, optional
        The engine's (:func:`pidpipe.measurement.cost_model.load_cost_model`); None: scaled from
        the pilot (:func:`pidpipe.measurement.cost_model.scaled_from_pilot`).
    pour_model : CostModel, optional
        The pour engine's, whose pour term prices a new packing (the DEM pours a packing several
        times cheaper than LIGGGHTS); None: ``cost_model``'s own pour term.
    steps_per_cycle, transient_cycles : int, optional
        Of the case's runs (the cost model counts time steps); by default the case's own, from
        its scene's timestep and its sampling.
    start : callable, optional
        For an engine whose runs can go on: ``start(settings, case, packings, workdir) -> run``
        makes a run as ``run`` does (:func:`pidpipe.dem.case.start_dem_case`) and keeps it, an
        object with ``record`` (its record) and ``extend(measured_cycles) -> record`` (the run
        taken on to more measured cycles, its record that of one run that long). Every run is
        then made with it and kept in memory for the case, and more cycles continue them, each
        priced as the cost model's run of the cycles added alone (no transient). ``run`` is then
        not needed.
    """
    from pidpipe.cell.layout import MAX_CELLS
    from pidpipe.cell.scene import CellScene
    from pidpipe.measurement.cost_model import scaled_from_pilot

    sampling = settings.sampling
    if steps_per_cycle is None:
        steps_per_cycle = CellScene.of(settings).timestep(case.freq_hz).steps_per_cycle
    if transient_cycles is None:
        transient_cycles = sampling.transient_cycles_at(case.freq_hz)
    pilot = [packings] if not isinstance(packings, (list, tuple)) else list(packings)
    workdir = Path(workdir)
    target = sampling.target_relative_sem

    if run is None and start is None:
        raise ValueError("run_to_target needs an engine's run or start")
    kept = {}

    def shake(cells: list, cycles: int, index: int) -> CaseRecord:
        staged = replace(settings, sampling=replace(sampling, measured_cycles=int(cycles)))
        folder = workdir if index == 0 else workdir / f"run{index}"
        if start is None:
            return run(staged, case, cells, folder)
        kept[index] = start(staged, case, cells, folder)
        return kept[index].record

    def extend(index: int, cycles: int) -> CaseRecord:
        return kept[index].extend(int(cycles))

    def costs(pilot_record: CaseRecord):
        n_spheres = int(pilot_record.n_spheres)
        model = cost_model or scaled_from_pilot(
            "pilot", pilot_record.engine_cpu_s, len(pilot), n_spheres,
            steps_per_cycle * (transient_cycles + sampling.measured_cycles))
        return ((lambda k, n: model.run_cpu_s(k, n_spheres, steps_per_cycle * (transient_cycles + n))),
                (pour_model or model).pour_cpu_s(n_spheres),
                (lambda k, n, n_new: model.run_cpu_s(k, n_spheres, steps_per_cycle * (n_new - n))))

    limits = Limits(max_cells=sampling.max_cells_per_case if new_packings is not None else len(pilot),
                    max_cycles=sampling.max_measured_cycles,
                    max_cpu_s=sampling.max_case_cpu_s, cells_per_run=MAX_CELLS)
    return measure_to_target(
        pilot, sampling.measured_cycles, target, limits, shake,
        new_packings or (lambda first, count: []), costs,
        lambda records: combine_runs(records, case.freq_hz, case.accel_g, settings.coupon_n_cells),
        extend if start is not None else None)
