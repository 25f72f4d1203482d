"""The case record: what one case's measurement hands on, whichever engine made it.

Both engines return a :class:`CaseRecord` (:func:`pidpipe.liggghts.shake.run_case`,
:func:`pidpipe.dem.case.run_dem_case`), as does a case whose run failed
(:func:`pidpipe.steps.cases.failed_record`); the C_eq table, the studies, the checks and the
figures read its attributes. On disk it is JSON (:meth:`CaseRecord.write`, atomically), with the
keys in the order of the fields below; a field left None is not written (a failed case has no
series, a run without motion sampling no ``motion``, an unchased case no ``target``), so the
file is what the engines wrote as plain dicts before the record was typed, byte for byte.

The nested blocks stay mappings, as they are written: ``fidelity`` (:class:`Fidelity`),
``engine`` (:class:`Engine`) and ``target`` (:class:`Target`) are dicts whose widely read keys
are also attributes (``record.fidelity.seeds``, ``record.engine.cpu_time_s``); ``cycles``,
``cells``, ``motion``, ``movie`` and ``dem`` are read by few and stay plain.

A new optional field goes at the end of :class:`CaseRecord`, with the default None (then old
records, which lack it, still read); a change to what a field means bumps
:data:`RECORD_VERSION`.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from pathlib import Path
from typing import Any, Mapping

from pidpipe.errors import ParseError
from pidpipe.files import write_atomic

RECORD_VERSION = 4
"""3: energy_j includes the elastic energy held in the contacts (mechanical_j and elastic_j
keep the parts), and the potential energy is measured from the packing's starting centre of mass.
4: a case may shake k cells in one run (fidelity.cells_per_run): the values are the mean cell's,
``cells`` holds each cell's own, ``cycles`` the k cells' series summed, and the standard error
includes the scatter between the cells' packings (:func:`pidpipe.measurement.cells.summarise_cells`).
Each cell's wall work is from the force on its spheres (their total force plus their weight);
the mesh's total checks the cells' sum (``ledger_mismatch_of_gross_work``)."""

STATUSES = ("ok", "flagged", "failed", "missing")
"""A record's ``status``: ``missing`` only for the table's stand-in of a case without a record."""

NAN = float("nan")


class RecordVersionError(ParseError):
    """A case record on disk was written by another version of the record's layout."""


class Fidelity(dict):
    """A record's ``fidelity`` block (:func:`pidpipe.measurement.run_record.fidelity_record`):
    the settings the run was made with, a dict whose widely read keys are also attributes."""

    @property
    def timestep_s(self) -> float:
        """The run's timestep, s."""
        return float(self.get("timestep_s", NAN))

    @property
    def steps_per_cycle(self) -> int | None:
        return self.get("steps_per_cycle")

    @property
    def transient_cycles(self) -> int:
        """Cycles discarded before the measured window."""
        return int(self["transient_cycles"])

    @property
    def measured_cycles(self) -> int:
        """Measured cycles the run was made with (as configured)."""
        return int(self["measured_cycles"])

    @property
    def sem_block_cycles(self) -> int:
        return int(self["sem_block_cycles"])

    @property
    def seed(self) -> int:
        """The first cell's packing seed."""
        return int(self["seed"])

    @property
    def seeds(self) -> list[int]:
        """Every cell's packing seed."""
        return [int(seed) for seed in self.get("seeds", [self["seed"]] if "seed" in self else [])]

    @property
    def cells_per_run(self) -> int:
        return int(self.get("cells_per_run", 1))

    @property
    def cells(self) -> int:
        """Cells of the case, over all its runs (``cells`` after combining, else the run's)."""
        return int(self.get("cells", self.cells_per_run))

    @property
    def pile_height_m(self) -> float | None:
        return self.get("pile_height_m")

    @property
    def pour_engine(self) -> str | None:
        return self.get("pour_engine")

    @property
    def engine(self) -> str | None:
        """The engine the run was configured with (``liggghts`` or ``dem``)."""
        return self.get("engine")


class Engine(dict):
    """A record's ``engine`` block: which solver, its version, what the run cost; a dict whose
    widely read keys are also attributes (NaN or None when the record has no such key)."""

    @property
    def name(self) -> str | None:
        return self.get("name")

    @property
    def solver(self) -> str | None:
        return self.get("solver")

    @property
    def version(self) -> str | None:
        return self.get("version")

    @property
    def cpu_time_s(self) -> float:
        """The engine's CPU time, s (LIGGGHTS' own count, or the process's for the DEM)."""
        return float(self.get("cpu_time_s", self.get("liggghts_cpu_time_s", NAN)))

    @property
    def wall_time_s(self) -> float:
        return float(self.get("wall_time_s", NAN))

    @property
    def loop_time_s(self) -> float:
        return float(self.get("liggghts_loop_time_s", NAN))

    @property
    def steps(self) -> int | None:
        return self.get("steps")

    @property
    def host(self) -> str | None:
        return self.get("host")


class Target(dict):
    """A record's ``target`` block (:func:`pidpipe.measurement.adaptive.measure_to_target`):
    how the case was measured to its target SEM, every run that made it."""

    @property
    def reached(self) -> bool | None:
        return self.get("reached")

    @property
    def runs(self) -> list[dict]:
        return list(self.get("runs", []))

    @property
    def cpu_time_s(self) -> float:
        """CPU of all the case's runs, s."""
        return float(self.get("cpu_time_s", NAN))


@dataclasses.dataclass(frozen=True, kw_only=True)
class CaseRecord:
    """One case's result: its coordinates, C_eq with its standard errors, checks and settings.

    The fields are in the order of the record's JSON; None means "not in the record". Values are
    SI unless named otherwise: C_eq in N s/m, energies in J, times in s.

    Attributes
    ----------
    record_version : int
        :data:`RECORD_VERSION` of the layout.
    solver : str
        The solver that made it (``liggghts`` or the DEM's :data:`pidpipe.dem.run.SOLVER_NAME`).
    case_id : str
    freq_hz, accel_g, fill_pct : float
        Frequency (Hz), acceleration amplitude (g) and fill (%).
    replicate : int
    n_spheres : int
        Spheres per cell.
    status : str
        ``ok``, ``flagged`` (a check failed: see ``flags``), ``failed`` (see ``message``) or
        ``missing`` (:data:`STATUSES`).
    flags : tuple of str
    message : str or None
        Why a failed case failed.
    n_cycles : int
        Measured cycles behind the values (0 for a failed case).
    ed_cycle_mean_j, ed_cycle_sem_j : float
        The mean cell's dissipation per cycle and its standard error, J.
    ed_cycle_std_j, ed_lag1_autocorrelation, displacement_amplitude_m : float or None
    ceq_cell_ns_m, ceq_cell_sem_ns_m, ceq_coupon_ns_m, ceq_coupon_sem_ns_m : float
        C_eq of the mean cell and of the coupon, with standard errors, N s/m (NaN if failed).
    ceq_cell_cycle_sem_ns_m, ceq_cell_between_cells_sem_ns_m, ceq_cell_packing_std_ns_m, cycle_noise_ns_m_sqrt_cycle : float or None
        The parts of the SEM (:func:`pidpipe.measurement.cells.summarise_cells`).
    cells : tuple of dict or None
        Each cell's own values and series (empty for one cell).
    detected_transient_cycles, energy_drift_fraction, halves_p_value : or None
        The steady-state verdict (:class:`pidpipe.measurement.steady_state.SteadyState`).
    regime : str or None
    motion, movie : dict or None
        The bed's sampled motion and the movie written, when asked for.
    wall_work_cycle_mean_j, ledger_mismatch_of_gross_work : float or None
    cycles : dict or None
        The per-cycle series (lists of J), of the cells summed.
    fidelity : Fidelity
    dem : dict or None
        The DEM's own ledgers (DEM records only).
    engine : Engine
    wall_time_s : float
        The record's wall time, s.
    target : Target or None
        How the case was measured to its target SEM.
    engine_attempts : int or None
        Attempts the campaign's step made.
    """

    record_version: int = RECORD_VERSION
    solver: str
    case_id: str
    freq_hz: float
    accel_g: float
    fill_pct: float
    replicate: int = 0
    n_spheres: int | None = None
    status: str
    flags: tuple[str, ...] = ()
    message: str | None = None
    n_cycles: int = 0
    ed_cycle_mean_j: float = NAN
    ed_cycle_sem_j: float = NAN
    ed_cycle_std_j: float | None = None
    ed_lag1_autocorrelation: float | None = None
    displacement_amplitude_m: float | None = None
    ceq_cell_ns_m: float = NAN
    ceq_cell_sem_ns_m: float = NAN
    ceq_coupon_ns_m: float = NAN
    ceq_coupon_sem_ns_m: float = NAN
    ceq_cell_cycle_sem_ns_m: float | None = None
    ceq_cell_between_cells_sem_ns_m: float | None = None
    ceq_cell_packing_std_ns_m: float | None = None
    cycle_noise_ns_m_sqrt_cycle: float | None = None
    cells: tuple[dict, ...] | None = None
    detected_transient_cycles: int | None = None
    energy_drift_fraction: float | None = None
    halves_p_value: float | None = None
    regime: str | None = None
    motion: dict | None = None
    movie: dict | None = None
    wall_work_cycle_mean_j: float | None = None
    ledger_mismatch_of_gross_work: float | None = None
    cycles: dict | None = None
    fidelity: Fidelity = dataclasses.field(default_factory=Fidelity)
    dem: dict | None = None
    engine: Engine = dataclasses.field(default_factory=Engine)
    wall_time_s: float = NAN
    target: Target | None = None
    engine_attempts: int | None = None
    harmonics: dict | None = None

    def __post_init__(self):
        if self.status not in STATUSES:
            raise ValueError(f"case record {self.case_id}: status {self.status!r}, "
                             f"expected one of {', '.join(STATUSES)}")
        coerce = object.__setattr__
        coerce(self, "flags", tuple(str(flag) for flag in self.flags))
        if self.cells is not None:
            coerce(self, "cells", tuple(self.cells))
        coerce(self, "fidelity", Fidelity(self.fidelity or {}))
        coerce(self, "engine", Engine(self.engine or {}))
        if self.target is not None:
            coerce(self, "target", Target(self.target))

    # --- what readers use across modules -------------------------------------------------

    @property
    def engine_name(self) -> str | None:
        """``engine.name``: the engine that made the record (``liggghts`` or ``dem``)."""
        return self.engine.name

    @property
    def engine_cpu_s(self) -> float:
        """The engine's CPU time of this run (the last run of a combined record), s."""
        return self.engine.cpu_time_s

    @property
    def cpu_time_s(self) -> float:
        """The record's CPU time: all the runs of a case measured to a target, else its one run, s."""
        if self.target is not None and "cpu_time_s" in self.target:
            return self.target.cpu_time_s
        return self.engine_cpu_s

    @property
    def measured(self) -> bool:
        """Whether the record holds values (``ok`` or ``flagged``)."""
        return self.status in ("ok", "flagged")

    @property
    def relative_sem(self) -> float:
        """C_eq's standard error over C_eq (NaN if C_eq is 0 or NaN)."""
        value = self.ceq_cell_ns_m
        return self.ceq_cell_sem_ns_m / value if value and math.isfinite(value) else NAN

    @classmethod
    def of_run(cls, solver: str, case, n_spheres: int, flags: list[str], **fields) -> "CaseRecord":
        """The record of one engine run of ``case`` (a :class:`pidpipe.cases.CaseSpec`): its id
        and numbers, ``status`` flagged when any of ``flags`` is set, and the run's ``fields``.

        Both engines build their records here (:func:`pidpipe.liggghts.shake.run_case`,
        :func:`pidpipe.dem.case.case_record`), so the case's part is written once.
        """
        return cls(solver=solver, case_id=case.case_id, freq_hz=case.freq_hz,
                   accel_g=case.accel_g, fill_pct=case.fill_pct, replicate=case.replicate,
                   n_spheres=n_spheres, status="flagged" if flags else "ok", flags=flags,
                   **fields)

    def with_(self, **changes) -> "CaseRecord":
        """A copy with ``changes`` (:func:`dataclasses.replace`)."""
        return dataclasses.replace(self, **changes)

    # --- serialisation -------------------------------------------------------------------

    def to_dict(self) -> dict:
        """The record as the JSON's dict: the fields in order, those left None out, tuples as lists."""
        out = {}
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if value is None:
                continue
            if isinstance(value, tuple):
                value = list(value)
            elif isinstance(value, dict):
                value = dict(value)
            out[field.name] = value
        return out

    def to_json(self) -> str:
        """The record's JSON text (indent 1, NaN written as ``NaN``)."""
        return json.dumps(self.to_dict(), indent=1, allow_nan=True)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str | os.PathLike | None = None) -> "CaseRecord":
        """The record of a dict read from JSON.

        Parameters
        ----------
        data : mapping
        source : path, optional
            Where it was read, for the messages.

        Raises
        ------
        RecordVersionError
            Its ``record_version`` is not :data:`RECORD_VERSION`.
        ParseError
            It is not a case record (no case_id or status, or keys no record has).
        """
        where = f"case record {source}" if source is not None else "case record"
        if not isinstance(data, Mapping) or "case_id" not in data or "status" not in data:
            raise ParseError(f"{where} is not a case record (no case_id or status)")
        version = data.get("record_version")
        if version != RECORD_VERSION:
            written = ("has no record_version (written before failed cases recorded one)"
                       if version is None else f"is of record version {version}")
            raise RecordVersionError(
                f"{where} {written}; this pidpipe reads record version {RECORD_VERSION}. "
                "Delete the record and run its case again (the workflow remakes a missing record).")
        names = {field.name for field in dataclasses.fields(cls)}
        unknown = [key for key in data if key not in names]
        if unknown:
            raise ParseError(f"{where} has keys no case record of version {RECORD_VERSION} has: "
                             f"{', '.join(unknown)}")
        try:
            return cls(**data)
        except (TypeError, ValueError) as exc:
            raise ParseError(f"{where} is not a valid case record: {exc}") from None

    @classmethod
    def from_json(cls, text: str, source: str | os.PathLike | None = None) -> "CaseRecord":
        """The record of its JSON text (:meth:`from_dict`)."""
        try:
            data = json.loads(text)
        except ValueError as exc:
            raise ParseError(f"case record {source or ''} cannot be read: {exc}") from None
        return cls.from_dict(data, source)

    @classmethod
    def read(cls, path: str | os.PathLike) -> "CaseRecord":
        """Read a record written by :meth:`write`.

        Raises
        ------
        ParseError
            The file cannot be read or is not a case record.
        RecordVersionError
            It is of another record version.
        """
        try:
            text = Path(path).read_text(encoding="utf-8")
        except OSError as exc:
            raise ParseError(f"case record {path} cannot be read: {exc}") from None
        return cls.from_json(text, path)

    def write(self, path: str | os.PathLike) -> Path:
        """Write the record as JSON, atomically and flushed to disk
        (:func:`pidpipe.files.write_atomic`): a reader never sees half a file, and an
        interrupted write leaves no temporary file behind."""
        text = self.to_json()
        return write_atomic(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))
