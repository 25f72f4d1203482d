"""Typed, frozen settings parsed once from a validated config (or from a stage's part of one).

:func:`pidpipe.config.validate_config` checks the YAML against the schema and fills its
defaults; the functions here turn the resulting dict into dataclasses that the stages take
instead of the dict. Each section parses on its own (``Fidelity.from_config(config)`` needs only
the keys it reads), so a rule that receives only its stage's part of the config
(:func:`pidpipe.config.stages.stage_config`) parses the part it was given, and a key the stage
reads that the part does not list is a ``KeyError`` at once, not a silent default.

The ``fidelity`` section of ``config.yaml`` holds three kinds of setting, split here by the
stage that uses them: :class:`Fidelity` (how the contact is resolved: timestep, stiffness,
rotation, friction; part of every scene), :class:`Sampling` (how long and on how many cells a
case is measured) and :class:`Pouring` (how packings are poured).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pidpipe.config.derived import (
    budget_spheres,
    full_cell_spheres,
    pair_properties,
    panel_mass_kg,
    panel_n_cells,
    spheres_at_fill,
)
from pidpipe.config.inspection import MotionSampling, motion_sampling
from pidpipe.errors import ConfigError
from pidpipe.physics.materials import Material, PairProperties

POUR_ENGINES: tuple[str, ...] = ("liggghts", "dem")
"""Engines that pour packings (``fidelity.pour_engine``)."""


def _material(config: dict, name: str) -> Material:
    props = config["materials"][name]
    return Material(youngs_modulus_pa=float(props["youngs_modulus_pa"]),
                    poisson_ratio=float(props["poisson_ratio"]),
                    density_kg_m3=float(props.get("density_kg_m3", 0.0)),
                    radius_m=float(props.get("radius_m", 0.0)), name=name)


def _pair(config: dict, a: str, b: str) -> PairProperties:
    props = pair_properties(config, a, b)
    return PairProperties(friction=props["friction"], restitution=props["restitution"])


@dataclass(frozen=True)
class Materials:
    """The particle and wall materials and the contact properties of their pairs.

    Attributes
    ----------
    particle, wall : Material
        What the spheres are made of (with their radius) and what the walls behave as.
    particle_particle, particle_wall : PairProperties
        Friction and restitution of sphere-sphere and sphere-wall contacts.
    wall_wall : PairProperties
        Never in contact, but LIGGGHTS needs a value: the configured pair if present, else the
        particle-wall one.
    """

    particle: Material
    wall: Material
    particle_particle: PairProperties
    particle_wall: PairProperties
    wall_wall: PairProperties

    @classmethod
    def from_config(cls, config: dict) -> "Materials":
        particle, wall = config["particle_material"], config["wall_material"]
        particle_wall = _pair(config, particle, wall)
        try:
            wall_wall = _pair(config, wall, wall)
        except ConfigError:
            wall_wall = particle_wall
        return cls(particle=_material(config, particle), wall=_material(config, wall),
                   particle_particle=_pair(config, particle, particle),
                   particle_wall=particle_wall, wall_wall=wall_wall)


@dataclass(frozen=True)
class Geometry:
    """The honeycomb cell (``geometry``), m.

    Attributes
    ----------
    cell_inscribed_diameter_m, core_height_m : float
        Inscribed-circle diameter of the hexagonal cell and the distance between the face
        sheets, m.
    """

    cell_inscribed_diameter_m: float
    core_height_m: float

    @classmethod
    def from_config(cls, config: dict) -> "Geometry":
        geo = config["geometry"]
        return cls(float(geo["cell_inscribed_diameter_m"]), float(geo["core_height_m"]))


@dataclass(frozen=True)
class Fidelity:
    """How a contact is resolved: the settings that enter every scene, pour or shake.

    Attributes
    ----------
    timestep_rayleigh_fraction : float
        dt / Rayleigh time of the (softened) particles, before rounding down to whole steps per
        cycle.
    youngs_modulus_scale : float
        Factor on every Young's modulus (1 = real stiffness).
    rotation, friction : bool
        Integrate the spheres' rotation; tangential (Coulomb) contact on.
    """

    timestep_rayleigh_fraction: float
    youngs_modulus_scale: float
    rotation: bool
    friction: bool

    @classmethod
    def from_config(cls, config: dict) -> "Fidelity":
        fid = config["fidelity"]
        return cls(float(fid["timestep_rayleigh_fraction"]), float(fid["youngs_modulus_scale"]),
                   bool(fid["rotation"]), bool(fid["friction"]))


@dataclass(frozen=True)
class Sampling:
    """How long, and on how many cells, a case is measured.

    Attributes
    ----------
    transient_cycles : int
        Cycles run and discarded before measuring (a floor: a longer detected transient is
        discarded too).
    transient_min_time_s : float
        The transient lasts at least this long, s.
    measured_cycles : int
        Cycles whose dissipation is averaged (first stage).
    sem_block_cycles : int
        Cycles per block of the block-means standard error.
    target_relative_sem : float or None
        Measure (more cells, more cycles) until SEM / C_eq is at most this; None: the pilot only.
    max_measured_cycles : int
        Cap on the measured cycles of a case's runs.
    cells_per_run : int
        Cells side by side in one run, each with its own packing (the pilot's cells).
    max_cells_per_case : int
        Cap on the cells (packings) a case measures to reach its target.
    max_case_cpu_s : float
        Cap on a case's planned CPU time, s.
    """

    transient_cycles: int
    transient_min_time_s: float
    measured_cycles: int
    sem_block_cycles: int
    target_relative_sem: float | None
    max_measured_cycles: int
    cells_per_run: int
    max_cells_per_case: int
    max_case_cpu_s: float

    @classmethod
    def from_config(cls, config: dict) -> "Sampling":
        fid = config["fidelity"]
        target = fid["target_relative_sem"]
        return cls(int(fid["transient_cycles"]), float(fid["transient_min_time_s"]),
                   int(fid["measured_cycles"]), int(fid["sem_block_cycles"]),
                   None if target is None else float(target), int(fid["max_measured_cycles"]),
                   int(fid["cells_per_run"]), int(fid["max_cells_per_case"]),
                   float(fid["max_case_cpu_s"]))

    def transient_cycles_at(self, freq_hz: float) -> int:
        """Cycles discarded before measuring at ``freq_hz`` (Hz): the configured count, or more
        to last at least ``transient_min_time_s``."""
        by_time = math.ceil(self.transient_min_time_s * freq_hz - 1e-9)
        return max(self.transient_cycles, by_time)


@dataclass(frozen=True)
class Pouring:
    """How packings are poured (``fidelity.settle_time_s``, ``fidelity.seed``, ``fidelity.pour_engine``).

    Attributes
    ----------
    settle_time_s : float
        Settling time after the pour and after the tapping, s.
    seed : int
        Seed of replicate 0; replicate k uses seed + k.
    engine : str
        The engine that pours: ``liggghts`` (the default) or ``dem`` (the compiled DEM), one
        of :data:`POUR_ENGINES`.
    """

    settle_time_s: float
    seed: int
    engine: str = "liggghts"

    def __post_init__(self) -> None:
        if self.engine not in POUR_ENGINES:
            raise ConfigError(f"fidelity.pour_engine must be one of {', '.join(POUR_ENGINES)}, "
                              f"got {self.engine!r}")

    @classmethod
    def from_config(cls, config: dict) -> "Pouring":
        fid = config["fidelity"]
        # a stage's part of the config names the pour engine only when it is not LIGGGHTS (stages.py)
        return cls(float(fid["settle_time_s"]), int(fid["seed"]),
                   str(fid.get("pour_engine", "liggghts")))


@dataclass(frozen=True)
class Fill:
    """Fill percent r -> spheres per cell (``fill``).

    Attributes
    ----------
    full_cell_spheres : int
        Spheres at r = 100 % under the configured definition.
    definition : str
        ``poured_capacity`` or ``source_36``.
    """

    full_cell_spheres: int
    definition: str

    @classmethod
    def from_config(cls, config: dict) -> "Fill":
        return cls(full_cell_spheres(config), str(config["fill"]["definition"]))

    def spheres(self, fill_pct: float) -> int:
        """Spheres per cell at fill r (percent): round half up of full_cell_spheres * r / 100."""
        return spheres_at_fill(self.full_cell_spheres, fill_pct)


@dataclass(frozen=True)
class Budget:
    """The particle budget of the optimisation and the cell counts (``budget``, ``panel``).

    The one budget type: the optimiser (:mod:`pidpipe.design.optimisation`) takes it as it is
    parsed here.

    Attributes
    ----------
    n_spheres : int
        n_b, spheres the panel may hold (the mass limit's, or ``budget.spheres``).
    full_cell_spheres : float
        Spheres in one cell at r = 100 % (:func:`pidpipe.config.full_cell_spheres`: 36 in the
        source's definition, 21 in the default poured-capacity one).
    n_cells_coupon : int
        N, cells of the coupon whose C_eq the surrogate predicts (C_eq / N is one cell's).
    n_cells_panel : int or None
        Cells of the structure that may be filled, the most n_c can be (``panel.n_cells``);
        None: the coupon's N.
    """

    n_spheres: int
    full_cell_spheres: float
    n_cells_coupon: int
    n_cells_panel: int | None = None

    def __post_init__(self) -> None:
        if not (self.n_spheres >= 1 and self.full_cell_spheres > 0 and self.n_cells_coupon >= 1
                and (self.n_cells_panel is None or self.n_cells_panel >= 1)):
            raise ConfigError(f"config key budget: the budget needs n_spheres >= 1, "
                              f"full_cell_spheres > 0, n_cells_coupon >= 1 and n_cells_panel "
                              f">= 1; got {self}")

    @classmethod
    def from_config(cls, config: dict) -> "Budget":
        return cls(budget_spheres(config), full_cell_spheres(config),
                   int(config["geometry"]["coupon_n_cells"]), panel_n_cells(config))

    @property
    def max_cells(self) -> int:
        """The most cells that may be filled: the panel's, or the coupon's N without a panel."""
        return int(self.n_cells_panel if self.n_cells_panel is not None else self.n_cells_coupon)

    def spheres_per_cell(self, fill_pct):
        """Spheres in one cell at fill r (%): full_cell_spheres * r / 100 (not rounded); the
        shape of ``fill_pct``."""
        return self.full_cell_spheres * np.asarray(fill_pct, dtype=float) / 100.0

    def as_params(self) -> dict:
        """The plain dict a rule's ``params`` carries (``Budget(**params)`` reads it back)."""
        return {"n_spheres": self.n_spheres, "full_cell_spheres": self.full_cell_spheres,
                "n_cells_coupon": self.n_cells_coupon, "n_cells_panel": self.n_cells_panel}


@dataclass(frozen=True)
class Environment:
    """An operating environment: a band of frequency (Hz) and of acceleration (g)
    (an entry of ``environments``).

    The band ends keep the numbers the config wrote (an integer stays one), so that a rule's
    params and the results files that echo them read as before.
    """

    name: str
    freq_hz: tuple[float, float]
    accel_g: tuple[float, float]

    def __post_init__(self) -> None:
        for key, unit in (("freq_hz", "Hz"), ("accel_g", "g")):
            lo, hi = getattr(self, key)
            if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
                raise ConfigError(f"config key environments ({self.name!r}).{key} = [{lo}, {hi}] "
                                  f"{unit} is not allowed: it must be finite with 0 < low <= high")

    @classmethod
    def from_entry(cls, entry: dict) -> "Environment":
        """One entry of the config's ``environments`` (or of a rule's params)."""
        return cls(str(entry["name"]), tuple(entry["freq_hz"]), tuple(entry["accel_g"]))

    @classmethod
    def list_from_config(cls, config: dict) -> list["Environment"]:
        return [cls.from_entry(e) for e in config["environments"]]

    def in_floats(self) -> "Environment":
        """The same environment with every band end a float."""
        return Environment(self.name, (float(self.freq_hz[0]), float(self.freq_hz[1])),
                           (float(self.accel_g[0]), float(self.accel_g[1])))

    def as_params(self) -> dict:
        """The plain, key-sorted dict a rule's ``params`` carries (:meth:`from_entry` reads it)."""
        return {"accel_g": list(self.accel_g), "freq_hz": list(self.freq_hz), "name": self.name}


@dataclass(frozen=True)
class VerifySettings:
    """How the designs are checked by DEM (``verify``; ``snakemake --cores 2 verify``).

    Attributes
    ----------
    engine : str
        ``liggghts`` or ``dem``: the solver of the verifying cases.
    flag_z : float
        A case is flagged when |DEM - surrogate| exceeds this many combined standard
        uncertainties.
    surrogate_draws : int
        Refits of the surrogate on the table redrawn within its SEMs (0: no noise part).
    surrogate_seed : int
        Seed of the redrawn tables.
    """

    engine: str = "liggghts"
    flag_z: float = 2.0
    surrogate_draws: int = 200
    surrogate_seed: int = 13

    def __post_init__(self) -> None:
        if self.engine not in ("liggghts", "dem"):
            raise ConfigError(f"verify.engine = {self.engine!r} is not allowed: liggghts or dem")
        if not self.flag_z > 0 or self.surrogate_draws < 0 or self.surrogate_seed < 0:
            raise ConfigError(f"verify needs flag_z > 0, surrogate_draws >= 0 and surrogate_seed "
                              f">= 0; got {self}")

    @classmethod
    def from_config(cls, config: dict) -> "VerifySettings":
        section = config["verify"]
        return cls(str(section["engine"]), float(section["flag_z"]),
                   int(section["surrogate_draws"]), int(section["surrogate_seed"]))

    def as_params(self) -> dict:
        """The plain dict a rule's ``params`` carries (and :meth:`from_config` reads back)."""
        return {"verify": {"engine": self.engine, "flag_z": self.flag_z,
                           "surrogate_draws": self.surrogate_draws,
                           "surrogate_seed": self.surrogate_seed}}


@dataclass(frozen=True)
class ShakeSettings:
    """Everything a case's shaking run reads: the scene's inputs, the sampling and the engine.

    Built from the case stage's part of the config (``stage_config(config, "case")``).
    ``engine`` is ``liggghts`` (the reference) or ``dem`` (the compiled in-repo DEM); ``motion``
    how finely a run of either engine samples the bed's motion within the cycle (None: not
    at all).
    """

    geometry: Geometry
    materials: Materials
    fidelity: Fidelity
    sampling: Sampling
    coupon_n_cells: int
    engine: str = "liggghts"
    motion: MotionSampling | None = None

    @classmethod
    def from_config(cls, config: dict) -> "ShakeSettings":
        # the case stage's part names the engine only when it is not LIGGGHTS (stages.py)
        return cls(Geometry.from_config(config), Materials.from_config(config),
                   Fidelity.from_config(config), Sampling.from_config(config),
                   int(config["geometry"]["coupon_n_cells"]),
                   str(config.get("engine", "liggghts")), motion_sampling(config))


@dataclass(frozen=True)
class PourSettings:
    """Everything a pour reads: the scene's inputs, the fill and the pouring settings.

    Built from the packing stage's part of the config (``stage_config(config, "packing")``).
    """

    geometry: Geometry
    materials: Materials
    fidelity: Fidelity
    fill: Fill
    pouring: Pouring

    @classmethod
    def from_config(cls, config: dict) -> "PourSettings":
        return cls(Geometry.from_config(config), Materials.from_config(config),
                   Fidelity.from_config(config), Fill.from_config(config),
                   Pouring.from_config(config))


@dataclass(frozen=True)
class HostSettings:
    """The host-coupled check of the C_eq model (``host``), with its nulls resolved.

    Attributes
    ----------
    environment_index : int
        Which of ``environments`` the host serves.
    environment : Environment
        That environment.
    design : str
        ``band_mean``, ``peak`` or ``worst_case``: which of its designs fills the cells.
    mass_kg : float
        m_h, the host's mass without the spheres, kg (``host.mass_kg``, else the panel's mass).
    natural_freq_hz : float
        The bare host's natural frequency, Hz (else the band centre).
    damping_ratio : float
        zeta_h = c_h / (2 sqrt(k_h m_h)).
    force_n : tuple of float
        Force amplitudes F_0, N, one sweep each.
    freq_span_fraction : float
    freq_points : int
        The sweep: ``freq_points`` frequencies evenly over (1 -/+ span) x natural_freq_hz.
    cells : int
        Representative cells k.
    transient_cycles, measured_cycles, sem_block_cycles : int
    start : str
        ``equivalent`` or ``rest``: the host's state at t = 0.
    surrogate_draws, seed : int
    agreement_fraction : float
    coupon_n_cells : int
        N, the coupon's cells, whose C_eq / N is one cell's.
    """

    environment_index: int
    environment: Environment
    design: str
    mass_kg: float
    natural_freq_hz: float
    damping_ratio: float
    force_n: tuple[float, ...]
    freq_span_fraction: float
    freq_points: int
    cells: int
    transient_cycles: int
    measured_cycles: int
    sem_block_cycles: int
    start: str
    surrogate_draws: int
    seed: int
    agreement_fraction: float
    coupon_n_cells: int

    @classmethod
    def from_config(cls, config: dict) -> "HostSettings":
        host = config["host"]
        environments = Environment.list_from_config(config)
        index = int(host["environment"])
        if index >= len(environments):
            raise ConfigError(f"config key host.environment = {index} is not allowed: there are "
                              f"{len(environments)} environment(s), indices 0 .. "
                              f"{len(environments) - 1}")
        environment = environments[index].in_floats()
        mass = host["mass_kg"]
        natural = host["natural_freq_hz"]
        return cls(
            environment_index=index, environment=environment, design=str(host["design"]),
            mass_kg=float(panel_mass_kg(config) if mass is None else mass),
            natural_freq_hz=float(0.5 * sum(environment.freq_hz) if natural is None else natural),
            damping_ratio=float(host["damping_ratio"]),
            force_n=tuple(float(f) for f in host["force_n"]),
            freq_span_fraction=float(host["freq_span_fraction"]),
            freq_points=int(host["freq_points"]), cells=int(host["cells"]),
            transient_cycles=int(host["transient_cycles"]),
            measured_cycles=int(host["measured_cycles"]),
            sem_block_cycles=int(host["sem_block_cycles"]), start=str(host["start"]),
            surrogate_draws=int(host["surrogate_draws"]), seed=int(host["seed"]),
            agreement_fraction=float(host["agreement_fraction"]),
            coupon_n_cells=int(config["geometry"]["coupon_n_cells"]))

    @property
    def stiffness_n_m(self) -> float:
        """k_h = m_h (2 pi f_n)^2, N/m."""
        return self.mass_kg * (2.0 * math.pi * self.natural_freq_hz) ** 2

    @property
    def damping_ns_m(self) -> float:
        """c_h = 2 zeta_h sqrt(k_h m_h), N s/m."""
        return 2.0 * self.damping_ratio * math.sqrt(self.stiffness_n_m * self.mass_kg)

    def frequencies_hz(self) -> list[float]:
        """The sweep's forcing frequencies, Hz."""
        low = 1.0 - self.freq_span_fraction
        step = 2.0 * self.freq_span_fraction / (self.freq_points - 1)
        return [self.natural_freq_hz * (low + i * step) for i in range(self.freq_points)]
