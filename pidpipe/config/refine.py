"""The design-driven refinement's settings (``refine:``), frozen and checking themselves.

The loop (:mod:`pidpipe.refine.loop`) spends engine CPU where the designs are uncertain and
stops when every design verifies and its total C_eq has a 95 % interval within
``interval_fraction`` of its value, or when ``max_cpu_s`` of planned engine CPU is spent, or
after ``max_rounds`` rounds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pidpipe.errors import ConfigError


#: Where the workflow runs the loop's cases (``refine.run_cases``).
RUN_CASES = ("auto", "in_step", "as_jobs")


@dataclass(frozen=True)
class RefineSettings:
    """How the refinement loop runs and when it stops.

    Attributes
    ----------
    interval_fraction : float
        A design's 95 % interval of its total C_eq must lie within +- this fraction of its value
        (0 < x < 1).
    max_cpu_s : float
        Planned engine CPU the loop may spend beyond the grid's pilots, s (> 0).
    cases_per_round : int
        Cases (new or extended) chosen per round (>= 1).
    max_rounds : int
        Rounds at most (>= 1); the last one fits, optimises and verifies, and runs no case of
        its own.
    enabled : bool
        Whether the workflow's campaign runs the loop after the grid's pilots and designs on
        its table (``results/ceq_table_refined.csv``); ``pidpipe refine`` runs it either way.
    run_cases : str
        Where the workflow runs the loop's cases: ``in_step`` (the step's job runs them, up to
        its threads at a time, and goes on to the next round: one job for the whole loop),
        ``as_jobs`` (each case a Snakemake job of its own, then a new step: what spreads the
        cases over a cluster), or ``auto`` (:meth:`runs_in_step`: ``in_step`` for the compiled
        DEM, whose cases take seconds, ``as_jobs`` for LIGGGHTS, whose cases take minutes).
        It does not change what the loop decides or runs.
    far_pilot_measured_cycles : int or None
        Measured cycles (at most ``fidelity.measured_cycles``) of a grid pilot at a frequency and
        acceleration that bracket no environment's band, when the loop is on and no uniform
        target is set (:mod:`pidpipe.config.pilots`); None: every pilot runs
        ``fidelity.measured_cycles``. At least 2 blocks of ``fidelity.sem_block_cycles``
        (checked with the config).
    """

    interval_fraction: float = 0.10
    max_cpu_s: float = 3600.0
    cases_per_round: int = 4
    max_rounds: int = 20
    enabled: bool = False
    run_cases: str = "auto"
    far_pilot_measured_cycles: int | None = 12

    def __post_init__(self) -> None:
        problems = self.problems()
        if problems:
            raise ConfigError("\n".join(problems))

    def problems(self) -> list[str]:
        """One line per bad setting (empty when all are good)."""
        lines = []
        if not (isinstance(self.interval_fraction, (int, float))
                and 0.0 < self.interval_fraction < 1.0):
            lines.append(f"config key refine.interval_fraction = {self.interval_fraction!r} is not "
                         "allowed: it must be a number with 0 < x < 1 (the 95 % interval's "
                         "half-width as a fraction of the design's total C_eq)")
        if not (isinstance(self.max_cpu_s, (int, float)) and math.isfinite(self.max_cpu_s)
                and self.max_cpu_s > 0):
            lines.append(f"config key refine.max_cpu_s = {self.max_cpu_s!r} is not allowed: it "
                         "must be a finite number > 0 (planned engine CPU seconds)")
        if not isinstance(self.enabled, bool):
            lines.append(f"config key refine.enabled = {self.enabled!r} is not allowed: it must "
                         "be true or false")
        if self.run_cases not in RUN_CASES:
            lines.append(f"config key refine.run_cases = {self.run_cases!r} is not allowed: it "
                         f"must be one of {', '.join(RUN_CASES)}")
        whole_numbers = [("cases_per_round", 1), ("max_rounds", 1)]
        if self.far_pilot_measured_cycles is not None:          # None: every pilot is full
            whole_numbers.append(("far_pilot_measured_cycles", 2))
        for key, least in whole_numbers:
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, int) or value < least:
                lines.append(f"config key refine.{key} = {value!r} is not allowed: it must be "
                             f"a whole number >= {least}")
        return lines

    @classmethod
    def from_config(cls, config: dict) -> "RefineSettings":
        """The settings of a validated config's ``refine`` section."""
        section = config["refine"]
        return cls(interval_fraction=float(section["interval_fraction"]),
                   max_cpu_s=float(section["max_cpu_s"]),
                   cases_per_round=section["cases_per_round"], max_rounds=section["max_rounds"],
                   enabled=section.get("enabled", False),
                   run_cases=section.get("run_cases", "auto"),
                   far_pilot_measured_cycles=section.get("far_pilot_measured_cycles", 12))

    def runs_in_step(self, engine: str) -> bool:
        """Whether the workflow's step runs the loop's cases itself (``run_cases``; ``auto``:
        for the ``dem`` engine only). On the DEM's default campaign the cases as jobs of their
        own took 183 s of jobs for 39 s of shaking: each job starts Python and loads the kernel
        (docs/explanation/refine.md)."""
        if self.run_cases == "auto":
            return engine == "dem"
        return self.run_cases == "in_step"

    def as_params(self) -> dict:
        """The plain dict a rule's ``params`` carries (and :meth:`from_config` reads back)."""
        return {"refine": {"interval_fraction": self.interval_fraction,
                           "max_cpu_s": self.max_cpu_s, "cases_per_round": self.cases_per_round,
                           "max_rounds": self.max_rounds, "enabled": self.enabled,
                           "run_cases": self.run_cases,
                           "far_pilot_measured_cycles": self.far_pilot_measured_cycles}}
