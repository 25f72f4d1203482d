"""What each Snakemake rule receives: the validated config, the campaign's cases and packings, and each stage's part of the config.

The parameters each rule receives are the parts of the config it depends on
(:func:`stage_config`), with sorted keys, so an edit elsewhere in the config does not rerun it.
"""

from __future__ import annotations

from pathlib import Path

from pidpipe.cases import NUMBER_PATTERN, CaseSpec, grid_cases
from pidpipe.config import validate_config
from pidpipe.config.schema import check_environments_in_reach
from pidpipe.config.sections import Grid, Inspection, Optimisation, Settings, Validation
from pidpipe.config.settings import Budget, Environment, Sampling, VerifySettings
from pidpipe.config.stages import sorted_keys, stage_config
from pidpipe.errors import ConfigError

#: Snakemake wildcard constraint of a number in a case id (as written by ``format_number``).
WILDCARD_NUMBER = NUMBER_PATTERN

#: Snakemake wildcard constraint of a replicate index.
WILDCARD_REPLICATE = r"[0-9]+"


def workflow_config(raw: dict) -> dict:
    """Validate the workflow's config; also check what only the workflow needs.

    Besides :func:`pidpipe.config.validate_config` (whose schema also lists the surrogate
    methods): every environment lies in the grid's range
    (:func:`pidpipe.config.schema.check_environments_in_reach`); an external C_eq table must exist (paths are relative to the working directory),
    so that the run does not fail after the simulations.

    Raises
    ------
    ConfigError
    """
    config = validate_config(raw)
    check_environments_in_reach(config)
    external = Optimisation.from_config(config).external_ceq_table
    if external is not None and not Path(external).is_file():
        raise ConfigError(f"config key optimisation.external_ceq_table = {external!r} is not allowed: "
                          f"no such file (relative paths start at {Path.cwd()})")
    return config


def workflow_settings(config: dict) -> Settings:
    """Every section of the workflow's validated config, parsed once (:class:`Settings`)."""
    return Settings.from_config(config)


def inspected_cases(config: dict, key: str) -> tuple[list[str], list[str]]:
    """The case ids of ``inspection.<key>`` (``movie_cases``, ``phase_figure_cases``) that are
    cases of the campaign, and those that are not (ignored, so that a grid cut down for a quick
    run keeps working; the workflow prints them)."""
    known = {case.case_id for case in campaign_cases(config)}
    listed = getattr(Inspection.from_config(config), key)
    return ([c for c in listed if c in known], [c for c in listed if c not in known])


def case_movie_params(inspection: Inspection, case_id: str, movie_cases: list[str]) -> dict:
    """A shaking job's movie settings: ``{}`` unless ``case_id`` is one of ``movie_cases``
    (:func:`inspected_cases`), else the frames per cycle, the cycles and the movie's folder."""
    if case_id not in movie_cases:
        return {}
    movie = inspection.movie
    return {"frames_per_cycle": movie.frames_per_cycle, "cycles": movie.cycles,
            "directory": f"results/movies/{case_id}"}


def phase_figure_targets(inspection: Inspection, phase_figure_cases: list[str]) -> list[str]:
    """The phase-resolved figures of the report's gallery; none when the motion is not sampled."""
    if inspection.motion is None:
        return []
    return [f"results/figures/phase/{case_id}.png" for case_id in phase_figure_cases]


#: The campaign's C_eq table, and the refinement loop's (what its last round fitted).
CAMPAIGN_TABLE, REFINED_TABLE = "results/ceq_table.csv", "results/ceq_table_refined.csv"


def ceq_table_path(optimisation: Optimisation, refine_enabled: bool = False) -> str:
    """The table the surrogate is fitted to: ``optimisation.external_ceq_table``; else, with
    ``refine.enabled``, the refinement loop's (``results/ceq_table_refined.csv``); else the
    campaign's ``results/ceq_table.csv``."""
    if optimisation.external_ceq_table:
        return optimisation.external_ceq_table
    return REFINED_TABLE if refine_enabled else CAMPAIGN_TABLE


def refine_params(config: dict) -> dict:
    """What the refinement loop's steps and runs depend on, as their rules' params carry it:
    the cases' settings (:func:`pidpipe.config.stages.stage_config`), the environments, the
    optimisation and its budget, the surrogate, verify's threshold and the loop's settings."""
    from pidpipe.config.stages import stage_config

    depends = stage_config(config, "case")
    depends["engine"] = config.get("engine", "liggghts")
    for key in ("environments", "optimisation", "budget", "surrogate"):
        depends[key] = config[key]
    # where the cases run does not change what the loop decides or runs
    depends["refine"] = {k: v for k, v in config["refine"].items() if k != "run_cases"}
    depends["verify"] = {"flag_z": config["verify"]["flag_z"]}
    return depends


#: The m_eff surrogate (:func:`pidpipe.steps.design.fit_m_eff_surrogate`) and its maps.
M_EFF_SURROGATE = "results/surrogate_m_eff.json"
M_EFF_FIGURES: tuple[str, ...] = ("results/figures/m_eff_freq_fill.png",
                                  "results/figures/m_eff_freq_accel.png")


def m_eff_surrogate_paths(optimisation: Optimisation) -> list[str]:
    """The m_eff surrogate when the fitted table can have m_eff: the campaign's table (every
    case record measures it); none with ``optimisation.external_ceq_table`` (a published C_eq
    table has no ``m_eff_cell_kg``; ask for :data:`M_EFF_SURROGATE` by name if one has)."""
    return [] if optimisation.external_ceq_table else [M_EFF_SURROGATE]


def m_eff_figure_paths(optimisation: Optimisation) -> list[str]:
    """The m_eff maps (PNG) when there is an m_eff surrogate (:func:`m_eff_surrogate_paths`)."""
    return list(M_EFF_FIGURES) if m_eff_surrogate_paths(optimisation) else []


def validation_params(config: dict) -> list[dict]:
    """The cases of ``validate_chosen`` (``validation.cases``) as its params carry them."""
    return Validation.from_config(config).as_params()


def validation_packing_ids(validation: Validation) -> list[str]:
    """The replicate-0 packing of every fill in ``validation.cases``, sorted."""
    return sorted({CaseSpec(1.0, 1.0, float(case.fill_pct)).packing_id
                   for case in validation.cases})


def fill_params(config: dict) -> dict:
    """The config's ``fill`` section, key-sorted (what the verify plan's spheres depend on)."""
    return sorted_keys(config["fill"])


def scene_params(config: dict) -> dict:
    """What the scene study depends on: a packing's and a case's part of the config, and
    ``scene``."""
    packing = stage_config(config, "packing")
    case = stage_config(config, "case")
    return {**packing, **case, "fidelity": {**packing["fidelity"], **case["fidelity"]},
            "scene": config["scene"]}


def host_params(config: dict) -> dict:
    """What the host check depends on: a packing's part of the config, the geometry and the
    panel (the host's default mass), the environments and ``host``."""
    return {**stage_config(config, "packing"), "geometry": dict(config["geometry"]),
            "panel": dict(config["panel"]), "environments": list(config["environments"]),
            "host": dict(config["host"])}


def campaign_cases(config: dict) -> list[CaseSpec]:
    """Every case of the campaign: the grid times ``grid.replicates`` runs."""
    return grid_cases(config, replicates=Grid.from_config(config).replicates)


def case_packing_ids(config: dict, case: CaseSpec) -> list[str]:
    """The packings a case shakes: one per cell of its run (``fidelity.cells_per_run``)."""
    return case.packing_ids(Sampling.from_config(config).cells_per_run)


def campaign_packing_ids(config: dict) -> list[str]:
    """Every packing the campaign's cases shake, sorted."""
    return sorted({packing_id for case in campaign_cases(config)
                   for packing_id in case_packing_ids(config, case)})


def dem_batch_fills(config: dict) -> list[str]:
    """The fills (as case ids write them) that one ``simulate_dem_cases`` job shakes: the grid's."""
    from pidpipe.cases import format_number

    return [format_number(float(fill)) for fill in sorted(Grid.from_config(config).fill_pct)]


def pour_batch_fill_pattern(config: dict) -> str:
    """Wildcard constraint of ``pour_dem_packings``' fill: the grid's fills (as case ids write
    them). Other fills (``validation.cases``, ``fidelity_study``) are poured one packing a job."""
    import re

    return "(?:" + "|".join(re.escape(fill) for fill in dem_batch_fills(config)) + ")"


def pour_batch_replicates(config: dict) -> list[int]:
    """The packing indices of one grid fill that the campaign's cases shake (the same for every
    fill: ``grid.replicates`` x ``fidelity.cells_per_run``), which one ``pour_dem_packings`` job pours."""
    return sorted({int(packing_id.rsplit("_rep", 1)[1]) for packing_id in campaign_packing_ids(config)})


def dem_batch_case_ids(config: dict, freq: str, accel: str, replicate: str) -> list[str]:
    """The cases of one ``simulate_dem_cases`` job: every fill at one frequency, acceleration and
    replicate (the wildcards' text), in :func:`dem_batch_fills`' order."""
    return [f"f{freq}Hz_G{accel}_r{fill}pct_rep{replicate}" for fill in dem_batch_fills(config)]


CHASE_WEIGHT_AT_1G = 3.0
"""How many times a case at G <= 1 counts its pilot's time steps in a DEM job's priority, when
the cases have a target. No sphere leaves the floor there, C_eq is contact damping and noisy,
and such a case cost a median 2.8-3.1x its pilot's CPU in the DEM campaigns of 2026-12-01,
against 1.0-1.2x at 5 and 10 g (``benchmarks/campaign_breakdown.py``, "a case's CPU over its
pilot's", on the campaigns of ``benchmarks/results.md``'s "Whole campaign" 18:18, 19:50 and
19:55 UTC). Weighted so, the 1000 Hz / 1 g job no longer ranks last. Only the order of the jobs
changes, not a result."""


def dem_batch_priority(config: dict, case_ids: list[str]) -> float:
    """A ``simulate_dem_cases`` job's priority: its cases' planned pilot time steps, in millions,
    those at G <= 1 weighted by :data:`CHASE_WEIGHT_AT_1G` when there is a target; the costliest
    job first."""
    from pidpipe.config.pilots import grid_case_config
    from pidpipe.config.settings import ShakeSettings
    from pidpipe.studies.fidelity import planned_steps

    chased = config["fidelity"]["target_relative_sem"] is not None
    total = 0.0
    for case in map(CaseSpec.from_id, case_ids):
        settings = ShakeSettings.from_config(grid_case_config(config, case.freq_hz, case.accel_g))
        weight = CHASE_WEIGHT_AT_1G if chased and case.accel_g <= 1.0 else 1.0
        total += weight * planned_steps(settings, case)
    return total / 1e6


def budget_params(config: dict) -> dict:
    """What the optimiser's particle budget depends on: n_b, spheres per full cell, N, N_panel."""
    return Budget.from_config(config).as_params()


def environment_params(config: dict) -> list[dict]:
    """The operating environments as plain, key-sorted dicts."""
    return [environment.as_params() for environment in Environment.list_from_config(config)]


def optimisation_params(config: dict) -> dict:
    """The optimisation section without ``external_ceq_table`` (the table is the rule's input)."""
    return Optimisation.from_config(config).as_params()


#: The maps' uncertainty panels use at most this many of the bootstrap's draws (a standard
#: deviation from 50 draws is good to about 10 % of itself; each draw costs a refit and a map).
MAP_DRAWS = 50


def map_uncertainty_params(config: dict) -> dict:
    """Draws and seed of the maps' bootstrap spread: the first (at most :data:`MAP_DRAWS`) of
    the optimum's draws, which the same seed redraws identically."""
    bootstrap = Optimisation.from_config(config).bootstrap
    return {"draws": min(bootstrap.draws, MAP_DRAWS), "seed": bootstrap.seed}


def verify_params(config: dict) -> dict:
    """The verify section as a rule's params (:meth:`VerifySettings.as_params`)."""
    return VerifySettings.from_config(config).as_params()


def verify_case_config(config: dict) -> dict:
    """The case stage's config of a verifying case: the campaign's, shaken by ``verify.engine``."""
    return stage_config({**config, "engine": VerifySettings.from_config(config).engine}, "case")
