"""What a run of k cells x n cycles costs, per engine: the cost model the sequential allocation
plans with (:mod:`pidpipe.measurement.allocation`).

A shaking run's CPU time is modelled as

    cpu_s = overhead_s + steps * (per_step_s + per_cell_step_s * k + per_sphere_step_s * k * s
                                  + per_pair_step_s * k * s (s - 1) / 2)

with ``steps`` = (transient + measured cycles) x steps per cycle, ``k`` cells of ``s`` spheres
each. The last term, the sphere pairs of a cell, is the compiled DEM's (it screens every pair
at every step, and fuller cells have more contacts per sphere); LIGGGHTS' model has it 0. LIGGGHTS' cost per step is mostly its mesh-wall fix (``notes/liggghts-3.8.md``), which
grows with the cells' triangles (k) more than with the spheres. A pour costs
``pour_overhead_s + pour_per_sphere_s * s``. The coefficients are fitted to measured runs
(``benchmarks/bench_cells.py --cost``) and stored with the machine, date and command in
``cost_models.json`` next to this module, one entry per engine: ``liggghts``, and ``dem`` for
the compiled DEM (``benchmarks/bench_cells.py --cost --engine dem``; its cost per step is
mostly per sphere, with no mesh). An engine without a stored model is planned with
:func:`scaled_from_pilot`.
"""

from __future__ import annotations

import dataclasses
import datetime
import json
import os
from pathlib import Path

import numpy as np

from pidpipe.errors import ConfigError

COST_MODELS_FILE = Path(__file__).resolve().parent / "cost_models.json"
"""The stored cost models, one entry per engine (``liggghts``, ``dem``)."""

ENGINES = ("liggghts", "dem")
"""Engines with a slot in :data:`COST_MODELS_FILE`."""


@dataclasses.dataclass(frozen=True)
class CostModel:
    """CPU time of a run and of a pour on one engine and machine.

    Attributes
    ----------
    engine : str
    overhead_s : float
        CPU time of a run that does no step (start-up, deck, output), s.
    per_step_s, per_cell_step_s, per_sphere_step_s : float
        CPU time per time step: fixed, per cell, and per sphere, s.
    per_pair_step_s : float
        CPU time per time step and sphere pair of a cell, s (0 in models fitted without it).
    pour_overhead_s, pour_per_sphere_s : float
        CPU time of one pour: fixed and per sphere, s.
    machine, date, command : str
        Where, when and by what the coefficients were measured.
    points : tuple of dict
        The measured runs the model was fitted to (``cells``, ``n_spheres``, ``steps``,
        ``cpu_s``, ...).
    """

    engine: str
    overhead_s: float
    per_step_s: float
    per_cell_step_s: float
    per_sphere_step_s: float
    pour_overhead_s: float
    pour_per_sphere_s: float
    machine: str = ""
    date: str = ""
    command: str = ""
    points: tuple = ()
    per_pair_step_s: float = 0.0

    def run_cpu_s(self, cells: int, n_spheres: int, steps: float) -> float:
        """CPU time of one run of ``cells`` cells of ``n_spheres`` spheres each over ``steps`` steps, s."""
        per_step = self.per_step_s + cells * (self.per_cell_step_s + self.per_sphere_step_s * n_spheres
                                              + self.per_pair_step_s * n_spheres * (n_spheres - 1) / 2)
        return float(self.overhead_s + steps * per_step)

    def pour_cpu_s(self, n_spheres: int) -> float:
        """CPU time of pouring and settling one packing of ``n_spheres`` spheres, s."""
        return float(self.pour_overhead_s + self.pour_per_sphere_s * n_spheres)

    def describe(self) -> str:
        """One line with the coefficients."""
        return (f"{self.engine}: run = {self.overhead_s:.2f} s + steps x ({1e6 * self.per_step_s:.2f} "
                f"+ {1e6 * self.per_cell_step_s:.2f} k + {1e6 * self.per_sphere_step_s:.3f} k s "
                f"+ {1e6 * self.per_pair_step_s:.4f} k s(s-1)/2) us; "
                f"pour = {self.pour_overhead_s:.2f} + {self.pour_per_sphere_s:.3f} s per sphere, s "
                f"({self.machine}; {self.date})")

    def as_record(self) -> dict:
        return dataclasses.asdict(self) | {"points": list(self.points)}


def fit_cost_model(points: list[dict], pours: list[dict], engine: str, machine: str,
                   command: str, pairs: bool = False) -> CostModel:
    """Least-squares fit of the run and pour costs to measurements.

    Parameters
    ----------
    points : list of dict
        Runs: ``cells`` (k), ``n_spheres`` (per cell), ``steps``, ``cpu_s``; at least 4, with
        at least two values of k and of spheres.
    pours : list of dict
        Pours: ``n_spheres``, ``cpu_s``.
    engine, machine, command : str
    pairs : bool
        Fit the per-pair term too (the compiled DEM's; needs at least three sphere counts).

    Returns
    -------
    CostModel
        Dated now (UTC). Coefficients are fitted with non-negative least squares, so that no
        cost term is negative.
    """
    from scipy.optimize import nnls

    k = np.array([p["cells"] for p in points], dtype=float)
    s = np.array([p["n_spheres"] for p in points], dtype=float)
    steps = np.array([p["steps"] for p in points], dtype=float)
    cpu = np.array([p["cpu_s"] for p in points], dtype=float)
    # Relative errors matter (runs span 1-200 s): weight each row by 1 / cpu.
    columns = [np.ones_like(k), steps, steps * k, steps * k * s]
    if pairs:
        columns.append(steps * k * s * (s - 1) / 2)
    coefficients, _ = nnls(np.column_stack(columns) / cpu[:, None], np.ones_like(cpu))
    per_pair = float(coefficients[4]) if pairs else 0.0
    pour_s = np.array([p["n_spheres"] for p in pours], dtype=float)
    pour_cpu = np.array([p["cpu_s"] for p in pours], dtype=float)
    if np.unique(pour_s).size > 1:
        pour_coefficients, _ = nnls(np.column_stack([np.ones_like(pour_s), pour_s]), pour_cpu)
    else:
        pour_coefficients = np.array([float(pour_cpu.mean()), 0.0])
    return CostModel(engine, *map(float, coefficients[:4]), *map(float, pour_coefficients),
                     per_pair_step_s=per_pair, machine=machine,
                     date=datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
                     command=command, points=tuple(points))


def store_cost_model(model: CostModel, path: str | Path = COST_MODELS_FILE) -> Path:
    """Write ``model`` into its engine's slot of the cost-model file (atomically); other engines' entries stay."""
    path = Path(path)
    stored = json.loads(path.read_text(encoding="utf-8")) if path.is_file() else {}
    stored.update({engine: stored.get(engine) for engine in ENGINES})
    stored[model.engine] = model.as_record()
    tmp = path.with_name(f".{path.name}.{os.getpid()}.part")
    tmp.write_text(json.dumps(stored, indent=1) + "\n", encoding="utf-8")
    os.replace(tmp, path)
    return path


def load_cost_model(engine: str, path: str | Path = COST_MODELS_FILE) -> CostModel | None:
    """The stored cost model of ``engine``; None if its slot is empty.

    Raises
    ------
    ConfigError
        ``engine`` is not one of :data:`ENGINES`.
    """
    if engine not in ENGINES:
        raise ConfigError(f"engine {engine!r} has no cost-model slot (engines: {', '.join(ENGINES)})")
    path = Path(path)
    entry = json.loads(path.read_text(encoding="utf-8")).get(engine) if path.is_file() else None
    if entry is None:
        return None
    entry = dict(entry)
    entry["points"] = tuple(entry.get("points", ()))
    return CostModel(**entry)


def scaled_from_pilot(engine: str, pilot_cpu_s: float, cells: int, n_spheres: int,
                      steps: float, pour_cpu_s: float = 0.0) -> CostModel:
    """A cost model for an engine without a stored one: proportional to steps x cells, through the pilot.

    Pessimistic for more cells (a run of k cells costs k times a cell's share of the pilot,
    with no saving from sharing the run), exact for the pilot itself.

    Parameters
    ----------
    pilot_cpu_s : float
        CPU time of the pilot run, s.
    cells, n_spheres, steps
        The pilot's cells, spheres per cell and time steps.
    pour_cpu_s : float
        CPU time of one pour on that engine, s (0 if unknown).
    """
    per_cell_step = pilot_cpu_s / (steps * cells)
    return CostModel(engine, 0.0, 0.0, per_cell_step, 0.0, float(pour_cpu_s), 0.0,
                     machine="scaled from this case's pilot run", date="", command="")
