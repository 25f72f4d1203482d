# pidpipe campaign: pour packings -> check them all -> shake every case in LIGGGHTS ->
# C_eq table -> (refine.enabled: the design-driven refinement loop, in checkpoint steps) ->
# surrogate (+ cross-validation) -> SLSQP optimum per environment -> figures.
#
#   snakemake --cores 2                                  # the campaign of config.yaml
#   snakemake --cores 2 --configfile .test/config.yaml   # the reduced CI campaign
#   snakemake table | refine | surrogate | optimum | figures   # stop after a stage
#   snakemake --report report.html                       # figures and tables with captions
#   snakemake --cores 2 validate                         # every case checked by the compiled DEM (grid.csv)
#   snakemake --cores 2 validate_chosen                  # validation.cases afresh in LIGGGHTS and the DEM
#   snakemake --cores 2 host                             # the design on a vibrating host: coupled DEM vs C_eq dashpot
#   snakemake --cores 2 verify                           # each band_mean and peak design checked by DEM (verify.csv)
#
# The config is validated (workflow/schemas/config.schema.yaml, pidpipe.config) before any job;
# an invalid value stops the run with one message naming the key. Rules live in
# workflow/rules/<stage>.smk, their scripts in workflow/scripts/ (each calls one function of
# pidpipe.steps), the grid and the get_* helpers in workflow/rules/common.smk.
#
# Failure policy
# - A case whose LIGGGHTS run fails (EngineError/ParseError) is run once more (a rare MPI_ABORT
#   does not reproduce); if it fails again it does not stop the others: its job logs the message (naming the case, LIGGGHTS' screen file and the job's log), writes
#   results/cases/<case>.json with status "failed", and succeeds. The C_eq table keeps the case
#   as a "failed" row with no values. Failed and flagged points are never fitted: with
#   surrogate.allow_holes false the fit stops and names them; with true (config.yaml) the
#   thin-plate RBF bridges them and the log lists them. To retry, delete the case's record
#   and run again.
# - A misfit or unsettled packing (PackingError) stops the run before any shaking run:
#   check_packings lists every refused packing and its cases in one message. A missing
#   LIGGGHTS, a bad config and every later stage's error stop the run with their message.
# - With --keep-going every independent job still runs after a failure.
#
# Resume: outputs are written atomically and each rule's params hold only the config values it
# depends on, so a finished case is recomputed only when its own inputs change, and an
# interrupted run (Ctrl-C, kill) resumes where it stopped with a plain `snakemake --cores 2`:
# profiles/default sets rerun-incomplete, so the jobs that were running are redone. After
# kill -9 (or a power loss) run `snakemake --unlock` once first: Snakemake's lock is left behind
# and cannot be told from a live run's (tests/workflow/test_interruption.py).

import sys

from pidpipe.steps.params import workflow_config
from pidpipe.errors import ConfigError


configfile: "config.yaml"


try:
    _validated = workflow_config(config)
except ConfigError as error:
    sys.exit(f"pidpipe: invalid config: {error}")
config.clear()
config.update(_validated)


report: "workflow/report/workflow.rst"


include: "workflow/rules/common.smk"
include: "workflow/rules/packing.smk"


# The engines' own rules: the pours' batch with fidelity.pour_engine dem, and the shaking rule
# of the configured engine (workflow/rules/simulate_liggghts.smk or simulate_dem.smk).
for _pour_rules in get_pour_rules():

    include: _pour_rules


include: get_simulate_rules()
include: "workflow/rules/simulate.smk"
include: "workflow/rules/table.smk"
include: "workflow/rules/refine.smk"
include: "workflow/rules/surrogate.smk"
include: "workflow/rules/optimise.smk"
include: "workflow/rules/figures.smk"
include: "workflow/rules/validate.smk"
include: "workflow/rules/fidelity.smk"
include: "workflow/rules/scene.smk"
include: "workflow/rules/host.smk"
include: "workflow/rules/verify.smk"
include: "workflow/rules/panel.smk"


rule all:
    input:
        get_final_targets(),
