"""Which surrogate to use on a real C_eq table: cross-validation of the GP against the splines
(issue 26), and the GP's calibration on synthetic tables of known truth.

On the table (``results/ceq_table.csv`` of a campaign): every case that the fit policy keeps
(:func:`pidpipe.design.fit_policy.split_for_fit`: flagged-for-precision cases included, failed
checks dropped) is held out in turn (leave-one-point-out) and predicted by each candidate
fitted to the rest:

- ``gp`` (log target, the default; asinh and linear targets), fitted to the policy's rows;
- ``rbf_thin_plate`` (log target) fitted to the status-ok rows only (the current default: it
  bridges the flagged cases) and to the policy's rows (interpolating them exactly);
- every method in the leave-one-plane-out scheme, on the policy's rows.

Each error is divided by the held-out case's SEM: a perfect predictor scores an RMS of 1 (the
case's own noise), more is the surrogate's error. For the GP, the z-scores of the held-out
values against its predictive uncertainty, its fitted excess scatter and the case's SEM (in the
transformed target, where the GP is Gaussian) should have mean 0 and standard deviation 1;
also printed by status (ok / flagged), and the fraction inside the 68.3 % and 95 % intervals.
Last, the prediction of each candidate at the verify points (450-500 Hz / 1 g) next to the
table's cases at 500 Hz / 1 g.

With ``--synthetic N``: N tables on the table's (f, G, r) grid with a known analytic truth
(C_eq ~ f^1.1, a steep rise above 1 g, a fill optimum) and the table's own relative SEMs per
case (the noise the DEM reported), each fitted from scratch; the coverage of the GP's latent
68.3 % and 95 % intervals of the truth at the grid points and at random off-grid points, with
the scatter of the mean coverage from the spread between tables; off-grid also split into the
points between 1 and 5 g and above 5 g, and into every interval between neighbouring G levels of
the grid (``off_G<lo>-<hi>``: a pooled off-grid figure can hide intervals too narrow in one band
and too wide in another). ``--onset-g`` moves the truth's onset (default 0.5 g: the truth is
exactly zero, and so is its SEM, at a 0.5 g level; 0.25 g makes it positive there).

Run: .venv/bin/python benchmarks/compare_surrogates.py results/ceq_table.csv [--synthetic 40]
[--onset-g 0.5]
(the default campaign's DEM table is committed: tests/fixtures/ceq_table_dem_default.csv)
Writes benchmarks/records/compare_surrogates.json.
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import os
import platform
import time
from pathlib import Path

import numpy as np
import pandas as pd

from pidpipe.design.ceq_table import COORDINATE_COLUMNS, SEM_COLUMN, VALUE_COLUMN, read_ceq_table
from pidpipe.design.fit_policy import split_for_fit
from pidpipe.design.surrogate import fit_surrogate, loo_predictions

RECORD = Path(__file__).resolve().parent / "records" / "compare_surrogates.json"

#: (label, method, target, log offset fraction, rows fitted) of the leave-one-point-out
#: comparison; the held-out rows are always the fit policy's.
POINT_CANDIDATES = (
    ("gp log (default)", "gp", "log", 1e-3, "policy"),
    ("gp asinh", "gp", "asinh", 1e-3, "policy"),
    ("gp linear", "gp", "linear", 1e-3, "policy"),
    ("rbf_thin_plate log, ok rows", "rbf_thin_plate", "log", 1e-3, "ok"),
    ("rbf_thin_plate log, policy rows", "rbf_thin_plate", "log", 1e-3, "policy"),
)
#: (label, method, target, log offset fraction) of the leave-one-plane-out comparison.
PLANE_CANDIDATES = (
    ("gp log (default)", "gp", "log", 1e-3),
    ("gp asinh", "gp", "asinh", 1e-3),
    ("rbf_thin_plate log", "rbf_thin_plate", "log", 1e-3),
    ("tensor_spline log", "tensor_spline", "log", 1e-3),
    ("tensor_linear log", "tensor_linear", "log", 1e-3),
)


def summary(points: pd.DataFrame) -> dict:
    """Figures of one candidate's held-out predictions."""
    per_sem = ((points["predicted"] - points["value"]) / points["sem"]).to_numpy(dtype=float)
    per_sem = per_sem[np.isfinite(per_sem)]
    relative = (np.abs(points["predicted"] - points["value"])
                / np.maximum(np.abs(points["value"]), 1e-3 * points["value"].abs().max()))
    out = {"n_predictions": int(len(points)),
           "rms_error_per_sem": float(np.sqrt(np.mean(per_sem**2))),
           "median_abs_error_per_sem": float(np.median(np.abs(per_sem))),
           "rms_rel_error": float(np.sqrt(np.mean(relative**2)))}
    if "z" in points.columns:
        z = points["z"].to_numpy(dtype=float)
        out.update(z_mean=float(z.mean()), z_std=float(z.std(ddof=1)),
                   coverage_68=float(points["in_68"].mean()), coverage_95=float(points["in_95"].mean()))
        if "status" in points.columns:
            out["z_std_by_status"] = {str(k): {"n": int(len(g)), "z_mean": float(g["z"].mean()),
                                               "z_std": float(g["z"].std(ddof=1)) if len(g) > 1 else None}
                                      for k, g in points.groupby("status")}
    return out


def compare_on_table(table: pd.DataFrame) -> dict:
    """The cross-validation figures of every candidate (module docstring)."""
    figures: dict = {"point": {}, "plane": {}}
    for label, method, target, fraction, fit_rows in POINT_CANDIDATES:
        start = time.process_time()
        points = loo_predictions(table, method, target, "point", rows="policy", fit_rows=fit_rows,
                                 log_offset_fraction=fraction)
        figures["point"][label] = {**summary(points), "cpu_s": time.process_time() - start}
        print(f"  {label}: {len(points)} held-out predictions, {figures['point'][label]['cpu_s']:.0f} CPU-s",
              flush=True)
    for label, method, target, fraction in PLANE_CANDIDATES:
        points = loo_predictions(table, method, target, "plane", rows="policy",
                                 log_offset_fraction=fraction)
        figures["plane"][label] = summary(points) if len(points) else {"n_predictions": 0}
    return figures


def verify_points(table: pd.DataFrame) -> dict:
    """Each candidate's prediction at 450-500 Hz / 1 g (the verify points) and the table's cases
    at 500 Hz / 1 g."""
    out = {"cases_500hz_1g": [], "predictions": {}}
    at = table[(table["freq_hz"] == 500.0) & (table["accel_g"] == 1.0)]
    for _, row in at.iterrows():
        out["cases_500hz_1g"].append({"fill_pct": float(row["fill_pct"]), "value": float(row[VALUE_COLUMN]),
                                      "sem": float(row[SEM_COLUMN]), "status": row.get("status"),
                                      "flags": None if pd.isna(row.get("flags")) else row.get("flags")})
    f = np.array([450.0, 475.0, 500.0])
    for label, kwargs in (("gp log (default)", {"method": "gp"}),
                          ("rbf_thin_plate log, ok rows", {"method": "rbf_thin_plate", "allow_holes": True})):
        surrogate = fit_surrogate(table, allow_holes=True, **{k: v for k, v in kwargs.items() if k != "allow_holes"})
        rows = []
        for fill in sorted(at["fill_pct"].unique()):
            try:
                if surrogate.method == "gp":
                    value, u = surrogate.predict_with_uncertainty(f, 1.0, fill)
                else:
                    value, u = surrogate.predict(f, 1.0, fill), np.full(f.shape, np.nan)
            except Exception as exc:  # outside the domain of the ok rows
                rows.append({"fill_pct": float(fill), "error": str(exc)})
                continue
            rows.append({"fill_pct": float(fill), "freq_hz": f.tolist(), "value": np.round(value, 4).tolist(),
                         "u": np.round(u, 4).tolist()})
        out["predictions"][label] = rows
    return out


#: G (g) at which the synthetic truth's onset starts (its C_eq is 0 there).
ONSET_G = 0.5


def synthetic_truth(f, g, r, scale, onset_g=ONSET_G):
    """Analytic C_eq, N*s/m (test_surrogate_gp's truth times scale / 80; zero at ``onset_g``)."""
    return (scale * (f / 100.0) ** 1.1 * (1.0 - np.exp(-(g - onset_g) / 3.0)) * (r / 100.0)
            * np.exp(-r / 120.0))


def level_intervals(levels) -> list[tuple[float, float]]:
    """(lo, hi) of every interval between neighbouring grid levels, ascending."""
    levels = np.unique(np.asarray(levels, dtype=float))
    return list(zip(levels[:-1], levels[1:]))


def synthetic_coverage(table: pd.DataFrame, n_tables: int, n_off: int = 60, seed: int = 7,
                       onset_g: float = ONSET_G) -> dict:
    """Coverage of the GP's intervals of a known truth on the table's grid, with its relative SEMs."""
    grid = table[list(COORDINATE_COLUMNS)].drop_duplicates().reset_index(drop=True)
    kept, _ = split_for_fit(table, VALUE_COLUMN, SEM_COLUMN)
    relative = (kept[SEM_COLUMN] / kept[VALUE_COLUMN].abs()).replace([np.inf], np.nan)
    by_point = dict(zip(map(tuple, kept[list(COORDINATE_COLUMNS)].to_numpy()), relative))
    fallback = float(np.nanmedian(relative))
    rel = np.array([by_point.get(tuple(p), fallback) for p in grid.to_numpy()], dtype=float)
    rel = np.clip(np.nan_to_num(rel, nan=fallback), 0.01, 1.0)  # a case at ~0 C_eq has no relative SEM
    # the truth's scale: the table's largest value
    scale = float(kept[VALUE_COLUMN].max()) / float(synthetic_truth(
        *(grid[c].to_numpy() for c in COORDINATE_COLUMNS), 1.0, onset_g).max())
    exact_grid = synthetic_truth(*(grid[c].to_numpy() for c in COORDINATE_COLUMNS), scale, onset_g)
    lo = {c: grid[c].min() for c in COORDINATE_COLUMNS}
    hi = {c: grid[c].max() for c in COORDINATE_COLUMNS}
    rng = np.random.default_rng(seed)
    bands = {f"off_G{lo:g}-{hi:g}": (lo, hi) for lo, hi in level_intervals(grid["accel_g"])}
    keys = [(w, lv) for w in ("grid", "off", "off_low_g", "off_high_g", *bands)
            for lv in (0.6827, 0.95)]
    coverage = {k: [] for k in keys}
    for k in range(n_tables):
        noisy = grid.copy()
        sem = rel * exact_grid
        noisy[VALUE_COLUMN] = exact_grid + sem * np.random.default_rng(1000 + k).standard_normal(len(grid))
        noisy[SEM_COLUMN] = sem
        # as the measurement flags them: within 2 SEM of zero is not_resolved (a negative
        # mean is allowed in a flagged row only)
        unresolved = noisy[VALUE_COLUMN] <= 2.0 * sem
        noisy["status"] = np.where(unresolved, "flagged", "ok")
        noisy["flags"] = np.where(unresolved, "not_resolved", "")
        surrogate = fit_surrogate(noisy, method="gp")
        off = (np.exp(rng.uniform(np.log(lo["freq_hz"]), np.log(hi["freq_hz"]), n_off)),
               rng.uniform(lo["accel_g"], hi["accel_g"], n_off), rng.uniform(lo["fill_pct"], hi["fill_pct"], n_off))
        low = (off[1] >= 1.0) & (off[1] < 5.0)   # the lift-off transition, 1 to 5 g
        where = {"grid": tuple(grid[c].to_numpy() for c in COORDINATE_COLUMNS), "off": off,
                 "off_low_g": tuple(a[low] for a in off), "off_high_g": tuple(a[off[1] >= 5.0] for a in off)}
        for name, (g_lo, g_hi) in bands.items():
            inside = (off[1] >= g_lo) & (off[1] < g_hi)
            where[name] = tuple(a[inside] for a in off)
        for name, level in keys:
            if where[name][0].size == 0:
                continue
            lower, upper = surrogate.predict_interval(*where[name], level=level)
            exact = synthetic_truth(*where[name], scale, onset_g)
            coverage[(name, level)].append((int(np.sum((exact >= lower) & (exact <= upper))), exact.size))
    out = {}
    for (name, level), counts in coverage.items():
        if not counts:
            continue
        hits, sizes = np.array(counts, dtype=float).T
        fractions = hits[sizes > 0] / sizes[sizes > 0]
        out[f"{name}_{round(100 * level)}"] = {
            "nominal": level, "coverage": float(hits.sum() / sizes.sum()),
            "scatter_between_tables": float(fractions.std(ddof=1) / np.sqrt(fractions.size)),
            "binomial_scatter_pooled": float(np.sqrt(level * (1 - level) / sizes.sum())),
            "tables": int(len(counts)), "points": int(sizes.sum())}
    return out


def print_report(figures: dict) -> None:
    print("Leave-one-point-out on the fit policy's rows (errors divided by each case's SEM):")
    print(f"{'candidate':34s} {'n':>4s} {'rms e/SEM':>10s} {'med |e|/SEM':>11s} {'rms rel':>8s} "
          f"{'z mean':>7s} {'z std':>6s} {'in 68%':>7s} {'in 95%':>7s}")
    for scheme in ("point", "plane"):
        if scheme == "plane":
            print("Leave-one-plane-out (interior levels), policy rows:")
        for label, row in figures[scheme].items():
            if not row.get("n_predictions"):
                print(f"{label:34s}    0 (no fold could be fitted)")
                continue
            z = (f"{row['z_mean']:7.2f} {row['z_std']:6.2f} {row['coverage_68']:7.2f} {row['coverage_95']:7.2f}"
                 if "z_std" in row else "")
            print(f"{label:34s} {row['n_predictions']:4d} {row['rms_error_per_sem']:10.2f} "
                  f"{row['median_abs_error_per_sem']:11.2f} {row['rms_rel_error']:8.3f} {z}")
    for label, row in figures["point"].items():
        for status, part in row.get("z_std_by_status", {}).items():
            print(f"  {label}, {status} cases: n {part['n']}, z mean {part['z_mean']:.2f}, "
                  f"z std {part['z_std'] if part['z_std'] is None else round(part['z_std'], 2)}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("table", type=Path, help="a campaign's results/ceq_table.csv")
    parser.add_argument("--synthetic", type=int, default=0, help="synthetic tables for the coverage (0: none)")
    parser.add_argument("--onset-g", type=float, default=ONSET_G,
                        help="G (g) where the synthetic truth is zero (default %(default)s)")
    args = parser.parse_args()
    table = read_ceq_table(args.table)
    kept, dropped = split_for_fit(table, VALUE_COLUMN, SEM_COLUMN)
    status = table["status"].value_counts().to_dict() if "status" in table.columns else {}
    print(f"{args.table.name}: {len(table)} rows, status {status}; the fit policy keeps {len(kept)}, "
          f"drops {len(dropped)}" + (": " + "; ".join(sorted(set(dropped["drop_reason"]))) if len(dropped) else ""))
    figures = {"table": {"rows": len(table), "status": status, "policy_kept": len(kept),
                         "policy_dropped": {str(k): int(v) for k, v in dropped["drop_reason"].value_counts().items()}}}
    figures.update(compare_on_table(table))
    print_report(figures)
    figures["verify_points"] = verify_points(table)
    print("At 450-500 Hz / 1 g:", json.dumps(figures["verify_points"], indent=None))
    if args.synthetic:
        figures["synthetic_coverage"] = synthetic_coverage(table, args.synthetic, onset_g=args.onset_g)
        figures["synthetic_onset_g"] = args.onset_g
        print(f"GP coverage of a known truth (onset at {args.onset_g:g} g) on {args.synthetic} "
              "synthetic tables (the table's grid and relative SEMs):")
        for key, row in figures["synthetic_coverage"].items():
            print(f"  {key}: {row['coverage']:.3f} of {row['points']} (nominal {row['nominal']:.3f}; scatter between tables "
                  f"{row['scatter_between_tables']:.3f}, binomial {row['binomial_scatter_pooled']:.3f})")
    # the table by its place in a campaign folder and its digest, not by this machine's path
    repo = Path(__file__).resolve().parent.parent
    if args.table.resolve().is_relative_to(repo):
        shown = str(args.table.resolve().relative_to(repo))
    else:
        shown = "results/ceq_table.csv" if args.table.parent.name == "results" else args.table.name
    command = " ".join(["python benchmarks/compare_surrogates.py", shown]
                       + (["--synthetic", str(args.synthetic)] if args.synthetic else [])
                       + (["--onset-g", f"{args.onset_g:g}"] if args.onset_g != ONSET_G else []))
    figures["table"]["sha256"] = hashlib.sha256(args.table.read_bytes()).hexdigest()
    record = {"benchmark": "compare_surrogates",
              "command": command,
              "machine": {"host": platform.node(), "cpus": os.cpu_count(),
                          "python": platform.python_version(), "platform": platform.platform()},
              "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
              "figures": figures}
    RECORD.parent.mkdir(exist_ok=True)
    RECORD.write_text(json.dumps(record, indent=1, default=str) + "\n")
    print(f"written {RECORD.relative_to(Path(__file__).resolve().parent.parent)}")


if __name__ == "__main__":
    main()
