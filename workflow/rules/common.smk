# The grid, wildcard constraints, the settings and the get_* helpers that the rules use. No rule
# lives here. The config is parsed once (SETTINGS, pidpipe.config.sections.Settings); the rules'
# params are plain values built by pidpipe.steps.params, the same as the finished jobs recorded.

import sys

from pidpipe.cases import CaseSpec
from pidpipe.steps.params import (WILDCARD_NUMBER, WILDCARD_REPLICATE, campaign_cases,
                                  campaign_packing_ids, case_movie_params, case_packing_ids,
                                  ceq_table_path, dem_batch_case_ids, dem_batch_fills,
                                  dem_batch_priority, fill_params, host_params, inspected_cases,
                                  m_eff_figure_paths, m_eff_surrogate_paths,
                                  map_uncertainty_params, phase_figure_targets,
                                  pour_batch_fill_pattern, pour_batch_replicates,
                                  refine_params, scene_params,
                                  validation_packing_ids, verify_case_config, workflow_settings)
from pidpipe.steps.verify import verify_case_ids
from pidpipe.config.settings import ShakeSettings
from pidpipe.config.derived import full_cell_spheres
from pidpipe.config.pilots import grid_case_config
from pidpipe.config.stages import stage_config
from pidpipe.steps import resources as cluster_resources
from pidpipe.studies import fidelity as fidelity_study
from pidpipe.errors import ConfigError
from pidpipe.config.panel import panel_check_params, panel_params
from pidpipe.config.refine import RefineSettings
from pidpipe.steps.refine import read_step


try:
    SETTINGS = workflow_settings(config)
    REFINE = RefineSettings.from_config(config)
except ConfigError as error:
    sys.exit(f"pidpipe: invalid config: {error}")
CASES = campaign_cases(config)
PACKING_IDS = campaign_packing_ids(config)
PHASE_FIGURE_CASES, _ignored_figures = inspected_cases(config, "phase_figure_cases")
MOVIE_CASES, _ignored_movies = inspected_cases(config, "movie_cases")
for _key, _ignored in (("phase_figure_cases", _ignored_figures), ("movie_cases", _ignored_movies)):
    if _ignored:
        print(f"pidpipe: inspection.{_key}: not cases of this campaign, ignored: "
              + ", ".join(_ignored), file=sys.stderr)

# Case ids are f{freq}Hz_G{accel}_r{fill}pct_rep{replicate}, numbers as pidpipe.cases writes
# them; a packing's id is the case id's fill and replicate. Every rule spells its paths with these.
PACKING_PATTERN = "r{fill}pct_rep{replicate}"
CASE_PATTERN = "f{freq}Hz_G{accel}_" + PACKING_PATTERN


wildcard_constraints:
    freq=WILDCARD_NUMBER,
    accel=WILDCARD_NUMBER,
    fill=WILDCARD_NUMBER,
    replicate=WILDCARD_REPLICATE,


def get_case_ids():
    """Every case id of the campaign."""
    return [case.case_id for case in CASES]


def get_full_cell_spheres():
    """Spheres in a cell at 100 % fill: the table places each row at the fill its cells hold."""
    return full_cell_spheres(config)


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
    return SETTINGS.sampling.cells_per_run


def get_case_id(wildcards):
    """The case id of a simulate_case job."""
    return CASE_PATTERN.format(**wildcards)


def get_case_runtime_min(wildcards, attempt):
    """The time limit of a simulate_case job, minutes: its planned steps (pidpipe.steps.resources)."""
    case = CaseSpec.from_id(get_case_id(wildcards))
    settings = ShakeSettings.from_config(get_case_config(wildcards))
    return cluster_resources.case_runtime_min(settings, case, attempt)


# engine: dem: the DEM's cases of one frequency, acceleration and replicate share a job
# (simulate_dem_cases, workflow/rules/simulate_dem.smk): its start-up costs more than a short
# DEM case.
DEM_BATCH_FILLS = dem_batch_fills(config)


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
    return [case_movie_params(SETTINGS.inspection, case_id, MOVIE_CASES)
            for case_id in get_dem_batch_case_ids(wildcards)]


def get_dem_batch_runtime_min(wildcards, attempt):
    """The time limit of a simulate_dem_cases job, minutes: its cases' limits summed."""
    settings = ShakeSettings.from_config(get_case_config(wildcards))
    return sum(cluster_resources.case_runtime_min(settings, CaseSpec.from_id(case_id), attempt)
               for case_id in get_dem_batch_case_ids(wildcards))


def get_dem_batch_priority(wildcards):
    """A simulate_dem_cases job's priority (pidpipe.steps.params.dem_batch_priority)."""
    return dem_batch_priority(config, get_dem_batch_case_ids(wildcards))


# fidelity.pour_engine: dem: the DEM's pours of one grid fill share a job (pour_dem_packings,
# workflow/rules/pour_dem.smk): one process's start-up, and one batched pour.
POUR_BATCH_FILL = pour_batch_fill_pattern(config)
POUR_BATCH_REPLICATES = pour_batch_replicates(config)


def get_pour_batch_workdirs(wildcards):
    """The engine folder of each packing of a pour_dem_packings job (unused by the DEM)."""
    return ["results/work/packings/" + PACKING_PATTERN.format(fill=wildcards.fill,
                                                              replicate=replicate)
            for replicate in POUR_BATCH_REPLICATES]


def get_simulate_rules():
    """The rule file that shakes the campaign's cases with the configured engine
    (workflow/rules/simulate_liggghts.smk or simulate_dem.smk)."""
    return f"workflow/rules/simulate_{SETTINGS.engine}.smk"


def get_pour_rules():
    """The rule files that pour the campaign's packings besides pour_packing (one a job, every
    engine): with fidelity.pour_engine dem, workflow/rules/pour_dem.smk batches each grid fill."""
    return ["workflow/rules/pour_dem.smk"] if SETTINGS.pouring.engine == "dem" else []


def get_packing_config():
    """The config values a packing depends on."""
    return stage_config(config, "packing")


def get_case_config(wildcards):
    """The config values the grid's cases at a frequency and acceleration depend on (their
    packings are inputs): the pilot's measured cycles are the point's (pidpipe.config.pilots)."""
    return grid_case_config(config, float(wildcards.freq), float(wildcards.accel))


def get_fresh_case_config():
    """The config values of a case run afresh at the configured fidelity (validate_chosen)."""
    return stage_config(config, "case")


def get_surrogate_method():
    return SETTINGS.surrogate.method


def get_surrogate_allow_holes():
    return SETTINGS.surrogate.allow_holes


def get_ceq_table():
    """The table the surrogate is fitted to: optimisation.external_ceq_table, else the
    refinement loop's (refine.enabled), else the campaign's."""
    return ceq_table_path(SETTINGS.optimisation, refining())


def refining():
    """Whether the campaign runs the refinement loop (refine.enabled, no external table)."""
    return REFINE.enabled and SETTINGS.optimisation.external_ceq_table is None


def get_refine_params():
    """What the loop's steps and runs depend on (their scripts read the whole config)."""
    return refine_params(config)


def get_refine_step_inputs(wildcards):
    """Step n's inputs: the campaign's table, and for n > 1 step n - 1's file and the records
    of the runs it named (Snakemake runs them first)."""
    step = int(wildcards.step)
    if step == 1:
        return {"table": "results/ceq_table.csv"}
    previous = checkpoints.refine_step.get(step=step - 1).output.step
    runs = read_step(previous).get("runs", [])
    return {"table": "results/ceq_table.csv", "previous": previous,
            "records": [f"results/refine/work/cases/{run}.json" for run in runs]}


def refine_runs_in_step():
    """Whether the loop's step runs its cases itself (refine.run_cases; auto: engine dem)."""
    return REFINE.runs_in_step(SETTINGS.engine)


def get_refine_step_threads(wildcards):
    """A step's cores: all of the campaign's when it runs the loop's cases, else one."""
    return workflow.cores if refine_runs_in_step() else 1


def get_refine_step_runtime_min(wildcards, attempt, threads):
    """The time limit of a refine_step job, minutes (pidpipe.steps.resources)."""
    return cluster_resources.refine_step_runtime_min(
        REFINE.max_cpu_s, REFINE.max_rounds, threads, refine_runs_in_step(), attempt)


def get_refine_run_runtime_min(wildcards, attempt):
    """The time limit of a run_refine_case job, minutes: its plan's planned CPU
    (pidpipe.steps.resources.refine_run_runtime_min); the plan is there once the step that
    asked for the run has finished, before the job is scheduled."""
    from pidpipe.steps.refine_engine import CaseEngine, Plan

    engine = CaseEngine.from_config(config, "results/refine/work")
    planned = engine.plan_cpu_s(Plan.read(engine.plan_path(wildcards.run)))
    return cluster_resources.refine_run_runtime_min(planned, attempt)


def get_refine_last_step(wildcards):
    """The step at which the loop stopped: steps are asked for one after another (each a
    checkpoint) until one says done."""
    step = 1
    while True:
        path = checkpoints.refine_step.get(step=step).output.step
        if read_step(path)["status"] == "done":
            return path
        step += 1


def get_m_eff_surrogate():
    """The m_eff surrogate, as a list: none with an external C_eq table (it has no m_eff)."""
    return m_eff_surrogate_paths(SETTINGS.optimisation)


def get_m_eff_figures():
    """The m_eff maps (PNG), when there is an m_eff surrogate."""
    return m_eff_figure_paths(SETTINGS.optimisation)


def get_environments():
    return [environment.as_params() for environment in SETTINGS.environments]


def get_budget():
    return SETTINGS.budget.as_params()


def get_optimisation_params():
    """What the designs depend on: config optimisation without the table's path (an input)."""
    return SETTINGS.optimisation.as_params()


def get_map_uncertainty_params():
    """The bootstrap draws and seed of the maps' uncertainty panels."""
    return map_uncertainty_params(config)


def get_final_targets():
    """What `snakemake` builds: the campaign's case records and table (unless an external table is
    used), then the surrogates (C_eq, and m_eff with the campaign's table), the cross-validation,
    the optimum and the figures. The records are targets themselves, so that a deleted record is
    recomputed."""
    targets = [
        "results/surrogate.json",
        "results/surrogate_cv.csv",
        "results/optimum.csv",
        "results/figures/ceq_freq_fill.png",
        "results/figures/ceq_freq_accel.png",
        "results/figures/convergence.png",
        "results/figures/optimum_spread.png",
    ]
    targets += get_m_eff_surrogate() + get_m_eff_figures()
    if refining():
        targets += ["results/refine/rounds.csv", "results/refine/convergence.png"]
    if SETTINGS.optimisation.external_ceq_table is None:
        targets = get_case_records() + ["results/ceq_table.csv"] + targets + get_phase_figures()
    return targets


def get_dem_check_records():
    """The compiled DEM's record of every case of the campaign (`snakemake validate`)."""
    return [f"results/validation/dem/{case_id}.json" for case_id in get_case_ids()]


def get_phase_figures():
    """The phase-resolved figures of the report's gallery (inspection.phase_figure_cases)."""
    return phase_figure_targets(SETTINGS.inspection, PHASE_FIGURE_CASES)


def get_case_movie(wildcards):
    """The movie settings of a simulate_case job: {} unless its case is in inspection.movie_cases."""
    return case_movie_params(SETTINGS.inspection, get_case_id(wildcards), MOVIE_CASES)


def get_validation_cases():
    """The cases of `snakemake validate` (validation.cases)."""
    return SETTINGS.validation.as_params()


def get_validation_packings():
    """The replicate-0 packing of every fill in validation.cases."""
    return [f"results/packings/{packing_id}.json" for packing_id in validation_packing_ids(SETTINGS.validation)]


# The designs' check by DEM (workflow/rules/verify.smk): its cases follow from the designs
# (checkpoint plan_verify).


def get_fill_config():
    """The config's fill section (spheres per full cell)."""
    return fill_params(config)


def get_verify_params():
    return SETTINGS.verify.as_params()


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
    return scene_params(config)


# The host-coupled check (workflow/rules/host.smk).


def get_host_config():
    """The config values the host check depends on (pidpipe.steps.params.host_params)."""
    return host_params(config)


def get_panel_config():
    """The config values the modal stage depends on (pidpipe.config.panel.panel_params)."""
    return panel_params(config)


def get_panel_check_config():
    """The config values the DEM check of a mode depends on
    (pidpipe.config.panel.panel_check_params)."""
    return panel_check_params(config)
