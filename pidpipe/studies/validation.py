"""Validation of single-cell LIGGGHTS results against the independent in-repo DEM (compiled with Numba).

Both solvers shake the same packing with the same settings (materials, pairs, fidelity, cycles);
per case the table gives E_d per cycle and the cell's C_eq from each, with their standard
errors (block means over the measured cycles), the ratio DEM / LIGGGHTS with its
uncertainty, and whether the two agree within the combined uncertainty (difference no larger
than ``coverage`` times the root-sum-square of the two standard errors; 2 by default). Each
solver discards its own run's transient by the same rule (the configured count, or more if MSER
detects a longer one, :func:`pidpipe.measurement.steady_state.assess_steady_state`); the table says how
many cycles each discarded and which steady-state checks each run failed.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from pidpipe.cases import CaseSpec
from pidpipe.cell.packing import Packing
from pidpipe.config.settings import ShakeSettings
from pidpipe.measurement.case_record import CaseRecord

#: Columns of the comparison table, in order.
TABLE_COLUMNS: tuple[str, ...] = (
    "case_id", "freq_hz", "accel_g", "fill_pct", "n_spheres",
    "ed_liggghts_j", "ed_liggghts_sem_j", "ed_dem_j", "ed_dem_sem_j",
    "ceq_cell_liggghts_ns_m", "ceq_cell_liggghts_sem_ns_m",
    "ceq_cell_dem_ns_m", "ceq_cell_dem_sem_ns_m",
    "ratio_dem_over_liggghts", "ratio_sem", "difference_over_combined_sem", "agree",
    "dem_balance_mismatch_fraction", "liggghts_wall_time_s", "dem_wall_time_s",
    "liggghts_transient_cycles", "dem_transient_cycles", "liggghts_flags", "dem_flags",
)


def compare_records(liggghts: CaseRecord, dem: dict, coverage: float = 2.0) -> dict:
    """One row of the comparison table from the two solvers' records of the same case.

    Parameters
    ----------
    liggghts : CaseRecord
        Record of :func:`pidpipe.liggghts.shake.run_case`.
    dem : dict
        Record of :func:`pidpipe.dem.simulate_cell` (one cell; not a case record).
    coverage : float
        Agreement when |E_d,dem - E_d,liggghts| <= coverage * sqrt(sem_l^2 + sem_d^2).

    Returns
    -------
    dict
        The :data:`TABLE_COLUMNS` of the case.
    """
    ed_l, sem_l = float(liggghts.ed_cycle_mean_j), float(liggghts.ed_cycle_sem_j)
    ed_d, sem_d = float(dem["ed_cycle_mean_j"]), float(dem["ed_cycle_sem_j"])
    combined = math.hypot(sem_l, sem_d)
    ratio = ed_d / ed_l if ed_l != 0 else float("nan")
    ratio_sem = abs(ratio) * math.hypot(sem_l / ed_l, sem_d / ed_d) if ed_l and ed_d \
        else float("nan")
    z = (ed_d - ed_l) / combined if combined > 0 else float("nan")
    return {
        "case_id": liggghts.case_id,
        "freq_hz": float(liggghts.freq_hz),
        "accel_g": float(liggghts.accel_g),
        "fill_pct": float(liggghts.fill_pct),
        "n_spheres": int(dem["n_spheres"]),
        "ed_liggghts_j": ed_l, "ed_liggghts_sem_j": sem_l,
        "ed_dem_j": ed_d, "ed_dem_sem_j": sem_d,
        "ceq_cell_liggghts_ns_m": float(liggghts.ceq_cell_ns_m),
        "ceq_cell_liggghts_sem_ns_m": float(liggghts.ceq_cell_sem_ns_m),
        "ceq_cell_dem_ns_m": float(dem["ceq_cell_ns_m"]),
        "ceq_cell_dem_sem_ns_m": float(dem["ceq_cell_sem_ns_m"]),
        "ratio_dem_over_liggghts": ratio,
        "ratio_sem": ratio_sem,
        "difference_over_combined_sem": z,
        "agree": bool(np.isfinite(z) and abs(z) <= coverage),
        "dem_balance_mismatch_fraction": float(dem.get("balance_mismatch_fraction", float("nan"))),
        "liggghts_wall_time_s": float(liggghts.wall_time_s),
        "dem_wall_time_s": float(dem.get("wall_time_s", float("nan"))),
        "liggghts_transient_cycles": int(liggghts.fidelity.get("transient_cycles", -1)),
        "dem_transient_cycles": transient_cycles(dem),
        "liggghts_flags": ";".join(liggghts.flags),
        "dem_flags": ";".join(dem.get("flags", [])),
    }


def transient_cycles(record: dict) -> int:
    """Cycles a :func:`pidpipe.dem.simulate_cell` record discarded before its measured window
    (-1 if not recorded)."""
    return int(record.get("fidelity", {}).get("transient_cycles", -1))


def validate_case(settings: ShakeSettings, case: CaseSpec, packing: Packing, workdir: str | Path,
                  coverage: float = 2.0) -> tuple[dict, CaseRecord, dict]:
    """Shake one case with both solvers from the same settings and packing.

    Returns
    -------
    row : dict
        :func:`compare_records` of the two records.
    liggghts_record : CaseRecord
    dem_record : dict
    """
    from pidpipe.cell.scene import CellScene
    from pidpipe.dem import simulate_cell
    from pidpipe.dem.from_scene import dem_scene
    from pidpipe.liggghts.shake import run_case

    sampling = settings.sampling
    liggghts_record = run_case(settings, case, packing, Path(workdir) / case.case_id)
    (dem_record,) = simulate_cell(
        dem_scene(CellScene.of(settings), case.freq_hz, case.accel_g), packing.centres(),
        transient_cycles=sampling.transient_cycles_at(case.freq_hz),
        measured_cycles=sampling.measured_cycles, block_cycles=sampling.sem_block_cycles,
        n_cells=settings.coupon_n_cells, seed=packing.seed)
    dem_record["case_id"] = case.case_id
    dem_record["fill_pct"] = case.fill_pct
    return compare_records(liggghts_record, dem_record, coverage), liggghts_record, dem_record


def comparison_table(rows: list[dict]) -> pd.DataFrame:
    """The rows as a table with :data:`TABLE_COLUMNS`."""
    return pd.DataFrame(rows, columns=list(TABLE_COLUMNS))


def write_table(rows: list[dict], path: str | Path) -> Path:
    """Write the comparison table as CSV (atomically)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".part")
    comparison_table(rows).to_csv(tmp, index=False)
    tmp.replace(path)
    return path


def plot_comparison(rows: list[dict], path: str | Path) -> Path:
    """C_eq per cell of each case from both solvers, with 2-sigma error bars (PNG/PDF/SVG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    table = comparison_table(rows)
    x = np.arange(len(table))
    fig, ax = plt.subplots(figsize=(max(5.0, 0.9 * len(table) + 3.0), 3.8))
    ax.errorbar(x - 0.1, table["ceq_cell_liggghts_ns_m"], yerr=2 * table["ceq_cell_liggghts_sem_ns_m"],
                fmt="o", capsize=3, label="LIGGGHTS 3.8")
    ax.errorbar(x + 0.1, table["ceq_cell_dem_ns_m"], yerr=2 * table["ceq_cell_dem_sem_ns_m"],
                fmt="s", capsize=3, label="in-repo DEM (Numba)")
    ax.set_xticks(x, table["case_id"], rotation=30, ha="right")
    ax.set_ylabel("C_eq per cell (N s/m), ±2 SEM")
    ax.set_yscale("log")
    ax.set_title("Single cell: LIGGGHTS vs the in-repo DEM", fontsize="medium")
    ax.legend()
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path)
    plt.close(fig)
    return path


def run_validation(settings: ShakeSettings, cases: list[CaseSpec], packings: dict[str, Packing],
                   outdir: str | Path, coverage: float = 2.0) -> pd.DataFrame:
    """Validate several cases; writes ``validation.csv`` and ``validation.png`` in ``outdir``.

    Parameters
    ----------
    settings : ShakeSettings
    cases : list of CaseSpec
    packings : dict
        Packing of each case, keyed by :attr:`CaseSpec.packing_id`.
    outdir : path
    coverage : float
        See :func:`compare_records`.
    """
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    rows = [validate_case(settings, case, packings[case.packing_id], outdir / "runs", coverage)[0]
            for case in cases]
    write_table(rows, outdir / "validation.csv")
    plot_comparison(rows, outdir / "validation.png")
    return comparison_table(rows)
