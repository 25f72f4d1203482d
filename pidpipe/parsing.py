"""Reading LIGGGHTS' per-cycle energy output and closing the energy balance.

The shake deck writes two ``fix ave/time`` files, one row per cycle of the base motion:

- the power file: the mean over the cycle of the power the walls put into the spheres, and of
  its absolute value (so mean * period is the work per cycle, and the gross work exchanged);
- the energy file: at the end of each cycle the spheres' translational and rotational kinetic
  energy and gravitational potential energy, and the lowest and highest sphere centre.

The energy dissipated in cycle k is the balance E_d,k = W_k - (E_k - E_{k-1}).
"""

from __future__ import annotations

from dataclasses import dataclass
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
        Total mechanical energy (kinetic + rotational + potential) at cycle boundaries, J.
    dissipated_j : ndarray, shape (n,)
        Dissipated energy per cycle by the balance, J.
    lowest_z_m, highest_z_m : ndarray, shape (n,)
        Lowest and highest sphere centre at the end of each cycle, m.
    """

    wall_work_j: np.ndarray
    gross_work_j: np.ndarray
    energy_j: np.ndarray
    dissipated_j: np.ndarray
    lowest_z_m: np.ndarray
    highest_z_m: np.ndarray

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
                expected_cycles: int) -> CycleSeries:
    """Per-cycle balance from the shake deck's two output files.

    Parameters
    ----------
    power_path, energy_path : path
        The ``fix ave/time`` outputs of the shake deck.
    period_s : float
        Period of the base motion, s.
    expected_cycles : int
        Cycles the deck ran; fewer rows means truncated output. The energy file has one row
        more: the state at step 0.
    """
    power = read_ave_time(power_path, 3)
    energy = read_ave_time(energy_path, 6)
    for name, path, table, rows in (("power", power_path, power, expected_cycles),
                                    ("energy", energy_path, energy, expected_cycles + 1)):
        if len(table) != rows:
            raise ParseError(f"{path} has {len(table)} rows, expected {rows} for {expected_cycles} "
                             "cycles (truncated run?)")
    if energy[0, 0] != 0 or not np.array_equal(power[:, 0], energy[1:, 0]):
        raise ParseError(f"the cycle ends of {power_path} and {energy_path} differ")
    work = power[:, 1] * period_s
    gross = power[:, 2] * period_s
    mechanical = energy[:, 1:4].sum(axis=1)
    return CycleSeries(wall_work_j=work, gross_work_j=gross, energy_j=mechanical,
                       dissipated_j=work - np.diff(mechanical), lowest_z_m=energy[1:, 4],
                       highest_z_m=energy[1:, 5])
