"""Reading the optimisation results (every design, with its band and bootstrap) back from their JSON file.
"""

from __future__ import annotations

import json
import os
from dataclasses import fields
from pathlib import Path

from pidpipe.errors import ParseError


def read_results_json(path: str | os.PathLike) -> list:
    """Read the results written by :func:`pidpipe.design.designs.write_results_json` back into
    dataclasses."""
    from pidpipe.design.band import BandSummary
    from pidpipe.design.optimisation import (
        Budget,
        Design,
        Environment,
        LocalOptimum,
        OptimisationResult,
        StartRun,
    )

    def build(cls, data):
        return cls(**{f.name: data[f.name] for f in fields(cls) if f.name in data})

    try:
        document = json.loads(Path(path).read_text(encoding="utf-8"))
        results = []
        for item in document:
            env = item["environment"]
            results.append(OptimisationResult(
                environment=Environment(env["name"], tuple(env["freq_hz"]), tuple(env["accel_g"])),
                budget=build(Budget, item["budget"]),
                bounds={k: tuple(v) for k, v in item["bounds"].items()},
                clipped=item["clipped"], seed=item["seed"],
                optimum=build(LocalOptimum, item["optimum"]),
                local_optima=[build(LocalOptimum, o) for o in item["local_optima"]],
                design=build(Design, item["design"]),
                starts=[build(StartRun, s) for s in item["starts"]],
                kind=item.get("kind", "peak"),
                band=None if item.get("band") is None else build(BandSummary, item["band"]),
                regime_warning=item.get("regime_warning", ""),
                uncertainty=item.get("uncertainty")))
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ParseError(f"optimisation results {path} cannot be read: {exc}") from None
    return results
