"""k cells side by side in one LIGGGHTS run (fidelity.cells_per_run): each cell is the packing
shaken alone, its ledger closes, and the case's standard error holds the cells' spread."""

import math

import numpy as np
import pytest

from pidpipe.cases import CaseSpec
from pidpipe.cli import format_result
from pidpipe.config.settings import PourSettings, ShakeSettings
from pidpipe.liggghts.pour import pour
from pidpipe.liggghts.shake import LEDGER_TOLERANCE, run_case
from tests.conftest import short_config

pytestmark = pytest.mark.engine

CASE = CaseSpec(1000, 10, 25)


@pytest.fixture(scope="module")
def quarter_fill_packings(tmp_path_factory):
    """Replicates 0, 1, 2 of the 25 % fill (5 spheres each)."""
    folder = tmp_path_factory.mktemp("pour25")
    return [pour(PourSettings.from_config(short_config()), 25, k, folder / f"rep{k}") for k in range(3)]


@pytest.fixture(scope="module")
def runs(quarter_fill_packings, tmp_path_factory):
    config = short_config(transient=3, measured=12)
    folder = tmp_path_factory.mktemp("cells")
    together = run_case(ShakeSettings.from_config(config), CASE, quarter_fill_packings, folder / "together")
    alone = [run_case(ShakeSettings.from_config(config), CASE, packing, folder / f"alone{k}")
             for k, packing in enumerate(quarter_fill_packings)]
    return together, alone


def test_the_first_cell_is_the_packing_shaken_alone(runs):
    """The first cell sits where a single cell does and cells are apart, so nothing else acts
    on it: the same trajectory. Its ledger differs only by how its wall work is written (the
    cell's own power against the mesh's, 6 digits each)."""
    together, alone = runs
    cell = np.array(together.cells[0]["dissipated_j"])
    single = np.array(alone[0].cycles["dissipated_j"])
    exchanged = np.mean(alone[0].cycles["gross_work_j"])
    assert np.max(np.abs(cell - single)) < 1e-5 * exchanged


def test_moved_cells_are_the_same_physics(runs):
    """Cells moved along x start from positions rounded differently, so their trajectories part
    (chaos), but their C_eq must agree with the same packing shaken alone within their errors."""
    together, alone = runs
    for cell, single in zip(together.cells[1:], alone[1:]):
        combined = math.hypot(cell["ceq_cell_sem_ns_m"], single.ceq_cell_sem_ns_m)
        assert abs(cell["ceq_cell_ns_m"] - single.ceq_cell_ns_m) < 3.0 * combined


def test_the_cells_ledgers_add_up_to_the_mesh(runs):
    together, _ = runs
    assert together.ledger_mismatch_of_gross_work < LEDGER_TOLERANCE
    assert "ledger_mismatch" not in together.flags


def test_the_case_reports_the_mean_cell_with_the_spread_between_cells(runs):
    together, _ = runs
    values = np.array([cell["ceq_cell_ns_m"] for cell in together.cells])
    assert together.ceq_cell_ns_m == pytest.approx(values.mean(), rel=1e-12)
    between = values.std(ddof=1) / math.sqrt(3)
    assert together.ceq_cell_between_cells_sem_ns_m == pytest.approx(between, rel=1e-12)
    assert together.ceq_cell_sem_ns_m == pytest.approx(
        max(between, together.ceq_cell_cycle_sem_ns_m), rel=1e-12)
    assert together.ceq_coupon_sem_ns_m == pytest.approx(441 * together.ceq_cell_sem_ns_m)
    assert together.fidelity["cells_per_run"] == 3
    assert together.fidelity["seeds"] == [cell["seed"] for cell in together.cells]
    assert len(set(together.fidelity["seeds"])) == 3
    assert "3 cells" in format_result(together) and "spread between cells" in format_result(together)


def test_one_cell_reports_no_spread(runs):
    _, alone = runs
    assert math.isnan(alone[0].ceq_cell_between_cells_sem_ns_m)
    assert alone[0].ceq_cell_sem_ns_m == alone[0].ceq_cell_cycle_sem_ns_m
    assert list(alone[0].cells) == []


def test_each_cells_first_harmonic_is_its_own(runs):
    """Each cell's first-harmonic sums (pidpipe.measurement.harmonics): the first cell's, from
    its spheres' forces, are those of the packing shaken alone, from the mesh's force (6 digits
    each)."""
    together, alone = runs
    harmonics = together.harmonics
    assert len(harmonics["cells"]) == 3 and len(harmonics["cos_sums_n_s"]) == 3
    single = alone[0].harmonics
    scale = np.mean(np.hypot(single["cos_sums_n_s"][0], single["sin_sums_n_s"][0]))
    for key in ("cos_sums_n_s", "sin_sums_n_s"):
        difference = np.array(harmonics[key][0]) - np.array(single[key][0])
        assert np.max(np.abs(difference)) < 1e-5 * scale, key
