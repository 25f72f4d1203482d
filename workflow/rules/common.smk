# The grid, wildcard constraints and the get_* helpers that the rules use. No rule lives here.

import sys

from pidpipe.cases import CaseSpec
from pidpipe.steps.params import (WILDCARD_NUMBER, WILDCARD_REPLICATE, budget_params,
                                  campaign_cases, campaign_packing_ids, case_packing_ids,
                                  dem_batch_case_ids, dem_batch_constraint, dem_batch_fills,
                                  dem_batch_priority,
                                  pour_batch_constraint, pour_batch_replicates,
                                  environment_params, inspected_cases, map_uncertainty_params,
                                  optimisation_params, verify_case_config, verify_params)
from pidpipe.steps.verify import verify_case_ids
from pidpipe.config.settings import ShakeSettings
from pidpipe.config.stages import sorted_keys, stage_config
from pidpipe.steps import resources as cluster_resources
from pidpipe.studies import fidelity as fidelity_study
from pidpipe.errors import ConfigError


CASES = campaign_cases(config)
PACKING_IDS = campaign_packing_ids(config)
PHASE_FIGURE_CASES, _ignored_figures = inspected_cases(config, "phase_figure_cases")
MOVIE_CASES, _ignored_movies = inspected_cases(config, "movie_cases")
for _key, _ignored in (("phase_figure_cases", _ignored_figures), ("movie_cases", _ignored_movies)):
    if _ignored:
        print(f"pidpipe: inspection.{_key}: not cases of this campaign, ignored: "
              + ", ".join(_ignored), file=sys.stderr)

# Case ids are f{freq}Hz_G{accel}_r{fill}pct_rep{replicate}, numbers as pidpipe.cases writes them.
CASE_PATTERN = "f{freq}Hz_G{accel}_r{fill}pct_rep{replicate}"
PACKING_PATTERN = "r{fill}pct_rep{replicate}"


wildcard_constraints:
    freq=WILDCARD_NUMBER,
    accel=WILDCARD_NUMBER,
    fill=WILDCARD_NUMBER,
    replicate=WILDCARD_REPLICATE,


def get_case_ids():
    """Every case id of the campaign."""
    return [case.case_id for case in CASES]


def get_case_records():
    """The record of every case."""
    return [f"results/cases/{case_id}.json" for case_id in get_case_ids()]


def get_packings():
    """The packing of every fill level and replicate."""
    return [f"results/packings/{packing_id}.json" for packing_id in PACKING_IDS]


def get_case_packings(wildcards):
    """The packings a simulate_case job shakes, one per cell of its run (fidelity.cells_per_run)."""
    case = CaseSpec.from_id(get_case_id(wildcards))
    return [f"results/packings/{packing_id}.json"
            for packing_id in case_packing_ids(config, case)]


def get_cells_per_run():
    return int(config["fidelity"]["cells_per_run"])


def get_case_id(wildcards):
    """The case id of a simulate_case job."""
    return CASE_PATTERN.format(**wildcards)


def get_case_runtime_min(wildcards, attempt):
    """The time limit of a simulate_case job, minutes: its planned steps (pidpipe.steps.resources)."""
    case = CaseSpec.from_id(get_case_id(wildcards))
    settings = ShakeSettings.from_config(stage_config(config, "case"))
    return cluster_resources.case_runtime_min(settings, case, attempt)


# The DEM's cases of one frequency, acceleration and replicate share a job (simulate_dem_cases):
# its start-up costs more than a short DEM case. With LIGGGHTS its pattern matches nothing.
DEM_BATCH_FILLS = dem_batch_fills(config)
DEM_BATCH_FREQ = dem_batch_constraint(config)


def get_dem_batch_case_ids(wildcards):
    """The case ids of a simulate_dem_cases job, one per grid fill."""
    return dem_batch_case_ids(config, wildcards.freq, wildcards.accel, wildcards.replicate)


def get_dem_batch_packings_by_case(wildcards):
    """Each case's packings of a simulate_dem_cases job (a list per case)."""
    return [[f"results/packings/{packing_id}.json"
             for packing_id in case_packing_ids(config, CaseSpec.from_id(case_id))]
            for case_id in get_dem_batch_case_ids(wildcards)]


def get_dem_batch_packings(wildcards):
    """Every packing a simulate_dem_cases job shakes."""
    return [path for paths in get_dem_batch_packings_by_case(wildcards) for path in paths]


def get_dem_batch_workdirs(wildcards):
    return [f"results/work/cases/{case_id}" for case_id in get_dem_batch_case_ids(wildcards)]


def get_dem_batch_movies(wildcards):
    """Each case's movie settings ({} unless in inspection.movie_cases)."""
    return [get_case_movie({"freq": wildcards.freq, "accel": wildcards.accel, "fill": fill,
                            "replicate": wildcards.replicate}) for fill in DEM_BATCH_FILLS]


def get_dem_batch_runtime_min(wildcards, attempt):
    """The time limit of a simulate_dem_cases job, minutes: its cases' limits summed."""
    settings = ShakeSettings.from_config(stage_config(config, "case"))
    return sum(cluster_resources.case_runtime_min(settings, CaseSpec.from_id(case_id), attempt)
               for case_id in get_dem_batch_case_ids(wildcards))


def get_dem_batch_priority(wildcards):
    """A simulate_dem_cases job's priority (pidpipe.steps.params.dem_batch_priority)."""
    return dem_batch_priority(config, get_dem_batch_case_ids(wildcards))


# The DEM's pours of one grid fill share a job (pour_dem_packings): one process's start-up, and
# one batched pour. With the LIGGGHTS pour its pattern matches nothing (a job per packing).
POUR_BATCH_FILL = pour_batch_constraint(config)
POUR_BATCH_REPLICATES = pour_batch_replicates(config)


def get_pour_batch_workdirs(wildcards):
    """The engine folder of each packing of a pour_dem_packings job (unused by the DEM)."""
    return [f"results/work/packings/r{wildcards.fill}pct_rep{replicate}"
            for replicate in POUR_BATCH_REPLICATES]


def get_packing_config():
    """The config values a packing depends on."""
    return stage_config(config, "packing")


def get_case_config():
    """The config values a case depends on (its packing is an input)."""
    return stage_config(config, "case")


def get_surrogate_method():
    return config["surrogate"]["method"]


def get_surrogate_allow_holes():
    return config["surrogate"]["allow_holes"]


def get_ceq_table():
    """The table the surrogate is fitted to: optimisation.external_ceq_table, else the campaign's."""
    return config["optimisation"]["external_ceq_table"] or "results/ceq_table.csv"


def get_environments():
    return environment_params(config)


def get_budget():
    return budget_params(config)


def get_optimisation_params():
    """What the designs depend on: config optimisation without the table's path (an input)."""
    return optimisation_params(config)


def get_map_uncertainty_params():
    """The bootstrap draws and seed of the maps' uncertainty panels."""
    return map_uncertainty_params(config)


def get_final_targets():
    """What `snakemake` builds: the campaign's case records and table (unless an external table is
    used), then the surrogate, its cross-validation, the optimum and the figures. The records
    are targets themselves, so that a deleted record is recomputed."""
    targets = [
        "results/surrogate.json",
        "results/surrogate_cv.csv",
        "results/optimum.csv",
        "results/figures/ceq_freq_fill.png",
        "results/figures/ceq_freq_accel.png",
        "results/figures/convergence.png",
        "results/figures/optimum_spread.png",
    ]
    if config["optimisation"]["external_ceq_table"] is None:
        targets = get_case_records() + ["results/ceq_table.csv"] + targets + get_phase_figures()
    return targets


def get_dem_check_records():
    """The compiled DEM's record of every case of the campaign (`snakemake validate`)."""
    return [f"results/validation/dem/{case_id}.json" for case_id in get_case_ids()]


def get_phase_figures():
    """The phase-resolved figures of the report's gallery (inspection.phase_figure_cases)."""
    if config["inspection"]["phase_windows_per_cycle"] == 0:
        return []
    return [f"results/figures/phase/{case_id}.png" for case_id in PHASE_FIGURE_CASES]


def get_case_movie(wildcards):
    """The movie settings of a simulate_case job: {} unless its case is in inspection.movie_cases."""
    case_id = get_case_id(wildcards)
    if case_id not in MOVIE_CASES:
        return {}
    return {"frames_per_cycle": config["inspection"]["movie_frames_per_cycle"],
            "cycles": config["inspection"]["movie_cycles"],
            "directory": f"results/movies/{case_id}"}


def get_validation_cases():
    """The cases of `snakemake validate` (validation.cases)."""
    return config["validation"]["cases"]


def get_validation_packings():
    """The replicate-0 packing of every fill in validation.cases."""
    fills = sorted({CaseSpec(1.0, 1.0, float(c["fill_pct"])).packing_id
                    for c in config["validation"]["cases"]})
    return [f"results/packings/{packing_id}.json" for packing_id in fills]


# The designs' check by DEM (workflow/rules/verify.smk): its cases follow from the designs
# (checkpoint plan_verify).


def get_fill_config():
    """The config's fill section (spheres per full cell)."""
    return sorted_keys(config["fill"])


def get_verify_params():
    return verify_params(config)


def get_verify_case_config():
    """The case stage's config of a verifying case (engine: verify.engine)."""
    return verify_case_config(config)


def _verify_case_ids():
    return verify_case_ids(checkpoints.plan_verify.get().output.points)


def get_verify_records(wildcards):
    """The record of every distinct verifying case."""
    return [f"results/verify/cases/{case_id}.json" for case_id in _verify_case_ids()]


def get_verify_case_packings(wildcards):
    """The packings a simulate_verify_case job shakes, one per cell of its run."""
    case = CaseSpec.from_id(get_case_id(wildcards))
    return [f"results/verify/packings/{packing_id}.json"
            for packing_id in case_packing_ids(config, case)]


def get_verify_case_packing_checks(wildcards):
    """The check of each packing a simulate_verify_case job shakes."""
    return [path.replace(".json", ".check.tsv") for path in get_verify_case_packings(wildcards)]


def get_verify_case_runtime_min(wildcards, attempt):
    """The time limit of a simulate_verify_case job, minutes (pidpipe.steps.resources)."""
    case = CaseSpec.from_id(get_case_id(wildcards))
    settings = ShakeSettings.from_config(verify_case_config(config))
    return cluster_resources.case_runtime_min(settings, case, attempt)


# The fidelity study (workflow/rules/fidelity.smk): planned and validated here, so that a bad
# reference or variant stops every run before any job, naming its key.

try:
    FIDELITY_STUDY = fidelity_study.plan_study(config)
except ConfigError as error:
    sys.exit(f"pidpipe: invalid config: {error}")

def get_fidelity_records():
    """The record of every (setting, case) of the study, the reference's first."""
    return [f"results/fidelity/cases/{variant}/{case_id}.json"
            for variant, case_id in FIDELITY_STUDY.jobs]


def get_fidelity_jobs():
    """(setting, case id) of each record of get_fidelity_records(), in the same order."""
    return [[variant, case_id] for variant, case_id in FIDELITY_STUDY.jobs]


def get_fidelity_case_config(wildcards):
    """The case stage's config of one setting (reference or variant)."""
    return FIDELITY_STUDY.case_configs[wildcards.variant]


def get_fidelity_priority(wildcards):
    """Planned time steps of a run, in millions: the costliest runs start first."""
    case = CaseSpec.from_id(get_case_id(wildcards))
    settings = ShakeSettings.from_config(FIDELITY_STUDY.case_configs[wildcards.variant])
    return fidelity_study.planned_steps(settings, case) / 1e6


def get_fidelity_variants():
    """Every setting's name, label, overrides and merged knob values (for the summary)."""
    return fidelity_study.variant_params(FIDELITY_STUDY)


# The scene study (workflow/rules/scene.smk).


def get_scene_config():
    """The config values the scene study depends on: a packing's and a case's, and scene."""
    packing = stage_config(config, "packing")
    case = stage_config(config, "case")
    return {**packing, **case, "fidelity": {**packing["fidelity"], **case["fidelity"]},
            "scene": config["scene"]}
