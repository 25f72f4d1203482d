"""The m_eff surrogate step (rule fit_m_eff_surrogate): a GP on a linear target, saved and read
back, and its maps."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pandas as pd
import pytest

from pidpipe.design.surrogate import load_surrogate
from pidpipe.errors import TableError
from pidpipe.steps.design import fit_m_eff_surrogate
from pidpipe.steps.params import (M_EFF_FIGURES, M_EFF_SURROGATE, m_eff_figure_paths,
                                  m_eff_surrogate_paths)
from pidpipe.config.sections import Optimisation
from pidpipe.config import REPO_ROOT as REPO

SPHERE_KG = 9.65e-6          # an acrylic sphere of radius 1.25 mm
FULL_CELL = 44


def bed_mass(fill_pct):
    return np.round(np.asarray(fill_pct) * FULL_CELL / 100.0) * SPHERE_KG


def lifting_ratio(accel_g):
    """m_eff / bed mass of a bed resting below 1 g and airborne above (smooth step in ln G)."""
    return 0.5 * (1.0 - np.tanh(3.0 * np.log(np.asarray(accel_g) / 1.3)))


def m_eff_table(seed=3, relative_sem=0.02, with_m_eff=True) -> pd.DataFrame:
    """A campaign-like table on the default grid: m_eff of a lifting bed with noise of known SEM."""
    rng = np.random.default_rng(seed)
    rows = []
    for f, g, r in itertools.product((50.0, 100.0, 500.0, 1000.0), (0.5, 1.0, 2.0, 5.0, 10.0),
                                     (25.0, 50.0, 90.0)):
        mass = float(bed_mass(r))
        sem = relative_sem * mass
        rows.append({"case_id": f"f{f:g}Hz_G{g:g}_r{r:g}pct_rep0", "freq_hz": f, "accel_g": g,
                     "fill_pct": r, "status": "ok", "flags": "", "ceq_coupon_ns_m": 1.0 + g,
                     "ceq_coupon_sem_ns_m": 0.1,
                     "m_eff_cell_kg": mass * lifting_ratio(g) + rng.normal(0.0, sem),
                     "m_eff_cell_sem_kg": sem, "bed_mass_kg": mass,
                     "m_eff_ratio": np.nan, "ceq_force_cell_ns_m": np.nan})
    table = pd.DataFrame(rows)
    if not with_m_eff:
        table[["m_eff_cell_kg", "m_eff_cell_sem_kg", "bed_mass_kg"]] = np.nan
    return table


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    folder = tmp_path_factory.mktemp("m_eff")
    table = m_eff_table()
    table.to_csv(folder / "ceq_table.csv", index=False)
    fit_m_eff_surrogate(str(folder / "ceq_table.csv"), str(folder / "surrogate_m_eff.json"))
    return folder, table


def test_the_m_eff_surrogate_is_a_gp_on_m_eff_with_a_linear_target(fitted):
    folder, table = fitted
    document = json.loads((folder / "surrogate_m_eff.json").read_text())
    assert (document["method"], document["target"]) == ("gp", "linear")
    assert (document["value_column"], document["sem_column"]) == ("m_eff_cell_kg",
                                                                  "m_eff_cell_sem_kg")
    surrogate = load_surrogate(folder / "surrogate_m_eff.json")     # round-trips (check values)
    assert surrogate.has_uncertainty and len(surrogate.training) == len(table)


def test_the_m_eff_surrogate_finds_the_bed_at_rest_and_airborne(fitted):
    """Off the grid's fills: the whole bed below lift-off, about nothing at 10 g, each within a
    few of its own predictive standard uncertainties plus the truth's 2 % noise level."""
    folder, _ = fitted
    surrogate = load_surrogate(folder / "surrogate_m_eff.json")
    f, g, r = np.array([70.0, 700.0, 300.0]), np.array([0.6, 10.0, 1.5]), np.array([40.0, 70.0, 60.0])
    value, sd = surrogate.predict_with_uncertainty(f, g, r)
    truth = bed_mass(r) * lifting_ratio(g)
    assert np.all(sd > 0)
    assert np.all(np.abs(value - truth) < 4 * sd + 0.02 * bed_mass(r)), (value, truth, sd)
    assert value[0] == pytest.approx(bed_mass(40.0) * lifting_ratio(0.6), rel=0.05)
    assert abs(value[1]) < 0.05 * bed_mass(70.0)


def test_a_slightly_negative_m_eff_is_fitted(tmp_path):
    table = m_eff_table(seed=5)
    airborne = table["accel_g"] == 10.0
    table.loc[airborne, "m_eff_cell_kg"] = -0.5 * table.loc[airborne, "m_eff_cell_sem_kg"]
    table.to_csv(tmp_path / "t.csv", index=False)
    fit_m_eff_surrogate(str(tmp_path / "t.csv"), str(tmp_path / "s.json"))
    surrogate = load_surrogate(tmp_path / "s.json")
    assert len(surrogate.training) == len(table)
    # an effective mass is not clipped at 0 as a dissipation is: the airborne plane reads negative
    at_10g = surrogate.predict(table.loc[airborne, "freq_hz"].to_numpy(), 10.0,
                               table.loc[airborne, "fill_pct"].to_numpy())
    assert not surrogate.nonnegative and (at_10g < 0).any()


def test_a_table_without_m_eff_is_refused_with_the_reason(tmp_path):
    m_eff_table(with_m_eff=False).to_csv(tmp_path / "t.csv", index=False)
    with pytest.raises(TableError, match="m_eff_cell_kg"):
        fit_m_eff_surrogate(str(tmp_path / "t.csv"), str(tmp_path / "s.json"))
    assert not (tmp_path / "s.json").exists()


def test_m_eff_targets_only_with_the_campaigns_table():
    assert m_eff_surrogate_paths(Optimisation()) == [M_EFF_SURROGATE]
    assert m_eff_figure_paths(Optimisation()) == list(M_EFF_FIGURES)
    external = Optimisation(external_ceq_table="published.csv")
    assert m_eff_surrogate_paths(external) == [] and m_eff_figure_paths(external) == []


def test_m_eff_maps_are_drawn_with_their_uncertainty(fitted, tmp_path):
    from pidpipe.steps.figures import plot_m_eff_maps

    folder, _ = fitted
    paths = [tmp_path / "m_eff_freq_fill.png", tmp_path / "m_eff_freq_accel.png"]
    plot_m_eff_maps(str(folder / "surrogate_m_eff.json"), str(folder / "ceq_table.csv"),
                    *map(str, paths))
    for path in paths:
        assert path.stat().st_size > 10_000 and path.with_suffix(".pdf").is_file()


def test_compare_designs_writes_the_m_eff_columns(fitted, tmp_path):
    """The verify step reads both surrogates and writes DEM m_eff against the surrogate's."""
    from pidpipe.config import load_config
    from pidpipe.config.settings import VerifySettings
    from pidpipe.design.surrogate import fit_surrogate, save_surrogate
    from pidpipe.loop.verify import plan_points
    from pidpipe.steps.params import verify_case_config
    from pidpipe.steps.verify import compare_designs, configured_fidelity
    from tests.loop.test_verify import design, record

    folder, table = fitted
    config = load_config(REPO / ".test" / "config.yaml")
    case_config = verify_case_config(config)
    fidelity, target = configured_fidelity(case_config)
    ceq = fit_surrogate(table, method="gp")
    save_surrogate(ceq, tmp_path / "surrogate.json")
    points = plan_points([design("A", "peak", 50.0, freq=(100.0, 500.0), accel=(1.0, 2.0))],
                         FULL_CELL)
    points.to_csv(tmp_path / "points.csv", index=False)
    m_eff = load_surrogate(folder / "surrogate_m_eff.json")
    paths = []
    for case_id in dict.fromkeys(points["case_id"]):
        row = points[points["case_id"] == case_id].iloc[0]
        truth = float(m_eff.predict(row["freq_hz"], row["accel_g"], row["fill_pct"]))
        rec = record(case_id, 2.0, 0.1).with_(
            fidelity={**fidelity, "transient_cycles": 30, "steps_per_cycle": 2000},
            harmonics={"m_eff_cell_kg": truth, "m_eff_cell_sem_kg": 0.02 * truth + 1e-9})
        if target is not None:
            rec = rec.with_(target={"relative_sem": target})
        paths.append(tmp_path / f"{case_id}.json")
        rec.write(paths[-1])
    out = tmp_path / "verify.csv"
    compare_designs(str(tmp_path / "points.csv"), [str(p) for p in paths],
                    str(tmp_path / "surrogate.json"),
                    VerifySettings.from_config(config).as_params(), case_config, str(out),
                    str(tmp_path / "verify.png"),
                    m_eff_surrogate_path=str(folder / "surrogate_m_eff.json"))
    written = pd.read_csv(out)
    assert (written["surrogate_u_method"] == "gp_predictive").all()
    assert written["m_eff_surrogate_u_kg"].gt(0).all()
    assert written["z_m_eff"].abs().max() < 0.5      # the records hold what the surrogate says
