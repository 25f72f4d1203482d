"""Rule run_scene_study: every scene of config scene (pidpipe.scene_study.write_scene_study)."""

from pidpipe.campaign import run_step
from pidpipe.scene_study import write_scene_study

run_step(
    write_scene_study,
    snakemake.log[0],
    config=snakemake.params.config,
    table_path=snakemake.output.table,
    comparisons_path=snakemake.output.comparisons,
    folder=snakemake.params.folder,
    workers=snakemake.threads,
)
