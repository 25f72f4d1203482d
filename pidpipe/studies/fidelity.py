"""The fidelity study: how far each speed-for-accuracy setting moves C_eq, and what it costs.

Every case of ``fidelity_study.cases`` is shaken at a high-fidelity reference setting
(``fidelity_study.reference``) and at each named variant (``fidelity_study.variants``), all on
the campaign's replicate-0 packing of the case's fill, so that only the shaking run differs.
The reference and the variants are overrides on the campaign's ``fidelity`` section; each
merged config is validated by :func:`pidpipe.config.validate_config`.

For a variant v of a case, the error of its cell's C_eq against the reference is
e = C_v / C_ref - 1, with the standard error propagated to first order from the two runs'
standard errors (independent runs: the trajectories part within a few cycles):
sigma_e = |C_v / C_ref| * sqrt((s_v / C_v)^2 + (s_ref / C_ref)^2).

The summary per variant uses only the *steady* cases: those whose reference run is ``ok`` (no
flag) and whose variant run is ``ok`` too. A case the variant flags or fails is not averaged
in; it is counted and named in the summary, as is every case whose reference is not steady.
"""

from __future__ import annotations

import copy
import logging
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from pidpipe.cases import CaseSpec
from pidpipe.cell.scene import CellScene
from pidpipe.config import validate_config
from pidpipe.config.settings import ShakeSettings
from pidpipe.config.studies import REFERENCE, FidelityStudySettings
from pidpipe.errors import ConfigError
from pidpipe.measurement.case_record import CaseRecord

logger = logging.getLogger("pidpipe.studies.fidelity")

#: Columns of the study's table (results/fidelity/fidelity.csv), in order.
TABLE_COLUMNS: tuple[str, ...] = (
    "case_id", "freq_hz", "accel_g", "fill_pct", "n_spheres", "variant", "label",
    "changes_physics", "status", "flags",
    "dt_s", "dt_rayleigh_fraction", "youngs_modulus_scale", "transient_cycles",
    "measured_cycles", "n_cycles", "rotation", "friction", "steps",
    "ceq_cell_ns_m", "ceq_cell_sem_ns_m", "ceq_ref_ns_m", "ceq_ref_sem_ns_m",
    "reference_status", "reference_flags", "steady", "error_rel", "error_rel_sem",
    "error_over_sem", "energy_drift_fraction", "cpu_time_s", "cpu_rel_baseline", "wall_time_s",
    "record_version", "message",
)

#: Columns of the summary per variant (results/fidelity/fidelity_summary.csv), in order.
SUMMARY_COLUMNS: tuple[str, ...] = (
    "variant", "label", "changes_physics", "dt_rayleigh_fraction", "youngs_modulus_scale",
    "transient_cycles", "transient_min_time_s", "measured_cycles", "rotation", "friction",
    "n_cases", "n_reference_not_steady", "n_used", "n_flagged", "flagged_cases",
    "median_abs_error", "median_abs_error_sem", "max_abs_error", "max_abs_error_sem",
    "max_error_case", "n_beyond_target", "cpu_time_s", "cpu_rel_baseline", "meets_target",
)

#: The fidelity values a variant's summary row shows, as configured.
_KNOBS = ("timestep_rayleigh_fraction", "youngs_modulus_scale", "transient_cycles",
          "transient_min_time_s", "measured_cycles", "rotation", "friction")

#: Table columns from a case record (:func:`_record_values`).
_RECORD_COLUMNS = (
    "n_spheres", "dt_s", "dt_rayleigh_fraction", "youngs_modulus_scale", "transient_cycles",
    "measured_cycles", "n_cycles", "rotation", "friction", "steps", "ceq_cell_ns_m",
    "ceq_cell_sem_ns_m", "energy_drift_fraction", "cpu_time_s", "wall_time_s", "record_version",
)


@dataclass(frozen=True)
class Variant:
    """One setting of the study: the reference or a named variant.

    Attributes
    ----------
    name : str
        ``reference`` or the variant's name.
    label : str
        Legend label.
    changes_physics : bool
        The setting changes the model (friction or rotation off), not just the numerics.
    overrides : dict
        Values that replace the campaign's ``fidelity`` values.
    """

    name: str
    label: str
    changes_physics: bool
    overrides: dict

    def as_params(self) -> dict:
        """Plain, key-sorted dict (a Snakemake parameter)."""
        return {"name": self.name, "label": self.label, "changes_physics": self.changes_physics,
                "overrides": {k: self.overrides[k] for k in sorted(self.overrides)}}


# --------------------------------------------------------------------------------------------
# Building the study from the config


def study_cases(config: dict) -> list[CaseSpec]:
    """The study's cases (replicate 0), in config order.

    Raises
    ------
    ConfigError
        A case is listed twice.
    """
    study = FidelityStudySettings.from_config(config)
    return [CaseSpec(float(c.freq_hz), float(c.accel_g), float(c.fill_pct)) for c in study.cases]


def study_variants(config: dict) -> list[Variant]:
    """The reference, then the variants in config order.

    Raises
    ------
    ConfigError
        A variant is named ``reference``, two share a name, or ``baseline`` names none of them.
    """
    study = FidelityStudySettings.from_config(config)
    return [Variant(REFERENCE, "reference", False, dict(study.reference))] + [
        Variant(v.name, v.label or v.name, v.changes_physics, dict(v.fidelity or {}))
        for v in study.variants]


def _where(variant: Variant, config: dict) -> str:
    """The config key that holds a variant's overrides."""
    return FidelityStudySettings.from_config(config).key_of(variant.name)


def variant_config(config: dict, variant: Variant) -> dict:
    """The campaign's config with a variant's fidelity overrides, validated.

    Only the settings a shaking run depends on may be overridden: the study shakes the
    campaign's packings, so a packing setting (seed, settle_time_s) would change nothing.

    Parameters
    ----------
    config : dict
        Validated config.
    variant : Variant

    Returns
    -------
    dict
        A validated config whose ``fidelity`` holds the overrides.

    Raises
    ------
    ConfigError
        Naming the variant's key: an unknown fidelity key, a value out of bounds, or a setting
        the shaking run does not depend on.
    """
    from pidpipe.config.stages import POURING_KEYS, stage_config

    where = _where(variant, config)
    merged = copy.deepcopy(config)
    merged["fidelity"] = {**config["fidelity"], **copy.deepcopy(variant.overrides)}
    try:
        merged = validate_config(merged)
    except ConfigError as exc:
        raise ConfigError(f"config key {where} (setting {variant.name!r}) is not allowed, after "
                          f"merging into fidelity: {exc}") from None
    # The case stage also reads the pouring keys (a case with a target pours further packings),
    # but the study shakes the campaign's own packings: those keys may not change here.
    shaking = set(stage_config(merged, "case")["fidelity"]) - set(POURING_KEYS)
    for key in sorted(variant.overrides):
        if key not in shaking:
            raise ConfigError(f"config key {where}.{key} is not allowed: the study shakes the "
                              f"campaign's packings, so only the shaking run's settings may "
                              f"change ({', '.join(sorted(shaking))})")
    return merged


@dataclass(frozen=True)
class StudyPlan:
    """Everything the workflow needs to fan the study out.

    Attributes
    ----------
    cases : list of CaseSpec
    variants : list of Variant
        The reference first.
    case_configs : dict
        Setting name -> the case stage's config (:func:`pidpipe.config.stages.stage_config`).
    baseline : str
    error_target : float
        ``fidelity_study.error_target_fraction``.
    """

    cases: list
    variants: list
    case_configs: dict
    baseline: str
    error_target: float

    @property
    def jobs(self) -> list[tuple[str, str]]:
        """(setting name, case id) of every run, the reference's first."""
        return [(v.name, c.case_id) for v in self.variants for c in self.cases]

    @property
    def packing_ids(self) -> list[str]:
        """The packings the study shakes."""
        return sorted({c.packing_id for c in self.cases})


def plan_study(config: dict) -> StudyPlan:
    """Build and validate the study of a validated config.

    Raises
    ------
    ConfigError
        Naming the key of any bad case, variant or override.
    """
    from pidpipe.config.stages import stage_config

    cases = study_cases(config)
    variants = study_variants(config)
    configs = {v.name: stage_config(variant_config(config, v), "case") for v in variants}
    study = FidelityStudySettings.from_config(config)
    return StudyPlan(cases, variants, configs, study.baseline, study.error_target_fraction)


def planned_steps(settings: ShakeSettings, case: CaseSpec) -> int:
    """Time steps of a case's shaking run under its settings (transient and measured cycles).

    The run's cost is about proportional to it (cost ∝ cycles / (f dt)).
    """
    plan = CellScene.of(settings).timestep(case.freq_hz)
    sampling = settings.sampling
    return plan.steps_per_cycle * (sampling.transient_cycles_at(case.freq_hz)
                                   + sampling.measured_cycles)


# --------------------------------------------------------------------------------------------
# Errors and the summary


def relative_error(value, sem, reference, reference_sem) -> tuple[np.ndarray, np.ndarray]:
    """Relative error of values against references, with first-order propagated uncertainty.

    Parameters
    ----------
    value, sem : array_like, shape (n,)
        C_eq of the variant and its standard error (any unit, the same as the reference's).
    reference, reference_sem : array_like, shape (n,)
        C_eq of the reference and its standard error.

    Returns
    -------
    error : ndarray, shape (n,)
        value / reference - 1 (dimensionless; NaN where the reference is not positive).
    error_sem : ndarray, shape (n,)
        |value / reference| * sqrt((sem / value)^2 + (reference_sem / reference)^2), assuming
        independent runs; where the value is 0, sem / reference.
    """
    value, sem = np.asarray(value, dtype=float), np.asarray(sem, dtype=float)
    reference = np.asarray(reference, dtype=float)
    reference_sem = np.asarray(reference_sem, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(reference > 0, value / reference, np.nan)
        ref_rel = reference_sem / reference
        # |r| sqrt((s/v)^2 + (s_ref/ref)^2) = sqrt((s/ref)^2 + (r s_ref/ref)^2): finite at v = 0
        error_sem = np.hypot(sem / reference, ratio * ref_rel)
    return ratio - 1.0, np.where(reference > 0, error_sem, np.nan)


def median_with_sem(values, sems) -> tuple[float, float]:
    """Median of values and the standard error carried by the case(s) it comes from.

    With an odd count the median is one case's value, and its standard error is that case's;
    with an even count it is the mean of the middle two, whose errors combine as
    sqrt(s_a^2 + s_b^2) / 2.

    Returns
    -------
    (float, float)
        (NaN, NaN) for no values.
    """
    values, sems = np.asarray(values, dtype=float), np.asarray(sems, dtype=float)
    n = values.size
    if n == 0:
        return math.nan, math.nan
    order = np.argsort(values, kind="stable")
    if n % 2:
        middle = order[n // 2]
        return float(values[middle]), float(sems[middle])
    a, b = order[n // 2 - 1], order[n // 2]
    return float(0.5 * (values[a] + values[b])), float(0.5 * math.hypot(sems[a], sems[b]))


def summarise_variants(table: pd.DataFrame, variants: list[dict], baseline: str,
                       error_target: float) -> pd.DataFrame:
    """One row per setting (reference included): errors over the steady cases and total cost.

    Parameters
    ----------
    table : pandas.DataFrame
        The study's table (:data:`TABLE_COLUMNS`).
    variants : list of dict
        :meth:`Variant.as_params` of every setting, with ``fidelity`` (the merged values of
        :data:`_KNOBS`) added.
    baseline : str
        The variant CPU totals are relative to.
    error_target : float
        Target for |error| (fraction of C_eq).

    Returns
    -------
    pandas.DataFrame
        :data:`SUMMARY_COLUMNS`. A case is used when both its reference run and the variant's
        run are ``ok`` (``steady``); a case whose reference is ok but whose variant run is
        flagged or failed is counted in ``n_flagged`` and named in ``flagged_cases`` (with its
        flags), never averaged in. ``meets_target``: at least one case used, median |error|
        <= target, no used case with |error| - 2 sem > target (``n_beyond_target``), and no case
        flagged that the baseline ran steady. The reference's own row has no errors.
    """
    baseline_cpu = float(table.loc[table["variant"] == baseline, "cpu_time_s"].sum())
    baseline_ok = set(table.loc[(table["variant"] == baseline) & (table["status"] == "ok"),
                                "case_id"])
    rows = []
    for variant in variants:
        rows_v = table[table["variant"] == variant["name"]]
        ref_ok = rows_v["reference_status"] == "ok"
        used = rows_v[rows_v["steady"].astype(bool)]
        flagged = rows_v[ref_ok & (rows_v["status"] != "ok")]
        abs_error = used["error_rel"].abs().to_numpy(dtype=float)
        abs_sem = used["error_rel_sem"].to_numpy(dtype=float)
        row = {"variant": variant["name"], "label": variant["label"],
               "changes_physics": bool(variant["changes_physics"]),
               "n_cases": int(len(rows_v)), "n_reference_not_steady": int((~ref_ok).sum()),
               "n_used": int(len(used)), "n_flagged": int(len(flagged)),
               "flagged_cases": ";".join(f"{r.case_id}({r.flags or r.status})"
                                         for r in flagged.itertuples()),
               "cpu_time_s": float(rows_v["cpu_time_s"].sum(min_count=1)),
               "cpu_rel_baseline": (float(rows_v["cpu_time_s"].sum(min_count=1)) / baseline_cpu
                                    if baseline_cpu > 0 else math.nan)}
        knobs = variant.get("fidelity", {})
        row.update({("dt_rayleigh_fraction" if k == "timestep_rayleigh_fraction" else k): knobs.get(k)
                    for k in _KNOBS})
        if variant["name"] == REFERENCE or abs_error.size == 0:
            row.update(median_abs_error=math.nan, median_abs_error_sem=math.nan,
                       max_abs_error=math.nan, max_abs_error_sem=math.nan, max_error_case="",
                       n_beyond_target=0, meets_target=False)
            rows.append(row)
            continue
        row["median_abs_error"], row["median_abs_error_sem"] = median_with_sem(abs_error, abs_sem)
        worst = int(np.argmax(abs_error))
        row.update(max_abs_error=float(abs_error[worst]), max_abs_error_sem=float(abs_sem[worst]),
                   max_error_case=str(used["case_id"].iloc[worst]))
        beyond = int(np.sum(abs_error - 2.0 * abs_sem > error_target))
        newly_flagged = set(flagged["case_id"]) & baseline_ok
        row["n_beyond_target"] = beyond
        row["meets_target"] = bool(row["median_abs_error"] <= error_target and beyond == 0
                                   and not newly_flagged)
        rows.append(row)
    return pd.DataFrame(rows, columns=list(SUMMARY_COLUMNS))


# --------------------------------------------------------------------------------------------
# The table from the case records


def _record_values(record: CaseRecord) -> dict:
    """The :data:`_RECORD_COLUMNS` of a case record (None where it has no such value)."""
    fidelity, engine = record.fidelity, record.engine
    return {"n_spheres": record.n_spheres, "dt_s": fidelity.get("timestep_s"),
            "dt_rayleigh_fraction": fidelity.get("rayleigh_fraction"),
            "youngs_modulus_scale": fidelity.get("youngs_modulus_scale"),
            "transient_cycles": fidelity.get("transient_cycles"),
            "measured_cycles": fidelity.get("measured_cycles"), "n_cycles": record.n_cycles,
            "rotation": fidelity.get("rotation"), "friction": fidelity.get("friction"),
            "steps": engine.steps, "ceq_cell_ns_m": record.ceq_cell_ns_m,
            "ceq_cell_sem_ns_m": record.ceq_cell_sem_ns_m,
            "energy_drift_fraction": record.energy_drift_fraction,
            "cpu_time_s": engine.get("liggghts_cpu_time_s"), "wall_time_s": record.wall_time_s,
            "record_version": record.record_version}


def _number(value) -> float:
    return math.nan if value is None else float(value)


def study_table(records: dict, variants: list[dict], baseline: str) -> pd.DataFrame:
    """The study's table: one row per (case, setting), the reference's rows first.

    Parameters
    ----------
    records : dict
        (setting name, case id) -> case record (:func:`pidpipe.liggghts.shake.run_case` or a failed
        record); a missing pair gives a ``missing`` row.
    variants : list of dict
        :meth:`Variant.as_params` of every setting, the reference first.
    baseline : str
        The variant whose CPU time per case ``cpu_rel_baseline`` divides by.

    Returns
    -------
    pandas.DataFrame
        :data:`TABLE_COLUMNS`. ``error_rel`` and ``error_rel_sem`` come from
        :func:`relative_error` on the cell's C_eq; for the reference's own rows the error is 0
        and its uncertainty the reference's relative standard error (how well it is known).
        ``steady`` is true when both the reference and this run have status ``ok``.
        ``error_over_sem`` is error_rel / error_rel_sem.
    """
    case_ids = list(dict.fromkeys(case_id for _, case_id in records))
    rows = []
    for variant in variants:
        for case_id in case_ids:
            record = records.get((variant["name"], case_id))
            row = _record_row(record, case_id)
            row.update(variant=variant["name"], label=variant["label"],
                       changes_physics=bool(variant["changes_physics"]))
            rows.append(row)
    table = pd.DataFrame(rows)
    reference = table[table["variant"] == REFERENCE].set_index("case_id")
    ref_value = table["case_id"].map(reference["ceq_cell_ns_m"])
    ref_sem = table["case_id"].map(reference["ceq_cell_sem_ns_m"])
    table["ceq_ref_ns_m"], table["ceq_ref_sem_ns_m"] = ref_value, ref_sem
    table["reference_status"] = table["case_id"].map(reference["status"]).fillna("missing")
    table["reference_flags"] = table["case_id"].map(reference["flags"]).fillna("")
    error, error_sem = relative_error(table["ceq_cell_ns_m"], table["ceq_cell_sem_ns_m"],
                                      ref_value, ref_sem)
    is_ref = (table["variant"] == REFERENCE).to_numpy()
    with np.errstate(divide="ignore", invalid="ignore"):
        error_sem = np.where(is_ref, ref_sem / ref_value, error_sem)
    error = np.where(is_ref & np.isfinite(error), 0.0, error)
    table["error_rel"], table["error_rel_sem"] = error, error_sem
    with np.errstate(divide="ignore", invalid="ignore"):
        table["error_over_sem"] = np.where(error_sem > 0, error / error_sem, np.nan)
    table["steady"] = (table["status"] == "ok") & (table["reference_status"] == "ok")
    base = table[table["variant"] == baseline].set_index("case_id")["cpu_time_s"]
    with np.errstate(divide="ignore", invalid="ignore"):
        table["cpu_rel_baseline"] = table["cpu_time_s"] / table["case_id"].map(base)
    return table[list(TABLE_COLUMNS)]


def _record_row(record: CaseRecord | None, case_id: str) -> dict:
    """A case record's columns of the study table."""
    case = CaseSpec.from_id(case_id)
    row = {"case_id": case_id, "freq_hz": case.freq_hz, "accel_g": case.accel_g,
           "fill_pct": case.fill_pct}
    if record is None:
        row.update(status="missing", flags="", message="no record")
        row.update({column: math.nan for column in _RECORD_COLUMNS})
        return row
    row.update(status=record.status, flags=";".join(record.flags), message=record.message or "")
    for column, value in _record_values(record).items():
        row[column] = value if isinstance(value, bool) else _number(value)
    if row["status"] == "failed":
        row["ceq_cell_ns_m"] = row["ceq_cell_sem_ns_m"] = math.nan
    return row


# --------------------------------------------------------------------------------------------
# Workflow steps


def variant_params(plan: StudyPlan) -> list[dict]:
    """Every setting as plain dicts for the collect rule: name, label, changes_physics,
    overrides and ``fidelity`` (the merged values of the knobs the summary shows)."""
    params = []
    for variant in plan.variants:
        item = variant.as_params()
        item["fidelity"] = {k: plan.case_configs[variant.name]["fidelity"][k] for k in _KNOBS}
        params.append(item)
    return params


def collect_fidelity_study(record_paths: list[str], jobs: list[list[str]], variants: list[dict],
                           baseline: str, error_target: float, table_path: str,
                           summary_path: str) -> pd.DataFrame:
    """Write the study's table and its summary per variant (CSV, atomically).

    Parameters
    ----------
    record_paths : list of path
        Case records (JSON), one per job; a path that does not exist gives a ``missing`` row.
    jobs : list of [str, str]
        (setting name, case id) of each record path, in the same order.
    variants : list of dict
        :func:`variant_params`.
    baseline : str
    error_target : float
        Fraction of C_eq.
    table_path, summary_path : path

    Returns
    -------
    pandas.DataFrame
        The summary.
    """
    from pidpipe.design.records import read_record
    from pidpipe.files import write_atomic

    if len(record_paths) != len(jobs):
        raise ValueError(f"{len(record_paths)} record paths for {len(jobs)} jobs")
    records = {tuple(job): read_record(path) for job, path in zip(jobs, record_paths)
               if Path(path).is_file()}
    for job in jobs:
        records.setdefault(tuple(job), None)
    table = study_table(records, variants, baseline)
    summary = summarise_variants(table, variants, baseline, error_target)
    write_atomic(table_path, lambda tmp: table.to_csv(tmp, index=False))
    write_atomic(summary_path, lambda tmp: summary.to_csv(tmp, index=False))
    reference = table[table["variant"] == REFERENCE]
    for row in reference[reference["status"] != "ok"].itertuples():
        logger.warning("reference run of %s is %s (%s): the case is left out of every variant's "
                       "summary", row.case_id, row.status, row.flags or row.message)
    for row in summary.itertuples():
        logger.info("%s: median |error| %.3g +- %.2g, max %.3g (%s) over %d steady case(s), %d "
                    "flagged%s; CPU %.1f s (x%.3g of %s)", row.variant, row.median_abs_error,
                    row.median_abs_error_sem, row.max_abs_error, row.max_error_case, row.n_used,
                    row.n_flagged, f" ({row.flagged_cases})" if row.flagged_cases else "",
                    row.cpu_time_s, row.cpu_rel_baseline, baseline)
    return summary


def plot_fidelity_study(table_path: str, summary_path: str, error_target: float, png: str) -> None:
    """The study's figure as PNG and PDF (:func:`pidpipe.figures.fidelity.plot_fidelity`)."""
    from pidpipe.figures.fidelity import plot_fidelity

    table = pd.read_csv(table_path, keep_default_na=False, na_values=[""])
    summary = pd.read_csv(summary_path, keep_default_na=False, na_values=[""])
    plot_fidelity(table, summary, error_target, stem=Path(png).with_suffix(""))
    logger.info("fidelity figure: %s (and PDF)", png)


def summary_markdown(summary: pd.DataFrame) -> list[str]:
    """The summary as Markdown table lines (errors in percent), for a benchmark record's notes (``benchmarks/record_fidelity.py``)."""
    lines = ["| variant | changes physics | steady cases used | flagged | median abs error % | "
             "max abs error % (case) | CPU s | CPU / baseline | meets target |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in summary.itertuples():
        flagged = f"{r.n_flagged}" + (f" ({r.flagged_cases})" if r.n_flagged else "")
        median = (f"{100 * r.median_abs_error:.1f} ± {100 * r.median_abs_error_sem:.1f}"
                  if np.isfinite(r.median_abs_error) else "—")
        worst = (f"{100 * r.max_abs_error:.1f} ± {100 * r.max_abs_error_sem:.1f} ({r.max_error_case})"
                 if np.isfinite(r.max_abs_error) else "—")
        lines.append(f"| {r.variant} | {'yes' if r.changes_physics else 'no'} | {r.n_used} | "
                     f"{flagged} | {median} | {worst} | {r.cpu_time_s:.0f} | "
                     f"{r.cpu_rel_baseline:.2f} | {'yes' if r.meets_target else 'no'} |")
    return lines
