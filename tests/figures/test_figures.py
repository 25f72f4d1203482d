"""Figures: produced as PNG and PDF, not blank, labelled with units, honest about the domain."""

import itertools

import numpy as np
import pandas as pd
import pytest
from matplotlib.contour import QuadContourSet
from matplotlib.image import imread

from pidpipe.design.bootstrap import Bootstrap, bootstrap_designs, resampled_surrogates
from pidpipe.design.designs import Search, optimise_designs
from pidpipe.design.optimisation import Budget, Environment
from pidpipe.design.surrogate import fit_surrogate
from pidpipe.figures.convergence import plot_convergence
from pidpipe.figures.maps import (
    plot_ceq_freq_accel,
    plot_ceq_freq_fill,
    relative_spread,
)
from pidpipe.figures.spread import plot_optimum_spread


def table(f=(50.0, 100.0, 500.0, 750.0, 1000.0), g=(1.0, 5.0, 10.0), r=(25.0, 50.0, 75.0, 90.0)):
    rows = pd.DataFrame(list(itertools.product(f, g, r)), columns=["freq_hz", "accel_g", "fill_pct"])
    rows["ceq_coupon_ns_m"] = (2.0 * (rows.freq_hz / 100) ** 1.1 * (1 - np.exp(-(rows.accel_g - 0.5) / 3))
                               * (rows.fill_pct / 100) * np.exp(-rows.fill_pct / 120))
    return rows


@pytest.fixture(scope="module")
def surrogate():
    return fit_surrogate(table())


def panels(fig, row=0):
    """The map axes (row 0) or their uncertainty panels (row 1), colour bars excluded."""
    axes = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
    half = len(axes) // 2
    return axes[:half] if row == 0 else axes[half:]


def assert_not_blank(png):
    image = imread(png)
    assert image.shape[0] > 300 and image.shape[1] > 600
    rgb = image[..., :3].reshape(-1, 3)
    assert rgb.std() > 0.1  # not a uniform image
    codes = (rgb * 255).astype(np.int64) @ np.array([65536, 256, 1])
    assert np.unique(codes).size > 50  # many colours: a map was drawn


def test_freq_fill_maps_are_saved_labelled_and_mark_the_dem_points(surrogate, tmp_path):
    fig = plot_ceq_freq_fill(surrogate, (2.0, 5.0, 8.0), stem=tmp_path / "ceq_f_r")
    assert (tmp_path / "ceq_f_r.pdf").stat().st_size > 5000
    assert_not_blank(tmp_path / "ceq_f_r.png")
    axes = panels(fig)
    assert [ax.get_title() for ax in axes] == ["G = 2 g", "G = 5 g", "G = 8 g"]
    assert all(ax.get_xlabel() == "frequency f (Hz)" and ax.get_xscale() == "log" for ax in axes)
    assert axes[0].get_ylabel() == "fill fraction r (%)"
    colourbar = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"][0]
    assert "N·s/m" in colourbar.get_ylabel()
    assert all(any(isinstance(c, QuadContourSet) for c in ax.get_children()) for ax in axes)
    # on the 5 g slice the 20 DEM rows at G = 5 g are filled markers; the others are open
    on_slice = [c for c in axes[1].collections if c.get_label() == "DEM points on the slice"]
    assert len(on_slice) == 1 and len(on_slice[0].get_offsets()) == 20
    assert not [c for c in axes[0].collections if c.get_label() == "DEM points on the slice"]


def test_freq_accel_maps_have_g_on_the_y_axis(surrogate, tmp_path):
    fig = plot_ceq_freq_accel(surrogate, (25.0, 50.0, 80.0), stem=tmp_path / "ceq_f_g")
    assert_not_blank(tmp_path / "ceq_f_g.png")
    axes = panels(fig)
    assert axes[0].get_ylabel() == "base acceleration G (g)"
    assert [ax.get_title() for ax in axes] == ["r = 25 %", "r = 50 %", "r = 80 %"]
    assert axes[0].get_ylim() == (1.0, 10.0)


def test_slice_outside_the_domain_is_not_extrapolated(tmp_path):
    ci = fit_surrogate(table(f=(100.0, 500.0), g=(1.0, 5.0), r=(25.0, 50.0)), method="tensor_linear")
    fig = plot_ceq_freq_fill(ci, (2.0, 5.0, 8.0), stem=tmp_path / "ci")
    axes = panels(fig)
    assert "outside the surrogate domain" in axes[2].get_title()
    assert "[1, 5] g" in axes[2].get_title()
    assert not any(isinstance(c, QuadContourSet) for c in axes[2].get_children())
    assert any(isinstance(c, QuadContourSet) for c in axes[1].get_children())
    assert axes[0].get_xlim() == pytest.approx((100.0, 500.0))  # the domain, not the request
    assert_not_blank(tmp_path / "ci.png")


def test_convergence_figure_highlights_the_global_optimum(surrogate, tmp_path):
    envs = [Environment("250-300 Hz, 5-6 g", (250.0, 300.0), (5.0, 6.0)),
            Environment("450-500 Hz, 1-2 g", (450.0, 500.0), (1.0, 2.0))]
    results = optimise_designs(surrogate, envs, Budget(230, 22, 441), Search(starts=5, seed=4))
    fig = plot_convergence(results, stem=tmp_path / "convergence")
    assert_not_blank(tmp_path / "convergence.png")
    assert (tmp_path / "convergence.pdf").exists()
    assert len(fig.axes) == 6  # rows: designs; columns: environments
    by_position = {(kind, env.name): ax for ax, (kind, env) in
                   zip(fig.axes, [(k, e) for k in ("peak", "band_mean", "worst_case") for e in envs])}
    for res in results:
        ax = by_position[(res.kind, res.environment.name)]
        assert ax.get_xlabel() == "SLSQP iteration" and "N·s/m" in ax.get_ylabel()
        assert res.environment.name in ax.get_title() and res.kind in ax.get_title()
        assert ("G ≤ 1" in ax.get_title()) == (res.environment.accel_g[0] <= 1.0)
        drawn = [line for line in ax.get_lines() if len(line.get_xdata()) > 0]
        assert len(drawn) == len(res.starts)
        best = max(drawn, key=lambda line: line.get_linewidth())
        best_run = next(r for r in res.starts if r.index == res.optimum.start_indices[0])
        np.testing.assert_allclose(best.get_ydata(), best_run.history_ns_m)


def test_uncertain_points_and_the_one_g_line_are_drawn(tmp_path):
    # Below resolution is shown as such: the 1 g rows carry a 50 % SEM and are ringed; the line
    # at G = 1 marks where the spheres stop leaving the floor.
    rows = table()
    rows["ceq_coupon_sem_ns_m"] = np.where(rows.accel_g <= 1.0, 0.5, 0.05) * rows.ceq_coupon_ns_m
    fig = plot_ceq_freq_accel(fit_surrogate(rows), (25.0, 50.0, 80.0), stem=tmp_path / "u")
    ax = panels(fig)[0]
    ringed = [c for c in ax.collections if c.get_label().startswith("DEM C_eq uncertain")]
    assert len(ringed) == 1
    assert np.allclose(ringed[0].get_offsets()[:, 1], 1.0) and len(ringed[0].get_offsets()) == 20
    assert any(line.get_label().startswith("G = 1") for line in ax.get_lines())


@pytest.fixture(scope="module")
def noisy_surrogate():
    rows = table()
    rows["ceq_coupon_sem_ns_m"] = 0.05 * rows["ceq_coupon_ns_m"]
    return fit_surrogate(rows)


def test_maps_carry_an_uncertainty_panel_whose_spread_is_the_sem_at_the_dem_points(noisy_surrogate,
                                                                                   tmp_path):
    draws = list(resampled_surrogates(noisy_surrogate, 50, seed=11))
    fig = plot_ceq_freq_fill(noisy_surrogate, (2.0, 5.0, 8.0), stem=tmp_path / "m", draws=draws)
    spread_axes = panels(fig, row=1)
    assert len(spread_axes) == 3
    assert all(any(isinstance(c, QuadContourSet) for c in ax.get_children()) for ax in spread_axes)
    assert "spread of 50 bootstrap refits" in spread_axes[1].get_title()
    bars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
    assert len(bars) == 2 and "std / value (%)" in bars[1].get_ylabel()
    # the refits interpolate their redrawn values, so at a DEM point the spread is its 5 % SEM
    on = noisy_surrogate.training[noisy_surrogate.training["accel_g"] == 5.0]
    at_points = relative_spread(noisy_surrogate, draws, on["freq_hz"].to_numpy(),
                                on["accel_g"].to_numpy(), on["fill_pct"].to_numpy())
    assert np.median(at_points) == pytest.approx(5.0, rel=0.2)
    assert_not_blank(tmp_path / "m.png")
    # no draws: the panels say why instead of drawing a spread
    fig = plot_ceq_freq_accel(noisy_surrogate, (25.0, 50.0, 80.0), draws=None, note="no SEM column")
    for ax in panels(fig, row=1):
        assert "uncertainty not drawn" in ax.get_title()
        assert not any(isinstance(c, QuadContourSet) for c in ax.get_children())
        assert any(t.get_text() == "no SEM column" for t in ax.texts)


def test_spread_figure_shows_every_draw_and_the_intervals(noisy_surrogate, tmp_path):
    envs = [Environment("250-300 Hz, 5-6 g", (250.0, 300.0), (5.0, 6.0)),
            Environment("450-500 Hz, 1-2 g", (450.0, 500.0), (1.0, 2.0))]
    budget, search = Budget(230, 22, 441), Search(starts=4, seed=1)
    results = optimise_designs(noisy_surrogate, envs, budget, search)
    draws = bootstrap_designs(noisy_surrogate, results, budget, search, Bootstrap(draws=12, starts=1))
    fig = plot_optimum_spread(results, draws, stem=tmp_path / "spread")
    assert_not_blank(tmp_path / "spread.png")
    assert (tmp_path / "spread.pdf").stat().st_size > 5000
    assert len(fig.axes) == 2
    for ax, env in zip(fig.axes, envs):
        assert env.name in ax.get_title() and "12 bootstrap draws" in ax.get_title()
        assert ("G ≤ 1" in ax.get_title()) == (env.accel_g[0] <= 1.0)
        assert "fill fraction r (%)" in ax.get_xlabel() and "N·s/m" in ax.get_ylabel()
        dots = [c for c in ax.collections if len(c.get_offsets()) == 12]
        assert len(dots) == 3  # one cloud of 12 draws per design
        labels = [text.get_text() for text in ax.get_legend().get_texts()]
        assert [label.split(":")[0] for label in labels] == ["peak", "band_mean", "worst_case"]
        assert all("n_c = " in label and "wins" in label for label in labels)
