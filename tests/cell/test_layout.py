"""Several cells per run: which packings a case uses, the layout, the parsing and the statistics."""

import math

import numpy as np
import pytest

from pidpipe.cases import CaseSpec
from pidpipe.cell.geometry import HexCell
from pidpipe.cell.layout import MAX_CELLS, side_by_side
from pidpipe.config import load_config, validate_config
from pidpipe.errors import ConfigError
from pidpipe.liggghts.parsing import read_shake_cycles
from pidpipe.measurement.cells import summarise_cells
from pidpipe.measurement.statistics import summarise_cycles
from pidpipe.steps.params import campaign_packing_ids

CELL = HexCell(4.76e-3, 25.4e-3)


def test_replicates_and_cells_never_share_a_packing():
    ids = [pid for q in range(3) for pid in CaseSpec(500, 5, 50, q).packing_ids(4)]
    assert len(ids) == len(set(ids)) == 12
    assert CaseSpec(500, 5, 50, 1).packing_ids(4) == [f"r50pct_rep{k}" for k in range(4, 8)]
    assert CaseSpec(500, 5, 50, 2).packing_ids(1) == [CaseSpec(500, 5, 50, 2).packing_id]


def test_campaign_pours_every_packing_its_cases_shake():
    config = load_config()
    config["fidelity"]["cells_per_run"] = 3
    config["grid"]["replicates"] = 2
    ids = campaign_packing_ids(config)
    assert len(ids) == len(config["grid"]["fill_pct"]) * 6
    assert "r90pct_rep5" in ids and "r90pct_rep6" not in ids


def test_cells_per_run_is_bounded_by_liggghts_groups():
    config = load_config()
    config["fidelity"]["cells_per_run"] = MAX_CELLS + 1
    with pytest.raises(ConfigError, match="cells_per_run"):
        validate_config(config)
    config["fidelity"]["cells_per_run"] = MAX_CELLS
    validate_config(config)
    with pytest.raises(ValueError, match="1 to 24"):
        side_by_side(CELL, [5] * (MAX_CELLS + 1), 1.25e-3)


def test_cells_are_apart_and_atoms_numbered_cell_by_cell():
    layout = side_by_side(CELL, [5, 3, 4], 1.25e-3)
    gaps = np.diff(layout.offsets_m[:, 0]) - 2.0 * CELL.circumradius_m
    assert np.all(gaps > 0)
    assert layout.first_atom_ids == (1, 6, 9) and layout.last_atom_ids == (5, 8, 12)
    assert layout.cell_of_atom().tolist() == [0] * 5 + [1] * 3 + [2] * 4


def test_the_mean_cell_carries_the_larger_of_the_cycle_and_the_between_cells_error():
    rng = np.random.default_rng(3)
    levels = [1.0e-8, 1.3e-8, 0.8e-8]   # packings far apart: the spread dominates
    cells = [level + 1e-10 * rng.standard_normal(40) for level in levels]
    summary = summarise_cells(cells, 500.0, 5.0, 441, 2)
    per_cell = [summarise_cycles(c, 500.0, 5.0, 441, 2)["ceq_cell_ns_m"] for c in cells]
    between = np.std(per_cell, ddof=1) / math.sqrt(3)
    assert summary["ceq_cell_between_cells_sem_ns_m"] == pytest.approx(between)
    assert summary["ceq_cell_sem_ns_m"] == pytest.approx(between)
    assert summary["ceq_cell_cycle_sem_ns_m"] < 0.1 * between
    assert summary["ceq_coupon_sem_ns_m"] == pytest.approx(441 * between)
    assert summary["ceq_cell_ns_m"] == pytest.approx(np.mean(per_cell))
    assert summary["ed_cycle_sem_j"] / summary["ed_cycle_mean_j"] == pytest.approx(
        summary["ceq_cell_sem_ns_m"] / summary["ceq_cell_ns_m"])
    # the same packing three times: the cycle noise is the larger, and it is kept
    same = [1e-8 + 1e-9 * rng.standard_normal(40) for _ in range(3)]
    summary = summarise_cells([same[0]] * 3, 500.0, 5.0, 441, 2)
    assert summary["ceq_cell_sem_ns_m"] == summary["ceq_cell_cycle_sem_ns_m"] > 0


def _write_ave_time(path, rows):
    path.write_text("# header\n# header\n" + "".join(" ".join(repr(float(v)) for v in row) + "\n"
                                                      for row in rows))


def test_each_cell_balance_and_the_mesh_total(tmp_path):
    """Power file: step, mesh power, |mesh power|; cell power file: step (from 0, as LIGGGHTS
    writes it), then each cell's power; energy file: 5 columns per cell at every boundary from
    step 0."""
    period, cycles = 0.002, 3
    cell_power = np.array([[1.0, 2.0], [1.5, 2.5], [0.5, 1.0]]) * 1e-6      # W per cell
    _write_ave_time(tmp_path / "power.txt",
                    [[100 * (k + 1), cell_power[k].sum(), 9e-6] for k in range(cycles)])
    _write_ave_time(tmp_path / "cell_power.txt",
                    [[0, 0.0, 0.0]] + [[100 * (k + 1), *cell_power[k]] for k in range(cycles)])
    energies = [[100 * k, 1e-9 * k, 0.0, 0.0, -0.01, 0.0, 2e-9 * k, 0.0, 0.0, -0.01, 0.0]
                for k in range(cycles + 1)]
    _write_ave_time(tmp_path / "energy.txt", energies)
    cells, mesh = read_shake_cycles(tmp_path / "power.txt", tmp_path / "energy.txt", period,
                                    cycles, 2, cell_power_path=tmp_path / "cell_power.txt")
    np.testing.assert_allclose(cells[0].dissipated_j, cell_power[:, 0] * period - 1e-9, atol=1e-20)
    np.testing.assert_allclose(cells[1].dissipated_j, cell_power[:, 1] * period - 2e-9, atol=1e-20)
    np.testing.assert_allclose(mesh.dissipated_j, cells[0].dissipated_j + cells[1].dissipated_j, atol=1e-20)
    np.testing.assert_allclose(mesh.gross_work_j, 9e-6 * period)
    assert np.all(np.isnan(cells[0].gross_work_j))
