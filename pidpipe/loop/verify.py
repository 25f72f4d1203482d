"""Each design checked by DEM where it matters: at its fill, at its band's corners and centre.

Which cases (:func:`plan_points`)
---------------------------------
For every environment's ``band_mean`` and ``peak`` design (:data:`VERIFIED_KINDS`) of the
optimisation (``results/optimum.json``), five points of its band [f_lo, f_hi] x [G_lo, G_hi]:
the four corners and the centre ((f_lo + f_hi)/2, (G_lo + G_hi)/2; the band mean takes f and G
uniform in their bands). The design's fill r_d stands in general for a fractional number of
spheres per cell; a cell holds whole spheres, so the DEM pours n = round half up of
(full_cell_spheres x r_d / 100), the count most of the design's cells hold (its
``spheres_left_over`` cells hold the next count up), and the case's fill is that count's,
100 n / full_cell_spheres, rounded to 1e-3 % (which gives n back;
:func:`pidpipe.config.derived.poured_fill`). The surrogate is read at that same fill: its fill
axis is the fill a cell holds (every row of the C_eq table sits at its sphere count's fill,
:func:`pidpipe.design.records.records_to_table`), so the comparison is of one cell with n spheres
against what the surrogate says such a cell gives, and ``design_fill_pct`` only records the
design it verifies. (Read at r_d instead, the surrogate gives a value between n - 1 and n
spheres, which no poured cell is: a design at 32.07 % of 21 spheres was flagged at |z| = 3.66
against 2.11 read at its 7 spheres, ``benchmarks/experiments/shared_packings_verify.py``.) Points
that two designs share (the same sphere count, f and G, e.g. a peak and a band_mean design at
one fill) are one case, run once (:func:`unique_case_ids`).

A verifying case is replicate :data:`VERIFY_REPLICATE` of its point, so it shakes packings no
case of the campaign shakes (:meth:`pidpipe.cases.CaseSpec.packing_ids`; the campaign's
replicates are 0-99, the cells its target adds are the pool's packings of that replicate). On
the campaign's packings (replicate 0) a verifying case would share their offset with the fitted
cases of its fill, which every case of a fill shakes: the offset cancels in C_dem - C_s, so
z comes out narrower than its uncertainties say and blind to the packings' own error
(``docs/explanation/validation.md``, ``benchmarks/experiments/verify_packings.py``).

The surrogate's standard uncertainty (:func:`surrogate_uncertainty`)
--------------------------------------------------------------------
For a Gaussian-process surrogate (``gp``, :attr:`~pidpipe.design.surrogate.Surrogate.has_uncertainty`)
u_s is its own predictive standard uncertainty at the point, with the fitted excess scatter
between cases (``predict_with_uncertainty(..., include_scatter=True)``: what one new case is
compared with, its own SEM added apart). The GP fits every case with its noise, so that one
figure holds both the cases' noise carried to the point and the error of interpolating to it,
larger far from the cases; ``surrogate_u_method`` is ``gp_predictive`` and the two parts below
are NaN. (Adding bootstrap redraws to it would count the cases' noise twice, and a leave-one-out
error, itself holding the held-out cases' noise, a third time.)

For the interpolants (no uncertainty of their own; ``surrogate_u_method``
``bootstrap_and_loo``) u_s = sqrt(u_noise^2 + u_interp^2), N*s/m:

``u_noise``
    the standard deviation at the point of ``draws`` refits of the surrogate on the C_eq table
    redrawn within its SEMs (:func:`pidpipe.design.bootstrap.resampled_surrogates`): the grid's
    statistical error carried through the interpolant (NaN, and left out, when the table has
    no SEMs or ``draws`` is 0);
``u_interp``
    e_loo x the prediction, e_loo the RMS relative leave-one-out error of the surrogate's method
    on its own table (:func:`pidpipe.design.bootstrap.loo_rel_error`): the error of
    interpolating between grid points, one figure for the whole domain (NaN, and left out,
    when there is no fold).

It includes the table's noise and a global estimate of the interpolation error. It omits how
the interpolation error varies over the domain (larger far from grid points, smaller near them:
one RMS is used everywhere). e_loo, measured on DEM data, also holds the held-out points' own
noise, so u_interp partly counts u_noise again: u_s leans large, and |z| small.

Either way u_s omits the DEM's own systematic error (contact model, fidelity settings), which
the grid and the verifying cases share when they run the same engine at the same fidelity; a
solver difference enters when ``verify.engine`` is not the campaign's engine (each row names
its engine).

The comparison (:func:`compare`)
--------------------------------
t_combined = (C_dem - C_s) / sqrt(SEM_dem^2 + u_s^2), for the coupon's C_eq (what the
surrogate models), judged by its degrees of freedom as the refinement loop judges its verifying
points (:mod:`pidpipe.refine.verification`). The DEM's SEM is its cells' spread
(:func:`pidpipe.measurement.cells.mean_of_cells`), so it has ``dem_dof`` = cells - 1 degrees of
freedom, cells the record's ``n_cells_measured`` (its target's cells, else its run's
``cells_per_run``); one cell, or no count, leaves it unknown, taken as infinite. u_s is taken as
known. Then t has nu = (SEM_dem^2 + u_s^2)^2 / (SEM_dem^4 / dem_dof) degrees of freedom
(Welch-Satterthwaite), and z_combined is the standard normal score of the same two-sided tail
probability under Student's t of nu degrees of freedom
(:func:`pidpipe.measurement.agreement.normal_score`; z = t when nu is infinite), so ``flag_z``
keeps its meaning, a tail probability, whatever the cells: a case that ends at a 7-cell pilot
(6 degrees of freedom, u_s small beside its SEM) passes up to |t| = 2.52 at ``flag_z`` = 2,
where judged as normal it would fail a calibrated surrogate at twice the rate the flag means.
``surrogate_off`` is |z_combined| > ``flag_z``.

The effective mass is compared the same way when there is an m_eff surrogate
(:func:`m_eff_predictions`, the campaign's GP of one cell's m_eff): the verifying case's m_eff
of the mean cell ± its SEM (its record's ``harmonics``) against the surrogate's prediction ±
its predictive standard uncertainty (with the excess scatter), read at the case's fill as
C_eq is, and t_m_eff = (m_dem - m_s) / sqrt(SEM_dem^2 + u_m^2). The m_eff SEM comes from
the same cells as C_eq's (:func:`pidpipe.measurement.harmonics.mean_cell` over the record's
cells), so t_m_eff is judged by the same ``dem_dof``: z_m_eff is its normal score as above, and
``m_eff_off`` is |z_m_eff| > ``flag_z``. Without an m_eff surrogate, or a record without
harmonics, those columns are NaN.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from pidpipe.cases import CaseSpec
from pidpipe.config.derived import poured_fill
from pidpipe.errors import PidpipeError
from pidpipe.measurement.case_record import CaseRecord

#: The replicate of every verifying case: its packings are none of the campaign's (its replicates
#: are below 100) nor the refinement loop's (extensions from 101, verifying runs from 200).
VERIFY_REPLICATE = 100

#: The designs checked, in the table's order.
VERIFIED_KINDS: tuple[str, ...] = ("band_mean", "peak")

#: The points of a band, in the table's order.
POINT_NAMES: tuple[str, ...] = ("f_lo_G_lo", "f_lo_G_hi", "f_hi_G_lo", "f_hi_G_hi", "centre")

#: Columns of the plan (results/verify/points.csv), one row per design and point.
POINT_COLUMNS: tuple[str, ...] = (
    "case_id", "environment", "design", "point", "freq_hz", "accel_g", "design_fill_pct",
    "fill_pct", "n_spheres", "n_cells",
)

#: Columns of results/verify.csv, in order.
VERIFY_COLUMNS: tuple[str, ...] = POINT_COLUMNS + (
    "engine", "solver", "dem_status", "dem_flags", "n_cycles", "n_cells_measured", "dem_dof",
    "transient_cycles", "steps_per_cycle",
    "target_relative_sem", "target_reached", "dem_cpu_time_s",
    "ceq_coupon_dem_ns_m", "ceq_coupon_dem_sem_ns_m",
    "surrogate_method", "ceq_coupon_surrogate_ns_m", "surrogate_u_method",
    "surrogate_noise_sd_ns_m", "surrogate_interp_sd_ns_m", "surrogate_u_ns_m", "difference_ns_m",
    "t_combined", "z_combined", "surrogate_off",
    "m_eff_dem_kg", "m_eff_dem_sem_kg", "m_eff_surrogate_kg", "m_eff_surrogate_u_kg",
    "t_m_eff", "z_m_eff", "m_eff_off", "note",
)

#: The m_eff columns of :func:`m_eff_predictions`, kg.
M_EFF_PREDICTION_COLUMNS: tuple[str, ...] = ("m_eff_surrogate_kg", "m_eff_surrogate_u_kg")


def band_points(freq_band: tuple[float, float],
                accel_band: tuple[float, float]) -> list[tuple[str, float, float]]:
    """The band's four corners and its centre: (name, f in Hz, G in g), :data:`POINT_NAMES` order."""
    (f_lo, f_hi), (g_lo, g_hi) = (float(v) for v in freq_band), (float(v) for v in accel_band)
    return [("f_lo_G_lo", f_lo, g_lo), ("f_lo_G_hi", f_lo, g_hi), ("f_hi_G_lo", f_hi, g_lo),
            ("f_hi_G_hi", f_hi, g_hi), ("centre", 0.5 * (f_lo + f_hi), 0.5 * (g_lo + g_hi))]


def plan_points(designs: list[dict], full_cell_spheres: int,
                kinds: tuple[str, ...] = VERIFIED_KINDS) -> pd.DataFrame:
    """The verifying cases of every design of ``kinds``: one row per design and band point.

    Parameters
    ----------
    designs : list of dict
        The optimisation's results as written to ``results/optimum.json``: each with
        ``environment`` ({name, ...}), ``kind``, ``bounds`` ({freq_hz: [lo, hi], accel_g: [lo,
        hi], ...}) and ``design`` ({fill_pct, n_cells, ...}).
    full_cell_spheres : int
        Spheres at 100 % fill.
    kinds : tuple of str
        The designs to check.

    Returns
    -------
    pandas.DataFrame
        :data:`POINT_COLUMNS`; environments in their order, then ``kinds``' order, then
        :data:`POINT_NAMES`. Rows of equal (fill, f, G) share a ``case_id``.

    Raises
    ------
    PidpipeError
        No design of ``kinds``, or a design without bounds or fill.
    """
    order = {kind: i for i, kind in enumerate(kinds)}
    chosen = [d for d in designs if d.get("kind") in order]
    if not chosen:
        raise PidpipeError(f"no {' or '.join(kinds)} design in the optimisation's results: "
                           "nothing to verify")
    environments = list(dict.fromkeys(d["environment"]["name"] for d in chosen))
    chosen.sort(key=lambda d: (environments.index(d["environment"]["name"]), order[d["kind"]]))
    rows = []
    for result in chosen:
        name = result["environment"]["name"]
        try:
            bounds, design = result["bounds"], result["design"]
            freq_band, accel_band = bounds["freq_hz"], bounds["accel_g"]
            design_fill, n_cells = float(design["fill_pct"]), int(design["n_cells"])
        except (KeyError, TypeError) as exc:
            raise PidpipeError(f"design {result['kind']} of {name!r} has no {exc} in the "
                               "optimisation's results") from None
        fill_pct, n_spheres = poured_fill(design_fill, full_cell_spheres)
        for point, freq_hz, accel_g in band_points(freq_band, accel_band):
            rows.append({"case_id": CaseSpec(freq_hz, accel_g, fill_pct, VERIFY_REPLICATE).case_id,
                         "environment": name, "design": result["kind"], "point": point,
                         "freq_hz": freq_hz, "accel_g": accel_g, "design_fill_pct": design_fill,
                         "fill_pct": fill_pct, "n_spheres": n_spheres, "n_cells": n_cells})
    return pd.DataFrame(rows, columns=list(POINT_COLUMNS))


def unique_case_ids(points: pd.DataFrame) -> list[str]:
    """The distinct cases of a plan, in first-seen order: a point two designs share runs once."""
    return list(dict.fromkeys(points["case_id"]))


def surrogate_uncertainty(surrogate, points: pd.DataFrame, draws: int,
                          seed: int) -> pd.DataFrame:
    """The surrogate's prediction and standard uncertainty at each point (module docstring).

    Parameters
    ----------
    surrogate : pidpipe.design.surrogate.Surrogate
    points : pandas.DataFrame
        With ``freq_hz`` (Hz), ``accel_g`` (g) and ``fill_pct`` (%, the case's fill, where the
        surrogate is read), m rows.
    draws, seed : int
        Refits on the table redrawn within its SEMs, and their seed (0 draws: no noise part);
        unused for a surrogate with its own predictive uncertainty (``gp``).

    Returns
    -------
    pandas.DataFrame
        m rows: ``surrogate_method``, ``ceq_coupon_surrogate_ns_m``, ``surrogate_u_method``
        (``gp_predictive`` or ``bootstrap_and_loo``), ``surrogate_noise_sd_ns_m``,
        ``surrogate_interp_sd_ns_m`` (NaN for ``gp_predictive``), ``surrogate_u_ns_m``
        (N*s/m) and ``note`` (what was left out, or where the fill was held to the domain).
    """
    freq, accel, held, notes = _surrogate_query(surrogate, points)
    if surrogate.has_uncertainty:
        value, u = surrogate.predict_with_uncertainty(freq, accel, held, include_scatter=True)
        nan = np.full(len(points), np.nan)
        return pd.DataFrame({"surrogate_method": surrogate.method,
                             "ceq_coupon_surrogate_ns_m": np.asarray(value, dtype=float),
                             "surrogate_u_method": "gp_predictive",
                             "surrogate_noise_sd_ns_m": nan, "surrogate_interp_sd_ns_m": nan,
                             "surrogate_u_ns_m": np.asarray(u, dtype=float), "note": notes})
    from pidpipe.design.bootstrap import has_sem, loo_rel_error, resampled_surrogates

    prediction = np.asarray(surrogate.predict(freq, accel, held), dtype=float).reshape(-1)
    if draws > 0 and has_sem(surrogate):
        redrawn = np.array([model.predict(freq, accel, held)
                            for model in resampled_surrogates(surrogate, draws, seed)])
        noise = redrawn.std(axis=0, ddof=1) if draws > 1 else np.full_like(prediction, np.nan)
    else:
        noise = np.full_like(prediction, np.nan)
    interp = loo_rel_error(surrogate) * prediction
    parts = np.vstack([noise, interp])
    total = np.sqrt(np.nansum(parts**2, axis=0))
    total[np.all(np.isnan(parts), axis=0)] = np.nan
    left_out = [name for name, part in (("noise", noise), ("interpolation", interp))
                if np.all(np.isnan(part))]
    if left_out:
        notes = [_join(note, f"surrogate uncertainty without its {' and '.join(left_out)} part")
                 for note in notes]
    return pd.DataFrame({"surrogate_method": surrogate.method,
                         "ceq_coupon_surrogate_ns_m": prediction,
                         "surrogate_u_method": "bootstrap_and_loo",
                         "surrogate_noise_sd_ns_m": noise, "surrogate_interp_sd_ns_m": interp,
                         "surrogate_u_ns_m": total, "note": notes})


def m_eff_predictions(m_eff_surrogate, points: pd.DataFrame) -> pd.DataFrame:
    """The m_eff surrogate's prediction and predictive standard uncertainty at each point.

    Parameters
    ----------
    m_eff_surrogate : pidpipe.design.surrogate.Surrogate or None
        The campaign's surrogate of one cell's m_eff, kg (``results/surrogate_m_eff.json``);
        None: every value NaN.
    points : pandas.DataFrame
        As :func:`surrogate_uncertainty`, m rows; read at ``fill_pct`` held to the
        surrogate's fill domain.

    Returns
    -------
    pandas.DataFrame
        m rows: :data:`M_EFF_PREDICTION_COLUMNS` (kg); the uncertainty is the GP's with the
        excess scatter (``include_scatter=True``), NaN for a surrogate without one.
    """
    nan = np.full(len(points), np.nan)
    if m_eff_surrogate is None:
        return pd.DataFrame({"m_eff_surrogate_kg": nan, "m_eff_surrogate_u_kg": nan})
    freq, accel, held, _ = _surrogate_query(m_eff_surrogate, points)
    if m_eff_surrogate.has_uncertainty:
        value, u = m_eff_surrogate.predict_with_uncertainty(freq, accel, held,
                                                            include_scatter=True)
    else:
        value, u = m_eff_surrogate.predict(freq, accel, held), nan
    return pd.DataFrame({"m_eff_surrogate_kg": np.asarray(value, dtype=float).reshape(-1),
                         "m_eff_surrogate_u_kg": np.asarray(u, dtype=float).reshape(-1)})


def _surrogate_query(surrogate, points: pd.DataFrame):
    """(f, G, fill held to the surrogate's fill domain, a note per point) of the plan's points:
    each read at its case's fill, the fill its cells hold."""
    freq, accel, fill = (points[c].to_numpy(dtype=float) for c in ("freq_hz", "accel_g", "fill_pct"))
    lo, hi = surrogate.domain["fill_pct"]
    held = np.clip(fill, lo, hi)
    notes = [f"surrogate at the fill domain's edge {h:g} % (the case's fill is {r:g} %)"
             if h != r else "" for r, h in zip(fill, held)]
    return freq, accel, held, notes


def t_combined(dem: np.ndarray, dem_sem: np.ndarray, surrogate: np.ndarray,
               surrogate_u: np.ndarray) -> np.ndarray:
    """t = (C_dem - C_s) / sqrt(SEM_dem^2 + u_s^2), shape of the inputs; NaN where the combined
    uncertainty is not a positive number (:func:`compare` judges it by its degrees of freedom)."""
    dem, dem_sem, surrogate, surrogate_u = (np.asarray(a, dtype=float)
                                            for a in (dem, dem_sem, surrogate, surrogate_u))
    combined = np.hypot(dem_sem, surrogate_u)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(combined > 0, (dem - surrogate) / combined, np.nan)


def dem_dof(cells) -> np.ndarray:
    """Degrees of freedom of a DEM SEM from ``cells`` cells: cells - 1, inf where the count is
    unknown (NaN) or below 2 (one cell's SEM is its cycles', of no known count); shape of
    ``cells``."""
    cells = np.asarray(cells, dtype=float)
    with np.errstate(invalid="ignore"):
        return np.where(cells >= 2, cells - 1.0, np.inf)


def is_off(z: np.ndarray, flag_z: float) -> np.ndarray:
    """Whether |z| exceeds ``flag_z`` (z the normal score of t, :func:`compare`): the surrogate
    is off by more than its and the DEM's standard uncertainties allow at that tail
    probability (False where z is NaN)."""
    z = np.asarray(z, dtype=float)
    return np.isfinite(z) & (np.abs(z) > float(flag_z))


def record_columns(record: CaseRecord) -> dict:
    """The DEM columns of a verifying case's record (failed, or m_eff without harmonics: NaN)."""
    nan = math.nan
    harmonics = {k: (nan if v is None else v) for k, v in (record.harmonics or {}).items()
                 if k in ("m_eff_cell_kg", "m_eff_cell_sem_kg")}
    target = record.target or {}
    fidelity = record.fidelity
    return {
        "engine": record.engine_name if record.engine_name is not None else (fidelity.engine or ""),
        "solver": record.solver, "dem_status": record.status,
        "dem_flags": ";".join(record.flags),
        "n_cycles": int(record.n_cycles),
        "n_cells_measured": int(target.get("cells", fidelity.get("cells_per_run", 0))),
        "transient_cycles": fidelity.get("transient_cycles", nan),
        "steps_per_cycle": fidelity.get("steps_per_cycle", nan),
        "target_relative_sem": target.get("relative_sem", nan),
        "target_reached": target.get("reached", ""),
        "dem_cpu_time_s": record.cpu_time_s,
        "ceq_coupon_dem_ns_m": float(record.ceq_coupon_ns_m),
        "ceq_coupon_dem_sem_ns_m": float(record.ceq_coupon_sem_ns_m),
        "m_eff_dem_kg": float(harmonics.get("m_eff_cell_kg", nan)),
        "m_eff_dem_sem_kg": float(harmonics.get("m_eff_cell_sem_kg", nan)),
    }


#: The record's ``fidelity`` keys a verifying case must share with the configured settings.
FIDELITY_KEYS: tuple[str, ...] = ("engine", "timestep_rayleigh_fraction_config",
                                  "youngs_modulus_scale", "measured_cycles", "rotation", "friction",
                                  "cells_per_run")


def stale_records(records: dict[str, CaseRecord], fidelity: dict,
                  target_relative_sem: float | None) -> list[str]:
    """The cases whose record was not made with the configured settings, each with the reason.

    Snakemake reruns a case whose settings changed, except in the run in which the checkpoint
    that plans the cases ran too (it does not check the provenance of jobs it adds after a
    checkpoint): this catches a record left from before the change.

    Parameters
    ----------
    records : dict of str -> CaseRecord
        Case id -> record.
    fidelity : dict
        The expected values of :data:`FIDELITY_KEYS` (a record's ``fidelity`` block).
    target_relative_sem : float or None
        The campaign's target (None: pilot only, the record has no ``target``).

    Returns
    -------
    list of str
        ``"<case>: <key> <recorded> (configured <value>)"``, empty when every record is current.
    """
    stale = []
    for case_id, record in records.items():
        made = pilot_fidelity(record)
        for key in FIDELITY_KEYS:
            if made.get(key) != fidelity[key]:
                stale.append(f"{case_id}: {key} {made.get(key)!r} (configured {fidelity[key]!r})")
        target = (record.target or {}).get("relative_sem")
        if record.status != "failed" and target != target_relative_sem:
            stale.append(f"{case_id}: target_relative_sem {target!r} (configured "
                         f"{target_relative_sem!r})")
    return stale


def pilot_fidelity(record: CaseRecord) -> dict:
    """A record's ``fidelity`` block with the cells and measured cycles of its pilot run.

    A case run to a target keeps its pilot's settings in ``target.runs[0]``; the allocation
    then adds cells and cycles (:func:`pidpipe.measurement.adaptive.measure_to_target`), so
    the record's own ``fidelity.measured_cycles`` and ``cells_per_run`` are the extended
    run's, not the configured ones. Comparing those with the config would call every extended
    record stale, and ``verify`` would ask for a rerun that changes nothing.

    Parameters
    ----------
    record : CaseRecord

    Returns
    -------
    dict
        ``fidelity`` as the pilot was configured: ``measured_cycles`` and ``cells_per_run``
        from ``target.runs[0]`` when the record has one, else the record's own.
    """
    made = dict(record.fidelity or {})
    runs = (record.target or {}).get("runs") or []
    if runs:
        made.update(measured_cycles=runs[0]["measured_cycles"], cells_per_run=runs[0]["cells"])
    return made


def compare(points: pd.DataFrame, records: dict[str, CaseRecord], predictions: pd.DataFrame,
            flag_z: float) -> pd.DataFrame:
    """The verification table: each design point's DEM case against the surrogate.

    Parameters
    ----------
    points : pandas.DataFrame
        :func:`plan_points`, m rows.
    records : dict of str -> CaseRecord
        The record of every case id of ``points``.
    predictions : pandas.DataFrame
        :func:`surrogate_uncertainty` at ``points``, m rows in the same order, and optionally
        the m_eff surrogate's (:func:`m_eff_predictions`, columns beside; NaN when absent).
    flag_z : float
        ``surrogate_off`` when |z_combined| exceeds it, ``m_eff_off`` when |z_m_eff| does.

    Returns
    -------
    pandas.DataFrame
        :data:`VERIFY_COLUMNS`, m rows (C_eq in N*s/m, m_eff of one cell in kg; a shared case
        repeats in each of its designs' rows). ``t_combined`` and ``t_m_eff`` are the
        differences over their combined standard uncertainties; ``z_combined`` and ``z_m_eff``
        their normal scores at the Welch-Satterthwaite degrees of freedom of the DEM's
        ``dem_dof`` (the module's text).

    Raises
    ------
    PidpipeError
        A case of the plan has no record, or a record is of another case.
    """
    from pidpipe.measurement.agreement import normal_score   # scipy.stats: not at the plan's import

    missing = [c for c in unique_case_ids(points) if c not in records]
    if missing:
        raise PidpipeError(f"no record of the verifying case(s) {', '.join(missing)}")
    rows = []
    for case_id in points["case_id"]:
        record = records[case_id]
        if record.case_id != case_id:
            raise PidpipeError(f"the record given for {case_id} is of case {record.case_id!r}")
        rows.append(record_columns(record))
    dem = pd.DataFrame(rows, index=points.index)
    table = pd.concat([points, dem, predictions.set_index(points.index)], axis=1)
    table["difference_ns_m"] = table["ceq_coupon_dem_ns_m"] - table["ceq_coupon_surrogate_ns_m"]
    table["dem_dof"] = dem_dof(table["n_cells_measured"])
    for column in M_EFF_PREDICTION_COLUMNS:
        if column not in table.columns:
            table[column] = math.nan
    for t, z, off, value, sem, surrogate, surrogate_u in (
            ("t_combined", "z_combined", "surrogate_off", "ceq_coupon_dem_ns_m",
             "ceq_coupon_dem_sem_ns_m", "ceq_coupon_surrogate_ns_m", "surrogate_u_ns_m"),
            ("t_m_eff", "z_m_eff", "m_eff_off", "m_eff_dem_kg", "m_eff_dem_sem_kg",
             "m_eff_surrogate_kg", "m_eff_surrogate_u_kg")):
        table[t] = t_combined(table[value], table[sem], table[surrogate], table[surrogate_u])
        table[z] = normal_score(table[t], table[sem], table["dem_dof"], table[surrogate_u])
        table[off] = is_off(table[z], flag_z)
    notes = []
    for _, row in table.iterrows():
        note = row["note"]
        if row["surrogate_off"]:
            note = _join(note, f"surrogate off by {row['t_combined']:+.1f} combined standard "
                               f"uncertainties (|z| {abs(row['z_combined']):.2f} > {flag_z:g})")
        if row["m_eff_off"]:
            note = _join(note, f"m_eff surrogate off by {row['t_m_eff']:+.1f} combined standard "
                               f"uncertainties (|z| {abs(row['z_m_eff']):.2f} > {flag_z:g})")
        if row["dem_status"] != "ok":
            note = _join(note, f"DEM case {row['dem_status']}"
                               + (f" ({row['dem_flags']})" if row["dem_flags"] else ""))
        notes.append(note)
    table["note"] = notes
    return table[list(VERIFY_COLUMNS)]


def off_lines(table: pd.DataFrame) -> list[str]:
    """One line per row where the C_eq surrogate is off (for the rule's log)."""
    return _off_lines(table, "surrogate_off", "", "ceq_coupon_dem_ns_m", "ceq_coupon_dem_sem_ns_m",
                      "ceq_coupon_surrogate_ns_m", "surrogate_u_ns_m", "N*s/m", "t_combined",
                      "z_combined")


def worst_z_line(table: pd.DataFrame) -> str:
    """``<environment> |z| <worst> (<design>, <point>); ...``: each environment's largest
    |z_combined| (the normal score of t at its degrees of freedom, :func:`compare`) over its
    design points (for the rule's log); ``-`` where no point has a z."""
    parts = []
    for environment, rows in table.groupby("environment", sort=False):
        z = rows["z_combined"].abs()
        if z.notna().any():
            worst = rows.loc[z.idxmax()]
            parts.append(f"{environment} |z| {abs(worst['z_combined']):.2f} ({worst['design']}, "
                         f"{worst['point']})")
        else:
            parts.append(f"{environment} -")
    return "; ".join(parts)


def calibration_line(table: pd.DataFrame, flag_z: float) -> str:
    """What the cases' z say of the surrogate's calibration, for the rule's log.

    ``n case(s): RMS z r; worst |z| w, which the worst of n independent points of a calibrated
    surrogate exceeds with probability p; |z| > flag_z at k (expected about e)``. Each distinct
    case counts once (two designs sharing a case read the same prediction). For a calibrated
    surrogate z (``z_combined``, t's normal score at its degrees of freedom) is standard
    normal: RMS z is about 1, and the worst of n exceeds w with probability
    1 - (1 - 2 Phi(-w))^n. Points of a design share its fill and packings, so they
    are not independent and the true probabilities are smaller; ``-`` without a z.
    """
    from scipy.stats import norm

    z = table.drop_duplicates("case_id")["z_combined"].to_numpy(dtype=float)
    z = z[np.isfinite(z)]
    if z.size == 0:
        return "-"
    worst = float(np.max(np.abs(z)))
    beyond = float(1.0 - (1.0 - 2.0 * norm.sf(worst)) ** z.size)
    tail = 2.0 * norm.sf(flag_z)
    return (f"{z.size} case(s): RMS z {math.sqrt(float(np.mean(z**2))):.2f}; worst |z| {worst:.2f}, "
            f"which the worst of {z.size} independent points of a calibrated surrogate exceeds "
            f"with probability {beyond:.2g}; |z| > {flag_z:g} at {int(np.sum(np.abs(z) > flag_z))} "
            f"(expected about {tail * z.size:.1f})")


def m_eff_off_lines(table: pd.DataFrame) -> list[str]:
    """One line per row where the m_eff surrogate is off (for the rule's log)."""
    return _off_lines(table, "m_eff_off", "m_eff ", "m_eff_dem_kg", "m_eff_dem_sem_kg",
                      "m_eff_surrogate_kg", "m_eff_surrogate_u_kg", "kg", "t_m_eff", "z_m_eff")


def _off_lines(table: pd.DataFrame, flag: str, label: str, dem: str, dem_sem: str,
               surrogate: str, surrogate_u: str, unit: str, t: str, z: str) -> list[str]:
    """``<environment>, <design>, <point> (<case>): DEM <label>x +- s, surrogate y +- u <unit>,
    t = ... (<dof> dof), z = ...`` for every row whose ``flag`` column is set."""
    return [f"{row['environment']}, {row['design']}, {row['point']} ({row['case_id']}): DEM "
            f"{label}{row[dem]:.4g} +- {row[dem_sem]:.2g}, surrogate "
            f"{row[surrogate]:.4g} +- {row[surrogate_u]:.2g} {unit}, t = {row[t]:+.2f} "
            f"({row['dem_dof']:g} dof), z = {row[z]:+.2f}"
            for _, row in table[table[flag]].iterrows()]


def _join(note: str, more: str) -> str:
    return f"{note}; {more}" if note else more
