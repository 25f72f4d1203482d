"""Reading LIGGGHTS' per-cycle energy output and closing the energy balance.

The shake deck writes two ``fix ave/time`` files, one row per cycle of the base motion:

- the power file: the mean over the cycle of the power the walls put into the spheres, and of
  its absolute value (so mean * period is the work per cycle, and the gross work exchanged);
- the energy file: at the end of each cycle the spheres' translational and rotational kinetic
  energy and gravitational potential energy (measured from the packing's starting centre of
  mass in the shake deck, from the floor in the patch deck), and the lowest and highest sphere
  centre.

With several cells in one run (:mod:`pidpipe.replicate_cells`) the energy file has these five
columns for each cell in turn, and a third file, the cell power file, has each cell's mean
power over each cycle (:func:`read_shake_cycles`).

The harmonics file holds the cycle means of the spheres' z force on the mesh times the cosine
of the walls' phase; with several cells, the cell harmonics file has that of each cell
(:func:`read_cos_sums`, :mod:`pidpipe.measurement.harmonics`).

The shake deck also dumps every particle-particle and particle-wall contact at the same cycle
boundaries (``dump local``, :data:`CONTACT_COLUMNS`): the overlap and the tangential spring of
each, from which :mod:`pidpipe.liggghts.contact_energy` computes the elastic energy held in the contacts.

The energy dissipated in cycle k is the balance E_d,k = W_k - (E_k - E_{k-1}), E the kinetic,
rotational, potential and (where measured) elastic energy at the boundaries.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from pidpipe.errors import ParseError


@dataclass(frozen=True)
class CycleSeries:
    """Per-cycle energy bookkeeping of one run (all cycles, transient included).

    Attributes
    ----------
    wall_work_j : ndarray, shape (n,)
        Work done by the walls on the spheres in each cycle, J.
    gross_work_j : ndarray, shape (n,)
        Integral of |power| over each cycle: the work the walls exchange with the spheres, J.
    energy_j : ndarray, shape (n + 1,)
        Energy at cycle boundaries, J: ``mechanical_j + elastic_j``, or ``mechanical_j`` alone
        where the elastic energy was not measured.
    dissipated_j : ndarray, shape (n,)
        Dissipated energy per cycle by the balance, ``wall_work_j - diff(energy_j)``, J.
    lowest_z_m, highest_z_m : ndarray, shape (n,)
        Lowest and highest sphere centre at the end of each cycle, m.
    mechanical_j : ndarray, shape (n + 1,)
        Kinetic + rotational + gravitational potential energy at cycle boundaries, J (the
        potential's zero is the deck's reference height). Defaults to ``energy_j``.
    elastic_j : ndarray, shape (n + 1,)
        Elastic energy held in the contacts at cycle boundaries, J; NaN where not measured
        (the default).
    """

    wall_work_j: np.ndarray
    gross_work_j: np.ndarray
    energy_j: np.ndarray
    dissipated_j: np.ndarray
    lowest_z_m: np.ndarray
    highest_z_m: np.ndarray
    mechanical_j: np.ndarray | None = None
    elastic_j: np.ndarray | None = None

    def __post_init__(self):
        if self.mechanical_j is None:
            object.__setattr__(self, "mechanical_j", np.asarray(self.energy_j, dtype=float))
        if self.elastic_j is None:
            object.__setattr__(self, "elastic_j", np.full(np.shape(self.energy_j), np.nan))

    def as_record(self) -> dict:
        """Lists of floats, for JSON."""
        return {name: getattr(self, name).tolist() for name in self.__dataclass_fields__}


def read_ave_time(path: str | Path, n_columns: int) -> np.ndarray:
    """Rows of a LIGGGHTS ``fix ave/time`` file (step first), shape (n_rows, n_columns).

    Raises
    ------
    ParseError
        If the file is missing, empty, malformed, or holds a non-finite value.
    """
    path = Path(path)
    if not path.is_file():
        raise ParseError(f"LIGGGHTS output {path} is missing (did the run finish?)")
    rows = []
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        fields = line.split()
        if len(fields) != n_columns:
            raise ParseError(f"{path}:{number} has {len(fields)} fields, expected {n_columns} "
                             "(truncated or corrupted output)")
        try:
            rows.append([float(field) for field in fields])
        except ValueError:
            raise ParseError(f"{path}:{number} holds a value that is not a number: {line.strip()!r}") from None
    table = np.array(rows, dtype=float).reshape(-1, n_columns)
    if table.size and not np.all(np.isfinite(table)):
        bad = int(np.argwhere(~np.isfinite(table))[0, 0])
        raise ParseError(f"{path} holds a non-finite value (NaN or inf) at data row {bad + 1}: "
                         "the run went unstable (timestep too large?)")
    return table


def read_cycles(power_path: str | Path, energy_path: str | Path, period_s: float,
                expected_cycles: int, elastic_j: np.ndarray | None = None) -> CycleSeries:
    """Per-cycle balance of all spheres from the mesh ledger (the patch deck's two files).

    Parameters
    ----------
    power_path, energy_path : path
        The ``fix ave/time`` outputs of the deck.
    period_s : float
        Period of the base motion, s.
    expected_cycles : int
        Cycles the deck ran; fewer rows means truncated output. The energy file has one row
        more: the state at step 0.
    elastic_j : ndarray, shape (expected_cycles + 1,), optional
        Elastic energy held in the contacts at each cycle boundary, from step 0, J
        (:func:`pidpipe.liggghts.contact_energy.boundary_elastic_energy`). Without it the balance leaves
        out the elastic energy (NaN in ``elastic_j``).
    """
    power, energy = _read_cycle_tables(power_path, energy_path, expected_cycles, 1)
    return _cycle_series(power[:, 1] * period_s, power[:, 2] * period_s, energy[:, 1:6], elastic_j)


def without_step_zero(table: np.ndarray) -> np.ndarray:
    """``table`` without its first row if that row is step 0.

    A ``fix ave/time`` with Nevery = Nfreq (values sampled only where they are written, as
    the shake deck's per-cell sums of per-sphere averages are) also writes a row at step 0,
    before anything was averaged; the files written every step start at the first cycle end.
    """
    return table[1:] if len(table) and table[0, 0] == 0 else table


def read_shake_cycles(power_path: str | Path, energy_path: str | Path, period_s: float,
                      expected_cycles: int, n_cells: int,
                      elastic_j: np.ndarray | None = None,
                      cell_power_path: str | Path | None = None) -> tuple[list[CycleSeries], CycleSeries]:
    """Per-cycle balance of each cell of a shake deck, and of all of them from the mesh's force.

    Parameters
    ----------
    power_path : path
        The power file: step, the mesh's power and |power| over all cells.
    energy_path : path
        Each cell's energies at the cycle boundaries (step, then 5 columns cell by cell).
    period_s, expected_cycles
        As :func:`read_cycles`.
    n_cells : int
    elastic_j : ndarray, shape (expected_cycles + 1, n_cells), optional
        Elastic energy held in each cell's contacts at each cycle boundary, J.
    cell_power_path : path, optional
        With several cells (then required): step, then each cell's mean power over the cycle.

    Returns
    -------
    cells : list of CycleSeries
        One per cell. With one cell, the mesh's; with several, each cell's gross work
        exchanged is not measured (NaN).
    mesh : CycleSeries
        All cells together, the wall work and gross work from the mesh's force; with several
        cells the sum of the cells' work must match its work.

    Raises
    ------
    ParseError
        Missing, truncated or inconsistent output.
    """
    power, energy = _read_cycle_tables(power_path, energy_path, expected_cycles, n_cells)
    if n_cells > 1:
        if cell_power_path is None:
            raise ValueError("several cells need their cell power file")
        cell_power = without_step_zero(read_ave_time(cell_power_path, 1 + n_cells))
        if not np.array_equal(cell_power[:, 0], power[:, 0]):
            raise ParseError(f"the cycle ends of {cell_power_path} and {power_path} differ "
                             f"({len(cell_power)} and {len(power)} rows; truncated run?)")
    if elastic_j is not None:
        elastic_j = np.asarray(elastic_j, dtype=float).reshape(len(energy), n_cells)
    mesh_work, mesh_gross = power[:, 1] * period_s, power[:, 2] * period_s
    cells = []
    for index in range(n_cells):
        work, gross = ((mesh_work, mesh_gross) if n_cells == 1
                       else (cell_power[:, 1 + index] * period_s, np.full(len(power), np.nan)))
        cells.append(_cycle_series(work, gross, energy[:, 1 + 5 * index:6 + 5 * index],
                                   None if elastic_j is None else elastic_j[:, index]))
    if n_cells == 1:
        return cells, cells[0]
    total = sum_cycle_series(cells)
    mesh = replace(total, wall_work_j=mesh_work, gross_work_j=mesh_gross,
                   dissipated_j=mesh_work - np.diff(total.energy_j))
    return cells, mesh


def read_cos_sums(harmonics_path: str | Path, cell_harmonics_path: str | Path, period_s: float,
                  expected_cycles: int, n_cells: int) -> np.ndarray:
    """Each cell's S_c, the sum over each cycle of its spheres' z force on the walls times the
    cosine of the walls' phase (:mod:`pidpipe.measurement.harmonics`): the cycle mean the deck
    wrote times the period.

    Parameters
    ----------
    harmonics_path : path
        One cell: the harmonics file (step, the mesh's mean of F cos).
    cell_harmonics_path : path
        Several cells: the cell harmonics file (step, each cell's mean of F cos; a row at
        step 0 is dropped).
    period_s : float
        Period of the base motion, s.
    expected_cycles, n_cells : int

    Returns
    -------
    ndarray, shape (n_cells, expected_cycles)
        N s.

    Raises
    ------
    ParseError
        Missing or truncated output.
    """
    path = harmonics_path if n_cells == 1 else cell_harmonics_path
    table = without_step_zero(read_ave_time(path, 1 + n_cells))
    if len(table) != expected_cycles:
        raise ParseError(f"{path} has {len(table)} rows, expected {expected_cycles} "
                         "(truncated run?)")
    return table[:, 1:].T * period_s


def _read_cycle_tables(power_path: str | Path, energy_path: str | Path, expected_cycles: int,
                       n_cells: int) -> tuple[np.ndarray, np.ndarray]:
    """The power file (step, power, |power|, ...) and the energy file (step, 5 columns per
    cell), checked for length and matching steps."""
    power = read_ave_time(power_path, 3)
    energy = read_ave_time(energy_path, 1 + 5 * n_cells)
    for path, table, rows in ((power_path, power, expected_cycles),
                              (energy_path, energy, expected_cycles + 1)):
        if len(table) != rows:
            raise ParseError(f"{path} has {len(table)} rows, expected {rows} for {expected_cycles} "
                             "cycles (truncated run?)")
    if energy[0, 0] != 0 or not np.array_equal(power[:, 0], energy[1:, 0]):
        raise ParseError(f"the cycle ends of {power_path} and {energy_path} differ")
    return power, energy


def _cycle_series(work_j: np.ndarray, gross_j: np.ndarray, energy_columns: np.ndarray,
                  elastic_j: np.ndarray | None) -> CycleSeries:
    """The balance of one set of spheres from its work per cycle and its energy columns
    (translational, rotational, potential, lowest, highest) at the cycle boundaries."""
    mechanical = energy_columns[:, 0:3].sum(axis=1)
    total = mechanical
    if elastic_j is not None:
        elastic_j = np.asarray(elastic_j, dtype=float)
        if elastic_j.shape != mechanical.shape:
            raise ParseError(f"{elastic_j.size} elastic energies for {mechanical.size} cycle boundaries")
        total = mechanical + elastic_j
    return CycleSeries(wall_work_j=work_j, gross_work_j=gross_j, energy_j=total,
                       dissipated_j=work_j - np.diff(total), lowest_z_m=energy_columns[1:, 3],
                       highest_z_m=energy_columns[1:, 4], mechanical_j=mechanical,
                       elastic_j=elastic_j)


def sum_cycle_series(cells: list[CycleSeries]) -> CycleSeries:
    """The series of several cells together: energies and works summed cycle by cycle, the
    lowest and highest sphere over all cells."""
    def total(name):
        return np.sum([getattr(series, name) for series in cells], axis=0)

    return CycleSeries(wall_work_j=total("wall_work_j"), gross_work_j=total("gross_work_j"),
                       energy_j=total("energy_j"), dissipated_j=total("dissipated_j"),
                       lowest_z_m=np.min([s.lowest_z_m for s in cells], axis=0),
                       highest_z_m=np.max([s.highest_z_m for s in cells], axis=0),
                       mechanical_j=total("mechanical_j"), elastic_j=total("elastic_j"))


CONTACT_COLUMNS = ("id_a", "id_b", "id_c", "shear_x", "shear_y", "shear_z", "overlap")
"""Columns of the shake deck's contact dumps (``compute pair/gran/local`` and
``wall/gran/local`` with ``id history delta``), in the order LIGGGHTS 3.8 writes them whatever
the order of the keywords (measured): three ids (particle-particle: the two atom ids and a
periodic flag; particle-wall: the mesh, the triangle and the atom id), the tangential history
of ``tangential history`` (the stored tangential displacement, m) and the overlap, m."""


def read_local_frames(path: str | Path, n_columns: int) -> tuple[np.ndarray, list[np.ndarray]]:
    """Every frame of a LIGGGHTS ``dump local`` file.

    Returns
    -------
    steps : ndarray of int, shape (n_frames,)
    frames : list of ndarray, each of shape (n_entries, n_columns)
        The entries of each frame (a frame may hold none).

    Raises
    ------
    ParseError
        If the file is missing or holds no frame, a frame's header is malformed, a frame is
        truncated or holds rows of another width, a value is not a finite number, or the steps
        do not increase.
    """
    path = Path(path)
    if not path.is_file():
        raise ParseError(f"LIGGGHTS output {path} is missing (did the run finish?)")
    lines = path.read_text(encoding="utf-8").splitlines()
    steps, frames = [], []
    at = 0
    while at < len(lines):
        if not lines[at].strip():
            at += 1
            continue
        header = lines[at:at + 9]
        if (len(header) < 9 or header[0].strip() != "ITEM: TIMESTEP"
                or header[2].strip() != "ITEM: NUMBER OF ENTRIES"
                or not header[4].startswith("ITEM: BOX BOUNDS")
                or not header[8].startswith("ITEM: ENTRIES")):
            raise ParseError(f"{path}:{at + 1}: frame {len(frames)} has a malformed or truncated "
                             "header")
        try:
            step, n_entries = int(header[1]), int(header[3])
        except ValueError:
            raise ParseError(f"{path}:{at + 2}: frame {len(frames)} has a malformed step or "
                             "entry count") from None
        if n_entries < 0:
            raise ParseError(f"{path}:{at + 4}: frame {len(frames)} has {n_entries} entries")
        body = lines[at + 9:at + 9 + n_entries]
        rows = [line.split() for line in body]
        if len(body) != n_entries or any(len(row) != n_columns for row in rows):
            raise ParseError(f"{path}: frame {len(frames)} (step {step}) does not hold {n_entries} rows "
                             f"of {n_columns} columns (truncated or corrupted output)")
        try:
            table = np.array(rows, dtype=float).reshape(n_entries, n_columns)
        except ValueError:
            raise ParseError(f"{path}: frame {len(frames)} (step {step}) holds a value that is not "
                             "a number") from None
        if not np.all(np.isfinite(table)):
            raise ParseError(f"{path}: frame {len(frames)} (step {step}) holds a non-finite value: "
                             "the run went unstable")
        if steps and step <= steps[-1]:
            raise ParseError(f"{path}: frame {len(frames)} is at step {step}, after step {steps[-1]}")
        steps.append(step)
        frames.append(table)
        at += 9 + n_entries
    if not frames:
        raise ParseError(f"{path} holds no frame")
    return np.array(steps, dtype=np.int64), frames


SPHERE_COLUMNS = ("id", "x", "y", "z", "vx", "vy", "vz", "omegax", "omegay", "omegaz", "radius",
                  "mass", "cycle_power")
"""Columns of the per-sphere dump of the patch deck (templates/patch.lmp.j2), in order: SI units;
``cycle_power`` is the sphere's share of the wall power averaged over the cycle that ends at the
frame, W (0 in the frame of step 0)."""
ROTATIONAL_INERTIA_FACTOR = 0.4
"""I = 0.4 m r^2, the solid sphere (as LIGGGHTS' compute erotate/sphere)."""


def read_dump_frames(path: str | Path, n_columns: int) -> tuple[np.ndarray, np.ndarray]:
    """Every frame of a LIGGGHTS ``dump custom`` file sorted by id (``dump_modify sort id``).

    Returns
    -------
    steps : ndarray of int, shape (n_frames,)
    frames : ndarray, shape (n_frames, n_atoms, n_columns)

    Raises
    ------
    ParseError
        If the file is missing or empty, a frame is truncated, the atom count or order changes
        between frames, or a value is not finite.
    """
    path = Path(path)
    if not path.is_file():
        raise ParseError(f"LIGGGHTS output {path} is missing (did the run finish?)")
    lines = path.read_text(encoding="utf-8").splitlines()
    starts = [i for i, line in enumerate(lines) if line.startswith("ITEM: TIMESTEP")]
    if not starts:
        raise ParseError(f"{path} holds no frame")
    steps, frames = [], []
    for number, start in enumerate(starts):
        try:
            steps.append(int(lines[start + 1]))
            n_atoms = int(lines[start + 3])
            body = lines[start + 9: start + 9 + n_atoms]
            table = np.array(" ".join(body).split(), dtype=float)
        except (IndexError, ValueError):
            raise ParseError(f"{path}: frame {number} is malformed or truncated") from None
        if not lines[start + 8].startswith("ITEM: ATOMS") or table.size != n_atoms * n_columns:
            raise ParseError(f"{path}: frame {number} (step {steps[-1]}) does not hold {n_atoms} "
                             f"rows of {n_columns} columns (truncated run?)")
        frames.append(table.reshape(n_atoms, n_columns))
    if len({frame.shape for frame in frames}) != 1:
        raise ParseError(f"{path}: the number of atoms changes between frames (atoms lost?)")
    frames = np.stack(frames)
    if not np.all(frames[:, :, 0] == frames[0, :, 0]):
        raise ParseError(f"{path}: the atoms are not in the same order in every frame (sort id?)")
    if not np.all(np.isfinite(frames)):
        raise ParseError(f"{path} holds a non-finite value: the run went unstable")
    return np.array(steps), frames


def cell_cycles(steps: np.ndarray, frames: np.ndarray, cell_index: np.ndarray, period_s: float,
                expected_cycles: int, gravity_m_s2: float, floor_z_m: float) -> list[CycleSeries]:
    """Per-cell energy balance from the patch deck's per-sphere dump (:func:`read_dump_frames`).

    For cell c and cycle k, the wall work is the period times the sum over the cell's spheres
    of their mean wall power over the cycle; the mechanical energy at cycle ends is the sum of
    1/2 m v^2, 1/2 (0.4 m r^2) omega^2 and m g (z - floor_z_m) over the cell's spheres.

    Parameters
    ----------
    steps : ndarray of int, shape (n_frames,)
    frames : ndarray, shape (n_frames, n_atoms, len(SPHERE_COLUMNS))
        The per-sphere dump: one frame per cycle end, from step 0.
    cell_index : ndarray of int, shape (n_atoms,)
        The cell of each atom, in atom-id order.
    period_s : float
        Period of the base motion, s.
    expected_cycles : int
        Cycles the deck ran (the dump holds one frame more).
    gravity_m_s2, floor_z_m : float
        Gravity and the potential energy's reference height (the floor at rest), as in the
        deck's whole-patch bookkeeping.

    Returns
    -------
    list of CycleSeries, one per cell
        ``gross_work_j`` is NaN: the gross work exchanged is a whole-mesh quantity.
    """
    cell_index = np.asarray(cell_index, dtype=np.int64)
    if len(steps) != expected_cycles + 1 or steps[0] != 0:
        raise ParseError(f"the sphere dump has {len(steps)} frames from step {steps[0]}, expected "
                         f"{expected_cycles + 1} from step 0 (truncated run?)")
    if frames.shape[1] != cell_index.size or frames.shape[2] != len(SPHERE_COLUMNS):
        raise ParseError(f"the sphere dump holds {frames.shape[1]} spheres x {frames.shape[2]} "
                         f"columns, expected {cell_index.size} x {len(SPHERE_COLUMNS)}")
    col = {name: k for k, name in enumerate(SPHERE_COLUMNS)}
    mass, radius = frames[:, :, col["mass"]], frames[:, :, col["radius"]]
    speed2 = np.sum(frames[:, :, col["vx"]:col["vz"] + 1] ** 2, axis=2)
    spin2 = np.sum(frames[:, :, col["omegax"]:col["omegaz"] + 1] ** 2, axis=2)
    sphere_energy = (0.5 * mass * speed2 + 0.5 * ROTATIONAL_INERTIA_FACTOR * mass * radius**2 * spin2
                     + gravity_m_s2 * mass * (frames[:, :, col["z"]] - floor_z_m))
    sphere_work = frames[1:, :, col["cycle_power"]] * period_s
    n_cells = int(cell_index.max()) + 1
    series = []
    for cell in range(n_cells):
        mine = cell_index == cell
        energy = sphere_energy[:, mine].sum(axis=1)
        work = sphere_work[:, mine].sum(axis=1)
        z = frames[1:, mine, col["z"]]
        series.append(CycleSeries(wall_work_j=work, gross_work_j=np.full(work.shape, np.nan),
                                  energy_j=energy, dissipated_j=work - np.diff(energy),
                                  lowest_z_m=z.min(axis=1), highest_z_m=z.max(axis=1)))
    return series


def read_dump_atoms(path: str | Path) -> np.ndarray:
    """The last frame of a LIGGGHTS ``dump custom`` file, sorted by id; shape (n_atoms, n_columns)."""
    path = Path(path)
    if not path.is_file():
        raise ParseError(f"LIGGGHTS output {path} is missing")
    lines = path.read_text(encoding="utf-8").splitlines()
    starts = [i for i, line in enumerate(lines) if line.startswith("ITEM: ATOMS")]
    if not starts:
        raise ParseError(f"{path} holds no ITEM: ATOMS frame")
    first = starts[-1]
    rows = [line.split() for line in lines[first + 1:] if line.strip()]
    try:
        table = np.array(rows, dtype=float)
    except ValueError:
        raise ParseError(f"{path} has a malformed atom row") from None
    if table.ndim != 2 or not np.all(np.isfinite(table)):
        raise ParseError(f"{path} holds non-finite or ragged atom data")
    return table[np.argsort(table[:, 0])]
