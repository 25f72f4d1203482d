"""The Snakemake workflow's steps: each workflow script calls one function of this package."""
