"""The design stage's steps: fit the surrogate, cross-validate it, optimise every environment.
"""

from __future__ import annotations

import logging

from pidpipe.files import write_atomic

logger = logging.getLogger("pidpipe.campaign")


def fit_table_surrogate(table_path: str, method: str, surrogate_path: str,
                        allow_holes: bool = False) -> None:
    """Fit the configured surrogate to a C_eq table and save it (JSON).

    With ``allow_holes`` grid points without an ok result are bridged by the RBF and listed in
    the log; without it the fit stops and names them.
    """
    from pidpipe.design.ceq_table import read_ceq_table
    from pidpipe.design.surrogate import fit_surrogate, save_surrogate

    table = read_ceq_table(table_path)
    surrogate = fit_surrogate(table, method=method, source=str(table_path), allow_holes=allow_holes)
    if surrogate.holes:
        logger.warning("surrogate bridges %d grid point(s) without an ok result (f Hz, G g, r %%): %s",
                       len(surrogate.holes), surrogate.holes)
    write_atomic(surrogate_path, lambda tmp: save_surrogate(surrogate, tmp))
    logger.info("surrogate %s (%s target) on %d rows of %s; %d left out; domain %s", method,
                surrogate.target, len(surrogate.training), table_path, len(surrogate.excluded),
                surrogate.domain)


def cross_validate_table(table_path: str, cv_path: str) -> None:
    """Leave-one-out cross-validation of every surrogate method on a C_eq table (CSV)."""
    from pidpipe.design.ceq_table import read_ceq_table
    from pidpipe.design.surrogate import cross_validate, select_surrogate

    cv = cross_validate(read_ceq_table(table_path))
    write_atomic(cv_path, lambda tmp: cv.to_csv(tmp, index=False))
    method, target = select_surrogate(cv)
    logger.info("cross-validation of %s: %d (method, target, scheme) rows; best by the plane "
                "scheme (or the default without one): %s, %s target", table_path, len(cv),
                method, target)


def optimise_surrogate(surrogate_path: str, environments: list[dict], budget: dict, starts: int,
                       seed: int, results_csv: str, history_csv: str, results_json: str) -> None:
    """Optimise every environment on a saved surrogate; write the results and histories."""
    from pidpipe.design.optimisation import (
        Budget,
        Environment,
        optimise_environments,
        write_history_csv,
        write_results_csv,
        write_results_json,
    )
    from pidpipe.design.surrogate import load_surrogate

    surrogate = load_surrogate(surrogate_path)
    envs = [Environment(e["name"], tuple(e["freq_hz"]), tuple(e["accel_g"])) for e in environments]
    results = optimise_environments(surrogate, envs, Budget(**budget), starts=int(starts),
                                    seed=int(seed))
    for res in results:
        d = res.design
        logger.info("%s: r = %.2f %%, n_c = %d cells, f = %g Hz, G = %g g, total C_eq = %.6g N*s/m "
                    "(%d of %d starts converged)", res.environment.name, d.fill_pct, d.n_cells,
                    d.freq_hz, d.accel_g, d.total_ceq_ns_m, res.n_converged, len(res.starts))
    write_atomic(results_csv, lambda tmp: write_results_csv(results, tmp))
    write_atomic(history_csv, lambda tmp: write_history_csv(results, tmp))
    write_atomic(results_json, lambda tmp: write_results_json(results, tmp))
