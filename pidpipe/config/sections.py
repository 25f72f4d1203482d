"""Typed, frozen settings of the config's campaign-wide sections, and the whole config parsed once.

:mod:`pidpipe.config.settings` holds the settings a pour or a shaking run reads (built from a
stage's part of the config); this module holds the other sections: ``grid``, ``inspection``,
``validation``, ``surrogate`` and ``optimisation`` (with its ``bootstrap``), and
:class:`Settings`, every section of a validated config parsed once
(:meth:`Settings.from_config`). Each class checks itself in ``__post_init__`` and names its
config key when a value is not allowed; the JSON schema (``workflow/schemas/config.schema.yaml``)
has already checked types and bounds, so these checks hold for settings built in code too.

A rule's ``params`` stay plain values (``as_params``), built from these settings, so that
Snakemake sees the same parameters as before and a finished job is not rerun.
"""

from __future__ import annotations

from dataclasses import dataclass

from pidpipe.config.inspection import MotionSampling, MovieSettings
from pidpipe.config.settings import (
    Budget,
    Environment,
    Fill,
    HostSettings,
    Pouring,
    Sampling,
    VerifySettings,
)
from pidpipe.errors import ConfigError

ENGINES: tuple[str, ...] = ("liggghts", "dem")
"""Solvers that shake the cases (``engine``)."""


@dataclass(frozen=True)
class Grid:
    """The campaign's grid (``grid``): every combination of the three lists is a case.

    Attributes
    ----------
    freq_hz, accel_g, fill_pct : tuple of float
        Frequencies (Hz), acceleration amplitudes (g) and fills (percent), as the config lists
        them.
    replicates : int
        Packings per fill; every case runs on each.
    """

    freq_hz: tuple[float, ...]
    accel_g: tuple[float, ...]
    fill_pct: tuple[float, ...]
    replicates: int = 1

    def __post_init__(self) -> None:
        for key, values, high in (("freq_hz", self.freq_hz, 1e5), ("accel_g", self.accel_g, 1e3),
                                  ("fill_pct", self.fill_pct, 100.0)):
            if not values or any(not 0 < float(v) <= high for v in values):
                raise ConfigError(f"config key grid.{key} = {list(values)!r} is not allowed: it "
                                  f"must list at least one value, each in (0, {high:g}]")
        if self.replicates < 1:
            raise ConfigError(f"config key grid.replicates = {self.replicates!r} is not allowed: "
                              "it must be >= 1")

    @classmethod
    def from_config(cls, config: dict) -> "Grid":
        grid = config["grid"]
        return cls(tuple(grid["freq_hz"]), tuple(grid["accel_g"]), tuple(grid["fill_pct"]),
                   int(grid.get("replicates", 1)))


@dataclass(frozen=True)
class Inspection:
    """Looking inside the cases (``inspection``).

    Attributes
    ----------
    phase_windows_per_cycle, phase_sample_every_steps : int
        The motion sampling of every shake run (0 windows: none).
    movie_cases, phase_figure_cases : tuple of str
        Case ids with a movie, and with a phase-resolved figure in the report.
    movie_frames_per_cycle, movie_cycles : int
        What a movie shows.
    """

    phase_windows_per_cycle: int = 20
    phase_sample_every_steps: int = 10
    movie_cases: tuple[str, ...] = ()
    movie_frames_per_cycle: int = 20
    movie_cycles: int = 3
    phase_figure_cases: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        for key in ("phase_sample_every_steps", "movie_frames_per_cycle", "movie_cycles"):
            if getattr(self, key) < 1:
                raise ConfigError(f"config key inspection.{key} = {getattr(self, key)!r} is not "
                                  "allowed: it must be >= 1")
        if self.phase_windows_per_cycle < 0:
            raise ConfigError(f"config key inspection.phase_windows_per_cycle = "
                              f"{self.phase_windows_per_cycle!r} is not allowed: it must be >= 0")

    @classmethod
    def from_config(cls, config: dict) -> "Inspection":
        section = config["inspection"]
        return cls(int(section["phase_windows_per_cycle"]), int(section["phase_sample_every_steps"]),
                   tuple(section["movie_cases"]), int(section["movie_frames_per_cycle"]),
                   int(section["movie_cycles"]), tuple(section["phase_figure_cases"]))

    @property
    def motion(self) -> MotionSampling | None:
        """How finely a shake run samples the bed's motion; None when sampling is off."""
        if self.phase_windows_per_cycle == 0:
            return None
        return MotionSampling(self.phase_windows_per_cycle, self.phase_sample_every_steps)

    @property
    def movie(self) -> MovieSettings:
        """What a movie shows."""
        return MovieSettings(self.movie_frames_per_cycle, self.movie_cycles)


@dataclass(frozen=True)
class ValidationCase:
    """One case of ``validation.cases``: the numbers as the config wrote them."""

    freq_hz: float
    accel_g: float
    fill_pct: float

    def __post_init__(self) -> None:
        if not (self.freq_hz > 0 and self.accel_g > 0 and 0 < self.fill_pct <= 100):
            raise ConfigError(f"config key validation.cases = {self.as_params()!r} is not "
                              "allowed: freq_hz and accel_g must be > 0, fill_pct in (0, 100]")

    def as_params(self) -> dict:
        """The case as the config's entry reads (keys in the schema's order)."""
        return {"freq_hz": self.freq_hz, "accel_g": self.accel_g, "fill_pct": self.fill_pct}


@dataclass(frozen=True)
class Validation:
    """The cases run afresh by LIGGGHTS and the DEM (``validation``; ``validate_chosen``)."""

    cases: tuple[ValidationCase, ...]

    @classmethod
    def from_config(cls, config: dict) -> "Validation":
        return cls(tuple(ValidationCase(c["freq_hz"], c["accel_g"], c["fill_pct"])
                         for c in config["validation"]["cases"]))

    def as_params(self) -> list[dict]:
        """The cases as a rule's ``params`` carries them."""
        return [case.as_params() for case in self.cases]


@dataclass(frozen=True)
class SurrogateSettings:
    """The surrogate of C_eq(f, G, r) (``surrogate``).

    Attributes
    ----------
    method : str
        The interpolant the optimiser uses (the schema lists the methods).
    allow_holes : bool
        Bridge grid points without an ok result (thin-plate RBF) instead of stopping.
    """

    method: str = "rbf_thin_plate"
    allow_holes: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.method, str) or not self.method:
            raise ConfigError(f"config key surrogate.method = {self.method!r} is not allowed: it "
                              "must name a surrogate method")
        if not isinstance(self.allow_holes, bool):
            raise ConfigError(f"config key surrogate.allow_holes = {self.allow_holes!r} is not "
                              "allowed: it must be true or false")

    @classmethod
    def from_config(cls, config: dict) -> "SurrogateSettings":
        section = config["surrogate"]
        return cls(str(section["method"]), bool(section["allow_holes"]))


@dataclass(frozen=True)
class Bootstrap:
    """The optimum's parametric bootstrap (``optimisation.bootstrap``).

    Attributes
    ----------
    draws : int
        Redrawn tables (0: no bootstrap).
    starts : int
        SLSQP starts per design and draw besides the main run's local optima.
    seed : int
        Seed of the redrawn tables and of the draws' starts.
    confidence : float
        Coverage of the percentile intervals, in (0, 1).
    """

    draws: int = 200
    starts: int = 2
    seed: int = 11
    confidence: float = 0.95

    def __post_init__(self) -> None:
        if self.draws < 0 or self.starts < 0 or self.seed < 0 or not 0 < self.confidence < 1:
            raise ConfigError(f"config key optimisation.bootstrap needs draws >= 0, starts >= 0, "
                              f"seed >= 0 and 0 < confidence < 1; got {self}")

    @classmethod
    def from_section(cls, section: dict) -> "Bootstrap":
        """From the ``optimisation.bootstrap`` mapping (or a rule's params of it)."""
        return cls(int(section["draws"]), int(section["starts"]), int(section["seed"]),
                   float(section["confidence"]))

    def as_params(self) -> dict:
        return {"confidence": self.confidence, "draws": self.draws, "seed": self.seed,
                "starts": self.starts}


@dataclass(frozen=True)
class Optimisation:
    """The SLSQP multi-start optimisation (``optimisation``).

    Attributes
    ----------
    starts, seed : int
        Starting points per environment and their seed.
    band_quadrature_points, band_grid_points : int
        The band mean's Gauss-Legendre points and the band's edge grid, per axis (>= 2).
    external_ceq_table : str or None
        A C_eq table to optimise instead of the campaign's (None: the campaign's).
    bootstrap : Bootstrap
    """

    starts: int = 40
    seed: int = 7
    band_quadrature_points: int = 5
    band_grid_points: int = 7
    external_ceq_table: str | None = None
    bootstrap: Bootstrap = Bootstrap()

    def __post_init__(self) -> None:
        if self.starts < 1 or self.seed < 0:
            raise ConfigError(f"config key optimisation needs starts >= 1 and seed >= 0; got "
                              f"starts = {self.starts}, seed = {self.seed}")
        for key in ("band_quadrature_points", "band_grid_points"):
            if getattr(self, key) < 2:
                raise ConfigError(f"config key optimisation.{key} = {getattr(self, key)!r} is "
                                  "not allowed: it must be >= 2")
        if self.external_ceq_table is not None and not self.external_ceq_table:
            raise ConfigError("config key optimisation.external_ceq_table = '' is not allowed: "
                              "a path, or null for the campaign's table")

    @classmethod
    def from_config(cls, config: dict) -> "Optimisation":
        section = config["optimisation"]
        return cls(int(section["starts"]), int(section["seed"]),
                   int(section["band_quadrature_points"]), int(section["band_grid_points"]),
                   section["external_ceq_table"], Bootstrap.from_section(section["bootstrap"]))

    def as_params(self) -> dict:
        """What the designs depend on, as a rule's ``params``: the section, key-sorted, without
        ``external_ceq_table`` (the table is the rule's input)."""
        return {"band_grid_points": self.band_grid_points,
                "band_quadrature_points": self.band_quadrature_points,
                "bootstrap": self.bootstrap.as_params(), "seed": self.seed, "starts": self.starts}


@dataclass(frozen=True)
class Settings:
    """Every section of a validated config, parsed once.

    The workflow (``workflow/rules/common.smk``) and the ``pidpipe`` command build one from
    the validated config and read it by attribute. The settings of a pour and of a shaking run
    (:class:`~pidpipe.config.settings.PourSettings`, :class:`~pidpipe.config.settings.ShakeSettings`)
    are built from a stage's part of the config instead, as the rule's params carry it.

    Attributes
    ----------
    engine : str
        The solver that shakes the campaign's cases: ``liggghts`` or ``dem``.
    grid : Grid
    fill : Fill
    sampling : Sampling
        How a case is measured (``fidelity``).
    pouring : Pouring
        How packings are poured (``fidelity``: seed, settle time, ``pour_engine``).
    inspection : Inspection
    budget : Budget
    environments : tuple of Environment
    validation : Validation
    verify : VerifySettings
    surrogate : SurrogateSettings
    optimisation : Optimisation
    host : HostSettings or None
        None when ``environments`` is empty (there is no design to carry).
    """

    engine: str
    grid: Grid
    fill: Fill
    sampling: Sampling
    pouring: Pouring
    inspection: Inspection
    budget: Budget
    environments: tuple[Environment, ...]
    validation: Validation
    verify: VerifySettings
    surrogate: SurrogateSettings
    optimisation: Optimisation
    host: HostSettings | None

    def __post_init__(self) -> None:
        if self.engine not in ENGINES:
            raise ConfigError(f"config key engine = {self.engine!r} is not allowed: it must be "
                              f"one of {', '.join(ENGINES)}")

    @classmethod
    def from_config(cls, config: dict) -> "Settings":
        """Parse a validated config (:func:`pidpipe.config.validate_config`)."""
        environments = tuple(Environment.list_from_config(config))
        return cls(engine=str(config["engine"]), grid=Grid.from_config(config),
                   fill=Fill.from_config(config), sampling=Sampling.from_config(config),
                   pouring=Pouring.from_config(config), inspection=Inspection.from_config(config),
                   budget=Budget.from_config(config), environments=environments,
                   validation=Validation.from_config(config),
                   verify=VerifySettings.from_config(config),
                   surrogate=SurrogateSettings.from_config(config),
                   optimisation=Optimisation.from_config(config),
                   host=HostSettings.from_config(config) if environments else None)
