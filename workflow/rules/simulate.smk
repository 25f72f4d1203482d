# Stage 2: shake every case (frequency x acceleration x fill x replicate) with the configured
# engine, on the same pours: LIGGGHTS (the default, simulate_liggghts.smk: a job per case) or the
# compiled in-repo DEM (engine: dem, simulate_dem.smk: a job per frequency, acceleration and
# replicate). The Snakefile includes the engine's file; both write the same records.


rule cases:
    input:
        get_case_records(),
