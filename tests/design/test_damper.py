"""The damper element (pidpipe.design.damper): m_eff and C_eq of n cells with uncertainties, the
impedance it adds to a structure, its files and the ``pidpipe damper`` command."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from pidpipe.cli import main
from pidpipe.design.damper import CEQ_FILE, M_EFF_FILE, Damper, acceleration_g
from pidpipe.design.surrogate import fit_surrogate, save_surrogate
from pidpipe.errors import DomainError, TableError
from pidpipe.loop.sdof import complex_amplitude
from tests._snakemake import TEST_CONFIG
from tests._surrogates import FakeSurrogate, MeanOnlySurrogate, constant

N_COUPON = 441
BED_KG = 11 * 9.65e-6


def _ceq(f, g, r):
    return 2.0 * r / 25 * np.minimum(g, 3.0) * (f / 500.0) ** 0.5


def _m_eff(f, g, r):
    return BED_KG * r / 50.0 / (1.0 + g**2)


def _damper() -> Damper:
    return Damper(FakeSurrogate(_ceq, lambda f, g, r: 0.1 * _ceq(f, g, r)),
                  FakeSurrogate(_m_eff, lambda f, g, r: 0.05 * _m_eff(f, g, r)), N_COUPON)


def test_values_are_per_cell_times_cells_with_their_uncertainties():
    f, g, r = np.array([200.0, 500.0]), np.array([0.5, 5.0]), np.array([30.0, 60.0])
    one, many = _damper().values(f, g, r), _damper().values(f, g, r, cells=20)
    assert one.ceq_ns_m == pytest.approx(_ceq(f, g, r) / N_COUPON)
    assert one.ceq_sd_ns_m == pytest.approx(0.1 * _ceq(f, g, r) / N_COUPON)
    assert one.m_eff_kg == pytest.approx(_m_eff(f, g, r))
    assert one.m_eff_sd_kg == pytest.approx(0.05 * _m_eff(f, g, r))
    for name in ("ceq_ns_m", "ceq_sd_ns_m", "m_eff_kg", "m_eff_sd_kg"):
        assert getattr(many, name) == pytest.approx(20 * getattr(one, name))
    assert not one.clipped.any() and one.cells == 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        one.cells = 2


def test_the_impedance_makes_the_structure_the_one_carrying_the_mass_and_dashpot():
    """A host m, k, c at the cells: X = F / (k - m w^2 + i w c + i w Z) is the host of mass
    m + m_eff and damping c + C_eq; and a rigid rider's force on the host is +M w^2 X."""
    damper = _damper()
    freq, accel, fill, cells = 275.0, 2.0, 50.0, 20
    omega = 2 * np.pi * freq
    z = damper.impedance(freq, accel, fill, cells)[0]
    v = damper.values(freq, accel, fill, cells)
    mass, stiffness, damping = 0.022, 0.022 * omega**2 * 1.1, 0.77
    x = 0.01 / (stiffness - mass * omega**2 + 1j * omega * damping + 1j * omega * z)
    expected = complex_amplitude(0.01, mass + v.m_eff_kg[0], stiffness,
                                 damping + v.ceq_ns_m[0], omega)
    assert abs(x / expected - 1) < 1e-12
    assert damper.dynamic_stiffness(freq, accel, fill, cells)[0] == pytest.approx(1j * omega * z)
    rider = Damper(FakeSurrogate(constant(0.0)), FakeSurrogate(constant(BED_KG)), N_COUPON)
    force_per_x = -rider.dynamic_stiffness(freq, accel, fill)[0]
    assert force_per_x == pytest.approx(BED_KG * omega**2)


def test_a_query_outside_the_common_domain_is_refused_or_clipped_and_flagged():
    narrow = {"freq_hz": (100.0, 400.0), "accel_g": (0.5, 10.0), "fill_pct": (25.0, 90.0)}
    damper = Damper(FakeSurrogate(_ceq), FakeSurrogate(_m_eff, domain=narrow), N_COUPON)
    assert damper.domain == {"freq_hz": (100.0, 400.0), "accel_g": (0.5, 10.0),
                             "fill_pct": (25.0, 90.0)}
    with pytest.raises(DomainError, match="freq_hz = 500 Hz is outside"):
        damper.values(500.0, 2.0, 50.0)
    with pytest.raises(DomainError, match="fill_pct = 20"):
        damper.values(300.0, 2.0, 20.0, clip=True)               # r is never clipped
    v = damper.values([500.0, 300.0, 300.0], [2.0, 0.1, 2.0], 50.0, clip=True)
    assert v.clipped.tolist() == [True, True, False]
    assert v.freq_hz.tolist() == [400.0, 300.0, 300.0] and v.accel_g.tolist() == [2.0, 0.5, 2.0]
    assert v.m_eff_kg[1] == pytest.approx(_m_eff(300.0, 0.5, 50.0))


def test_a_surrogate_without_a_predictive_uncertainty_reports_none():
    damper = Damper(MeanOnlySurrogate(_ceq), FakeSurrogate(_m_eff), N_COUPON)
    v = damper.values(300.0, 2.0, 50.0)
    assert np.isnan(v.ceq_sd_ns_m).all() and v.m_eff_sd_kg == pytest.approx([0.0])
    assert "C_eq no, m_eff yes" in damper.describe()


def test_acceleration_of_a_displacement():
    assert acceleration_g(100.0, 1e-4) == pytest.approx((2 * np.pi * 100) ** 2 * 1e-4 / 9.81)


def _grid(value) -> pd.DataFrame:
    rows = [{"freq_hz": f, "accel_g": g, "fill_pct": r, "status": "ok",
             "ceq_coupon_ns_m": float(value(f, g, r))}
            for f in (200.0, 500.0, 1000.0) for g in (1.0, 2.0, 5.0, 10.0) for r in (25.0, 50.0)]
    return pd.DataFrame(rows)


def _results(folder, with_m_eff=True):
    """A results folder of spline surrogates (the m_eff one fitted to m_eff values in the value
    column: the loader is what is exercised, not the m_eff surrogate's own format)."""
    folder.mkdir(exist_ok=True)
    ceq = fit_surrogate(_grid(_ceq), method="tensor_linear")
    save_surrogate(ceq, folder / CEQ_FILE)
    m_eff = fit_surrogate(_grid(_m_eff), method="tensor_linear")
    if with_m_eff:
        save_surrogate(m_eff, folder / M_EFF_FILE)
    return ceq, m_eff


def test_from_results_reads_both_files_with_the_default_loader(tmp_path):
    ceq, m_eff = _results(tmp_path)
    damper = Damper.from_results(tmp_path, N_COUPON)
    v = damper.values([300.0, 700.0], [1.5, 7.0], 40.0, cells=3)
    assert v.ceq_ns_m == pytest.approx(3 / N_COUPON * ceq.predict([300.0, 700.0], [1.5, 7.0], 40.0))
    assert v.m_eff_kg == pytest.approx(3 * m_eff.predict([300.0, 700.0], [1.5, 7.0], 40.0))
    assert np.isnan(v.ceq_sd_ns_m).all() and np.isnan(v.m_eff_sd_kg).all()


def test_from_results_uses_a_given_loader_and_refuses_a_missing_m_eff_file(tmp_path):
    (tmp_path / CEQ_FILE).write_text("{}")
    with pytest.raises(TableError, match="surrogate_m_eff.json does not exist"):
        Damper.from_results(tmp_path, N_COUPON, loader=lambda path: FakeSurrogate(_ceq))
    (tmp_path / M_EFF_FILE).write_text("{}")
    loaded = []

    def loader(path):
        loaded.append(path.name)
        return FakeSurrogate(_ceq if path.name == CEQ_FILE else _m_eff)

    damper = Damper.from_results(tmp_path, N_COUPON, loader=loader)
    assert loaded == [CEQ_FILE, M_EFF_FILE]
    assert damper.values(300.0, 2.0, 50.0).m_eff_kg == pytest.approx(_m_eff(300.0, 2.0, 50.0))


def test_pidpipe_damper_prints_both_values(tmp_path, capsys):
    ceq, m_eff = _results(tmp_path / "results")
    code = main(["--config", str(TEST_CONFIG), "damper", "--freq-hz", "300", "--accel-g", "1.5",
                 "--fill-pct", "40", "--cells", "3", "--results", str(tmp_path / "results")])
    out = capsys.readouterr().out
    assert code == 0
    m = 3 * float(m_eff.predict(300.0, 1.5, 40.0))
    assert f"m_eff           = {m:.4g} kg (the surrogate gives no uncertainty)" in out
    assert "impedance Z" in out


def test_pidpipe_damper_without_an_m_eff_surrogate_says_so(tmp_path, capsys):
    _results(tmp_path / "results", with_m_eff=False)
    code = main(["--config", str(TEST_CONFIG), "damper", "--freq-hz", "300", "--accel-g", "1.5",
                 "--fill-pct", "40", "--results", str(tmp_path / "results")])
    assert code == 2
    assert "surrogate_m_eff.json does not exist" in capsys.readouterr().err
