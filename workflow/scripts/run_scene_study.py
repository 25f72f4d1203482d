"""Rule run_scene_study: every scene of config scene (pidpipe.studies.scene.write_scene_study)."""

from pidpipe.steps.run import run_step
from pidpipe.studies.scene import write_scene_study

run_step(
    write_scene_study,
    snakemake.log[0],
    config=snakemake.params.config,
    table_path=snakemake.output.table,
    comparisons_path=snakemake.output.comparisons,
    folder=snakemake.params.folder,
    workers=snakemake.threads,
)
