"""The design stage's steps: fit the surrogates (C_eq, and the effective mass), cross-validate, optimise every design of every environment.

Here the config's parts become the design's settings objects (:class:`~pidpipe.design.designs.Search`,
:class:`~pidpipe.design.bootstrap.Bootstrap`, environments); nothing below reads the config.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

from pidpipe.files import write_atomic

if TYPE_CHECKING:
    from pidpipe.design.bootstrap import Bootstrap
    from pidpipe.design.designs import Search

logger = logging.getLogger("pidpipe.campaign")


def fit_table_surrogate(table_path: str, method: str, surrogate_path: str,
                        allow_holes: bool = False) -> None:
    """Fit the configured surrogate to a C_eq table and save it (JSON).

    With ``allow_holes`` grid points without an ok result are bridged by the RBF and listed in
    the log; without it the fit stops and names them.
    """
    from pidpipe.design.ceq_table import read_ceq_table
    from pidpipe.design.surrogate import fit_surrogate, listed_points, save_surrogate

    table = read_ceq_table(table_path)
    surrogate = fit_surrogate(table, method=method, source=str(table_path), allow_holes=allow_holes)
    if surrogate.holes:
        logger.warning("surrogate bridges %d grid point(s) without an ok result (f Hz, G g, r %%): %s",
                       len(surrogate.holes), listed_points(surrogate.holes))
    write_atomic(surrogate_path, lambda tmp: save_surrogate(surrogate, tmp))
    logger.info("surrogate %s (%s target) on %d rows of %s; %d left out; domain %s", method,
                surrogate.target, len(surrogate.training), table_path, len(surrogate.excluded),
                surrogate.domain)


def fit_m_eff_surrogate(table_path: str, surrogate_path: str, allow_holes: bool = False) -> None:
    """Fit the Gaussian process of one cell's effective mass to a C_eq table and save it (JSON).

    The fitted column is ``m_eff_cell_kg`` with its SEM ``m_eff_cell_sem_kg``
    (:data:`pidpipe.design.ceq_table.M_EFF_COLUMN`), rows by the fit policy
    (:mod:`pidpipe.design.fit_policy`), on a **linear** target: m_eff runs from the whole bed's
    mass (resting) to about zero, and slightly below within its noise, when the bed is airborne,
    where a log target is not defined. Whatever the C_eq surrogate's method (``surrogate.method``),
    m_eff is always fitted by ``gp``: the damper element and the host check's model (c) draw it
    within its own predictive uncertainty.

    Parameters
    ----------
    table_path : path
        The campaign's C_eq table (``results/ceq_table.csv``).
    surrogate_path : path
        ``results/surrogate_m_eff.json`` (:data:`pidpipe.design.damper.M_EFF_FILE`).
    allow_holes : bool
        Bridge grid points without a fitted m_eff (``surrogate.allow_holes``); without it the
        fit stops and names them.

    Raises
    ------
    TableError
        The table has no m_eff (records made before the harmonics were measured), or a row to
        fit has no SEM.
    """
    from pidpipe.design.ceq_table import M_EFF_COLUMN, M_EFF_SEM_COLUMN, read_ceq_table
    from pidpipe.design.surrogate import fit_surrogate, listed_points, save_surrogate
    from pidpipe.errors import TableError

    table = read_ceq_table(table_path)
    if M_EFF_COLUMN not in table.columns or not table[M_EFF_COLUMN].notna().any():
        raise TableError(f"C_eq table {table_path}: no {M_EFF_COLUMN} in any row (its records "
                         "were made before the effective mass was measured): delete "
                         "results/cases/ and rerun the campaign to measure it")
    surrogate = fit_surrogate(table, method="gp", target="linear", source=str(table_path),
                              allow_holes=allow_holes, value_column=M_EFF_COLUMN,
                              sem_column=M_EFF_SEM_COLUMN)
    if surrogate.holes:
        logger.warning("m_eff surrogate bridges %d grid point(s) without a fitted m_eff "
                       "(f Hz, G g, r %%): %s", len(surrogate.holes),
                       listed_points(surrogate.holes))
    write_atomic(surrogate_path, lambda tmp: save_surrogate(surrogate, tmp))
    logger.info("m_eff %s", surrogate.describe())


def cross_validate_table(table_path: str, cv_path: str, workers: int = 1) -> None:
    """Leave-one-out cross-validation of every surrogate method on a C_eq table (CSV), its folds
    fitted ``workers`` at a time."""
    from pidpipe.design.ceq_table import read_ceq_table
    from pidpipe.design.surrogate import cross_validate, select_surrogate

    cv = cross_validate(read_ceq_table(table_path), workers=workers)
    write_atomic(cv_path, lambda tmp: cv.to_csv(tmp, index=False))
    method, target = select_surrogate(cv)
    logger.info("cross-validation of %s: %d (method, target, scheme) rows; best by the plane "
                "scheme (or the default without one): %s, %s target", table_path, len(cv),
                method, target)


def search_settings(optimisation: dict) -> Search:
    """The designs' search from the config's ``optimisation`` section."""
    from pidpipe.design.band import BandRule
    from pidpipe.design.designs import Search

    return Search(starts=int(optimisation["starts"]), seed=int(optimisation["seed"]),
                  rule=BandRule(quadrature_points=int(optimisation["band_quadrature_points"]),
                                grid_points=int(optimisation["band_grid_points"])))


def bootstrap_settings(bootstrap: dict) -> Bootstrap:
    """The bootstrap from the config's ``optimisation.bootstrap`` section."""
    from pidpipe.design.bootstrap import Bootstrap

    return Bootstrap(draws=int(bootstrap["draws"]), starts=int(bootstrap["starts"]),
                     seed=int(bootstrap["seed"]), confidence=float(bootstrap["confidence"]))


def environment_objects(environments: list[dict]) -> list:
    """The config's ``environments`` as :class:`~pidpipe.design.optimisation.Environment`."""
    from pidpipe.design.optimisation import Environment

    return [Environment(e["name"], tuple(e["freq_hz"]), tuple(e["accel_g"])) for e in environments]


def optimise_surrogate(surrogate_path: str, environments: list[dict], budget: dict,
                       optimisation: dict, results_csv: str, history_csv: str, results_json: str,
                       bootstrap_csv: str, workers: int = 1, cv_path: str | None = None) -> None:
    """Every design of every environment on a saved surrogate, with its bootstrap; write the
    designs (CSV, JSON), the convergence histories and the bootstrap's draws (CSV).

    Parameters
    ----------
    environments : list of dict
        The config's ``environments``.
    budget : dict
        :class:`~pidpipe.design.optimisation.Budget`'s fields (``steps.params.budget_params``).
    optimisation : dict
        The config's ``optimisation`` section (starts, seed, band rule, bootstrap).
    workers : int
        Processes the bootstrap's draws are shared among (the rule's threads; the same results).
    cv_path : str, optional
        The cross-validation of the surrogate's table (``results/surrogate_cv.csv``): the
        surrogate's leave-one-out error is read from it rather than computed again.
    """
    from pidpipe.design.designs import (
        format_designs,
        write_history_csv,
        write_results_csv,
        write_results_json,
    )
    from pidpipe.design.optimisation import Budget
    from pidpipe.design.optimum import optimise_panel
    from pidpipe.design.surrogate import load_surrogate

    surrogate = load_surrogate(surrogate_path)
    loo = None
    if cv_path is not None:
        import pandas

        from pidpipe.design.bootstrap import loo_from_cross_validation

        loo = loo_from_cross_validation(pandas.read_csv(cv_path), surrogate)
        logger.info("the surrogate's leave-one-out error: %s", "from " + cv_path if loo is not None
                    else f"computed ({cv_path} has no row of {surrogate.method}, "
                         f"{surrogate.target})")
    optimum = optimise_panel(surrogate, environment_objects(environments), Budget(**budget),
                             search_settings(optimisation), bootstrap_settings(optimisation["bootstrap"]),
                             workers=workers, loo=loo)
    results = optimum.results
    for res in results:
        d = res.design
        logger.info("%s, %s: r = %.2f %%, n_c = %d cells, total C_eq = %.6g N*s/m (band mean %.6g, "
                    "worst %.6g, best %.6g); %d of %d starts converged%s", res.environment.name,
                    res.kind, d.fill_pct, d.n_cells, d.total_ceq_ns_m, res.band.mean_total_ceq_ns_m,
                    res.band.worst_total_ceq_ns_m, res.band.best_total_ceq_ns_m, res.n_converged,
                    len(res.starts), f"; WARNING: {res.regime_warning}" if res.regime_warning else "")
    logger.info("designs:\n%s", format_designs(results))
    write_atomic(results_csv, lambda tmp: write_results_csv(results, tmp))
    write_atomic(history_csv, lambda tmp: write_history_csv(results, tmp))
    write_atomic(results_json, lambda tmp: write_results_json(results, tmp))
    write_atomic(bootstrap_csv, lambda tmp: optimum.draws.to_csv(tmp, index=False))
