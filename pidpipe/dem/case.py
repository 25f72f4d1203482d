"""One case in the compiled DEM, with the record of the LIGGGHTS path (:func:`pidpipe.liggghts.shake.run_case`).

The same settings, case and packings (poured by ``fidelity.pour_engine``), the k cells of ``fidelity.cells_per_run``
integrated as one batch, and the same rules on the result: the steady-state verdict on the k
cells' summed series (:func:`pidpipe.measurement.steady_state.assess_steady_state`), the mean cell's C_eq
with a standard error that includes the packing scatter
(:func:`pidpipe.measurement.cells.summarise_cells`), containment flags at every cycle end. The
record has every key of the LIGGGHTS record (``solver`` and ``engine.name`` say which produced
it); ``cycles`` holds the k cells' series summed, with the term-by-term dissipation as
``dissipated_j`` (the DEM's E_d; the balance is under ``dem``), and ``dem`` the DEM's own
ledgers: the balance, its mismatch with the term-by-term sum, and the dissipation by term and
contact type. With ``settings.motion`` the kernel samples the bed's motion within the cycle
as the LIGGGHTS deck does, and the record's ``regime`` and ``motion`` come from it by the same
code (:func:`pidpipe.measurement.inspection.motion_record`).

A case's run can go on (:func:`start_dem_case`, :class:`DemCaseRun`): its end state stays in
memory, and :meth:`DemCaseRun.extend` takes it on to more measured cycles, giving the record of
one run that long from the pour, to the last bit; the allocation's "more cycles" steps use it
(:func:`pidpipe.measurement.adaptive.run_to_target`).
"""

from __future__ import annotations

import dataclasses
import platform
import time
from pathlib import Path
from typing import Sequence

import numpy as np

from pidpipe.cases import CaseSpec, regime
from pidpipe.cell.packing import Packing, pour_engines
from pidpipe.cell.scene import CellScene
from pidpipe.config.settings import ShakeSettings
from pidpipe.dem.contacts import DISSIPATION_TERMS
from pidpipe.dem.from_scene import dem_scene
from pidpipe.dem.run import CONTACT_TYPES, SOLVER_NAME, CycleRun, start
from pidpipe.liggghts.parsing import CycleSeries
from pidpipe.liggghts.shake import checked_packing_list, containment_flags
from pidpipe.measurement.case_record import CaseRecord
from pidpipe.measurement.cells import summarise_cells
from pidpipe.measurement.harmonics import harmonics_record
from pidpipe.measurement.inspection import motion_record
from pidpipe.measurement.run_record import fidelity_record
from pidpipe.measurement.steady_state import assess_steady_state
from pidpipe.physics.equivalent_damping import displacement_amplitude_m

ENGINE_NAME = "dem"
"""The value of ``engine`` in the config that selects this path."""
BALANCE_TOLERANCE = 0.01
"""Largest difference, in any cycle, between the term-by-term dissipation and the energy
balance, as a fraction of the work exchanged with the walls (the two differ by the O(dt^2)
error of the trapezoidal work of the elastic forces; measured well below 1e-3 of E_d)."""


def run_dem_case(settings: ShakeSettings, case: CaseSpec, packings: Packing | Sequence[Packing],
                 workdir: str | Path | None = None) -> CaseRecord:
    """Shake one case in the compiled DEM and return its record.

    Parameters
    ----------
    settings : ShakeSettings
        The cell, materials, fidelity and sampling of the case.
    case : CaseSpec
    packings : Packing or sequence of Packing
        One settled packing per cell (all of the case's fill, so of equal sphere counts).
    workdir : path, optional
        Unused (the DEM writes no files); accepted so that both engines are called alike.

    Returns
    -------
    CaseRecord
        The case record.
    """
    return start_dem_case(settings, case, packings, workdir).record


def start_dem_case(settings: ShakeSettings, case: CaseSpec, packings: Packing | Sequence[Packing],
                   workdir: str | Path | None = None) -> "DemCaseRun":
    """:func:`run_dem_case`, keeping the run's end state so that it can go on (:class:`DemCaseRun`)."""
    return DemCaseRun(settings, case, packings)


class DemCaseRun:
    """One case's run in the compiled DEM, kept in memory so that it can be continued.

    The run shakes the case for its configured transient + ``measured_cycles`` cycles and
    keeps its end state (positions, velocities, spins, forces, contact history, the walls'
    phase): :meth:`extend` runs the cycles that make it a run of more measured cycles and gives
    the record that one run of that length from the pour gives, to the last bit
    (tests/dem/test_case.py): the series extended, and the steady-state verdict, the measured
    cycles and every summary decided on the whole of it. Only the record's timing differs:
    ``engine`` (``cpu_time_s``, ``wall_time_s``, ``steps``) and ``wall_time_s`` are the last
    call's alone, and ``engine.continued_from_cycles`` the cycles the run had before it
    (0 for the first).

    Parameters
    ----------
    settings, case, packings
        As for :func:`run_dem_case`.

    Attributes
    ----------
    record : CaseRecord
        The record of the run so far.
    """

    def __init__(self, settings: ShakeSettings, case: CaseSpec,
                 packings: Packing | Sequence[Packing]):
        started, cpu_started = time.perf_counter(), time.process_time()
        self.settings, self.case = settings, case
        self.packings = checked_packing_list(packings, case.case_id)
        self.cell_scene = CellScene.of(settings)
        scene = dem_scene(self.cell_scene, case.freq_hz, [case.accel_g] * len(self.packings))
        scene, state, ws = start(scene, np.stack([packing.centres() for packing in self.packings]))
        self.scene = scene
        self.run = CycleRun(scene, state, ws, settings.motion)
        self.record: CaseRecord | None = None
        self._go_on(settings, started, cpu_started)

    @property
    def configured_transient(self) -> int:
        """The case's configured transient, cycles."""
        return self.settings.sampling.transient_cycles_at(self.case.freq_hz)

    def extend(self, measured_cycles: int) -> CaseRecord:
        """Go on to ``measured_cycles`` measured cycles (more than the run has) and return the record.

        Raises
        ------
        ValueError
            ``measured_cycles`` is not more than the run's measured cycles.
        """
        started, cpu_started = time.perf_counter(), time.process_time()
        sampling = self.settings.sampling
        if measured_cycles <= sampling.measured_cycles:
            raise ValueError(f"a run of {sampling.measured_cycles} measured cycles goes on to more, "
                             f"not to {measured_cycles}")
        settings = dataclasses.replace(
            self.settings, sampling=dataclasses.replace(sampling, measured_cycles=int(measured_cycles)))
        return self._go_on(settings, started, cpu_started)

    def _go_on(self, settings: ShakeSettings, started: float, cpu_started: float) -> CaseRecord:
        before = self.run.n_cycles
        self.run.run(self.configured_transient + settings.sampling.measured_cycles - before)
        self.settings = settings
        record = case_record(settings, self.case, self.packings, self.cell_scene, self.scene,
                             self.run.cycles(), self.run.motion())
        wall_time, cpu_time = time.perf_counter() - started, time.process_time() - cpu_started
        engine = engine_record(wall_time, cpu_time,
                               (self.run.n_cycles - before) * self.scene.steps_per_cycle)
        self.record = record.with_(engine={**engine, "continued_from_cycles": before},
                                   wall_time_s=wall_time)
        return self.record


def case_record(settings: ShakeSettings, case: CaseSpec, packings: list[Packing],
                cell_scene: CellScene, scene, cycles: dict, motion) -> CaseRecord:
    """The record of a DEM case from its run's ledgers (:meth:`CycleRun.cycles`) and sampled
    motion (or None); ``engine`` and ``wall_time_s`` are the caller's to add."""
    k = len(packings)
    sampling = settings.sampling
    block = sampling.sem_block_cycles
    configured_transient = sampling.transient_cycles_at(case.freq_hz)
    series = summed_series(cycles)
    balance = cycles["dissipated_balance_j"]
    steady = assess_steady_state(series.dissipated_j, series.energy_j, configured_transient,
                                 block)
    transient = steady.transient_cycles
    n_coupon = settings.coupon_n_cells
    summary = summarise_cells([cell[transient:] for cell in cycles["dissipated_terms_j"]],
                              case.freq_hz, case.accel_g, n_coupon, block)
    for cell_summary, terms, packing in zip(summary["cells"], cycles["dissipated_terms_j"],
                                            packings):
        cell_summary.update(seed=packing.seed, n_spheres=packing.n_spheres,
                            pile_height_m=packing.pile_height_m, dissipated_j=terms.tolist())
    inspection = ({"regime": regime(case.accel_g)} if motion is None else motion_record(
        motion, transient, scene.steps_per_cycle, settings.motion.windows_per_cycle,
        [float(np.ptp(packing.centres()[:, 2])) for packing in packings]))
    mismatch = balance_mismatch(series.dissipated_j, balance.sum(axis=0), series.gross_work_j)
    harmonics = harmonics_record(cycles["harmonic_cos_n_s"], cycles["harmonic_sin_n_s"], transient,
                                 case.freq_hz, case.accel_g, scene.mass_kg * packings[0].n_spheres,
                                 block, summary["ceq_cell_ns_m"], summary["ceq_cell_sem_ns_m"],
                                 series.energy_j)
    flags = (containment_flags(cell_scene, series, displacement_amplitude_m(case.freq_hz, case.accel_g))
             + steady.flags + (["ledger_mismatch"] if mismatch > BALANCE_TOLERANCE else [])
             + harmonics["flags"])
    measured = slice(transient, None)
    return CaseRecord.of_run(
        SOLVER_NAME, case, packings[0].n_spheres, flags,
        **summary,
        **steady.as_record(),
        **inspection,
        wall_work_cycle_mean_j=float(series.wall_work_j[measured].mean()) / k,
        ledger_mismatch_of_gross_work=mismatch,
        cycles=series.as_record(),
        fidelity=fidelity_record(settings, cell_scene.timestep(case.freq_hz), transient,
                                 [packing.seed for packing in packings], ENGINE_NAME,
                                 configured_transient, packings[0].pile_height_m,
                                 pour_engines(packings)),
        dem={
            "balance_dissipated_j": balance.sum(axis=0).tolist(),
            "balance_cycle_mean_j": float(balance[:, measured].mean()),
            "balance_mismatch_fraction": float(
                (series.dissipated_j[measured].sum() - balance[:, measured].sum())
                / balance[:, measured].sum()),
            "dissipated_by_term_j": {
                f"{term}_{ctype}_j": float(cycles[f"{term}_{ctype}_j"][:, measured].mean())
                for term in DISSIPATION_TERMS for ctype in CONTACT_TYPES},
        },
        harmonics=harmonics,
    )


def summed_series(cycles: dict) -> CycleSeries:
    """The k cells' per-cycle series summed, as the LIGGGHTS path's :class:`CycleSeries`.

    ``dissipated_j`` is the term-by-term E_d; ``energy_j`` the ledger energy K^ + P + U
    (:mod:`pidpipe.dem.energy`), ``elastic_j`` its U; the lowest and highest sphere centres
    are over all cells at each cycle's end.
    """
    elastic = cycles["elastic_j"].sum(axis=0)
    energy = cycles["ledger_energy_j"].sum(axis=0)
    return CycleSeries(wall_work_j=cycles["wall_work_j"].sum(axis=0),
                       gross_work_j=cycles["gross_work_j"].sum(axis=0),
                       energy_j=energy,
                       dissipated_j=cycles["dissipated_terms_j"].sum(axis=0),
                       lowest_z_m=cycles["lowest_z_m"].min(axis=0)[1:],
                       highest_z_m=cycles["highest_z_m"].max(axis=0)[1:],
                       mechanical_j=energy - elastic, elastic_j=elastic)


def balance_mismatch(terms_j: np.ndarray, balance_j: np.ndarray, gross_j: np.ndarray) -> float:
    """Largest |term-by-term - balance| of any cycle over the mean work exchanged (0 if none)."""
    gross = float(np.mean(gross_j))
    return float(np.max(np.abs(terms_j - balance_j)) / gross) if gross > 0 else 0.0


def engine_record(wall_time_s: float, cpu_time_s: float, steps: int) -> dict:
    """The ``engine`` block of a DEM record: which solver, its version, what the run cost."""
    import numba

    return {"name": ENGINE_NAME, "solver": SOLVER_NAME, "version": f"numba {numba.__version__}",
            "wall_time_s": wall_time_s, "cpu_time_s": cpu_time_s, "steps": int(steps),
            "host": platform.node()}
