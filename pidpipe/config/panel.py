"""Typed settings of the panel's modal stage (config ``panel``, with geometry's sandwich).

The face sheets' thickness and density and the core's height and density are ``geometry``'s
(the source's Table 2, the same sandwich the coupon is cut from); ``panel`` adds the plate's
size and support, the faces' elastic constants and the core's transverse shear moduli. The
number of cells follows from the plate's area (:mod:`pidpipe.panel.cells`); ``panel.n_cells``
keeps its old meaning, the bound of the coupon designs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pidpipe.config.derived import full_cell_spheres, particle_properties
from pidpipe.errors import ConfigError
from pidpipe.physics.contact import sphere_mass

#: Edge supports the modal stage can solve (the Navier solution).
BOUNDARIES: tuple[str, ...] = ("simply_supported",)


@dataclass(frozen=True)
class PanelSettings:
    """The plate, its sandwich and how its layouts are searched (config ``panel``).

    Attributes
    ----------
    length_m, width_m : float
        a (along x, the ribbon L) and b (along y, W), m.
    boundary : str
        One of :data:`BOUNDARIES`.
    face_thickness_m, face_density_kg_m3, face_youngs_modulus_pa, face_poisson_ratio : float
    core_height_m, core_density_kg_m3, core_shear_modulus_xz_pa, core_shear_modulus_yz_pa : float
    cell_inscribed_diameter_m : float
        The hexagonal cell's flat-to-flat size, m.
    rotary_inertia : bool
    max_freq_hz : float
        Modes listed up to this frequency, Hz.
    damping_ratio : float
        The bare panel's modal damping ratio.
    modal_force_n : tuple of float
        Modal force amplitudes, N.
    effective_mass_fraction : float
        Fraction of a filled cell's particle mass in the modal mass.
    regions, starts, seed, surrogate_draws : int
    confidence : float
    n_spheres : int
        The particle budget n_b of the plate (``budget``: its mass fraction of the plate's mass,
        or the count).
    full_cell_spheres : int
        Spheres in a cell at r = 100 %.
    sphere_mass_kg : float
        One particle's mass, kg.
    """

    length_m: float
    width_m: float
    boundary: str
    face_thickness_m: float
    face_density_kg_m3: float
    face_youngs_modulus_pa: float
    face_poisson_ratio: float
    core_height_m: float
    core_density_kg_m3: float
    core_shear_modulus_xz_pa: float
    core_shear_modulus_yz_pa: float
    cell_inscribed_diameter_m: float
    rotary_inertia: bool = True
    max_freq_hz: float = 1000.0
    damping_ratio: float = 0.01
    modal_force_n: tuple[float, ...] = (0.3, 1.0, 3.0)
    effective_mass_fraction: float = 1.0
    regions: int = 8
    starts: int = 6
    seed: int = 17
    surrogate_draws: int = 40
    confidence: float = 0.95
    n_spheres: int = 1
    full_cell_spheres: int = 21
    sphere_mass_kg: float = 1e-5

    def __post_init__(self) -> None:
        self._check()

    def _check(self) -> None:
        if self.boundary not in BOUNDARIES:
            raise ConfigError(f"config key panel.boundary = {self.boundary!r} is not allowed: the "
                              f"closed-form (Navier) modes exist for {', '.join(BOUNDARIES)} edges only")
        positive = ("length_m", "width_m", "face_thickness_m", "face_density_kg_m3",
                    "face_youngs_modulus_pa", "core_height_m", "core_shear_modulus_xz_pa",
                    "core_shear_modulus_yz_pa", "cell_inscribed_diameter_m", "max_freq_hz",
                    "damping_ratio", "sphere_mass_kg")
        for name in positive:
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(f"panel setting {name} = {value!r} is not allowed: it must be a "
                                  f"finite number > 0")
        if not 0.0 <= self.face_poisson_ratio < 0.5:
            raise ConfigError(f"config key panel.face_poisson_ratio = {self.face_poisson_ratio!r} is "
                              f"not allowed: it must lie in [0, 0.5)")
        circumdiameter = 2.0 * self.cell_inscribed_diameter_m / math.sqrt(3.0)
        if self.length_m < circumdiameter or self.width_m < self.cell_inscribed_diameter_m:
            raise ConfigError(f"config keys panel.length_m x panel.width_m = {self.length_m:g} m x "
                              f"{self.width_m:g} m are not allowed: the plate must hold at least one "
                              f"honeycomb cell ({circumdiameter * 1e3:.3g} mm x "
                              f"{self.cell_inscribed_diameter_m * 1e3:.3g} mm)")
        if not self.modal_force_n or any(not (math.isfinite(f) and f > 0) for f in self.modal_force_n):
            raise ConfigError(f"config key panel.modal_force_n = {list(self.modal_force_n)!r} is not "
                              f"allowed: it must list force amplitudes > 0 N")
        if not 0.0 <= self.effective_mass_fraction <= 1.0:
            raise ConfigError(f"config key panel.effective_mass_fraction = "
                              f"{self.effective_mass_fraction!r} is not allowed: it must lie in [0, 1]")
        if self.regions < 1 or self.starts < 0 or self.surrogate_draws < 0 or not 0 < self.confidence < 1:
            raise ConfigError(f"config key panel needs regions >= 1, starts >= 0, surrogate_draws >= 0 "
                              f"and 0 < confidence < 1; got regions {self.regions}, starts "
                              f"{self.starts}, surrogate_draws {self.surrogate_draws}, confidence "
                              f"{self.confidence}")
        if self.n_spheres < 1:
            raise ConfigError(f"the particle budget (config key budget) gives {self.n_spheres} spheres "
                              f"for the {self.length_m:g} m x {self.width_m:g} m plate: at least one is needed")

    @property
    def mass_per_area_kg_m2(self) -> float:
        """The empty sandwich's mass per area, kg/m^2."""
        return 2.0 * self.face_density_kg_m3 * self.face_thickness_m + self.core_density_kg_m3 * self.core_height_m

    @property
    def plate_mass_kg(self) -> float:
        """The empty plate's mass, kg."""
        return self.mass_per_area_kg_m2 * self.length_m * self.width_m

    @classmethod
    def from_config(cls, config: dict) -> "PanelSettings":
        """Parse a validated config's ``panel``, ``geometry``, ``budget`` and particle material."""
        panel, geo, budget = config["panel"], config["geometry"], config["budget"]
        particle = particle_properties(config)
        one = sphere_mass(float(particle["radius_m"]), float(particle["density_kg_m3"]))
        area_mass = (2.0 * float(geo["face_sheet_density_kg_m3"]) * float(geo["face_sheet_thickness_m"])
                     + float(geo["core_density_kg_m3"]) * float(geo["core_height_m"]))
        plate_mass = area_mass * float(panel["length_m"]) * float(panel["width_m"])
        if budget["mode"] == "spheres":
            n_spheres = int(budget["spheres"])
        else:
            n_spheres = int(math.floor(float(budget["mass_fraction"]) * plate_mass / one))
        return cls(
            length_m=float(panel["length_m"]), width_m=float(panel["width_m"]),
            boundary=str(panel["boundary"]),
            face_thickness_m=float(geo["face_sheet_thickness_m"]),
            face_density_kg_m3=float(geo["face_sheet_density_kg_m3"]),
            face_youngs_modulus_pa=float(panel["face_youngs_modulus_pa"]),
            face_poisson_ratio=float(panel["face_poisson_ratio"]),
            core_height_m=float(geo["core_height_m"]), core_density_kg_m3=float(geo["core_density_kg_m3"]),
            core_shear_modulus_xz_pa=float(panel["core_shear_modulus_xz_pa"]),
            core_shear_modulus_yz_pa=float(panel["core_shear_modulus_yz_pa"]),
            cell_inscribed_diameter_m=float(geo["cell_inscribed_diameter_m"]),
            rotary_inertia=bool(panel["rotary_inertia"]), max_freq_hz=float(panel["max_freq_hz"]),
            damping_ratio=float(panel["damping_ratio"]),
            modal_force_n=tuple(float(f) for f in panel["modal_force_n"]),
            effective_mass_fraction=float(panel["effective_mass_fraction"]),
            regions=int(panel["regions"]), starts=int(panel["starts"]), seed=int(panel["seed"]),
            surrogate_draws=int(panel["surrogate_draws"]), confidence=float(panel["confidence"]),
            n_spheres=n_spheres, full_cell_spheres=full_cell_spheres(config), sphere_mass_kg=one)


def panel_params(config: dict) -> dict:
    """The part of a validated config the modal stage depends on (a rule's ``params``)."""
    keep = ("geometry", "panel", "budget", "fill", "environments", "materials",
            "particle_material", "surrogate", "optimisation")
    return {key: config[key] for key in keep}


@dataclass(frozen=True)
class PanelCheckSettings:
    """The DEM check of a mode (config ``panel.check``; :mod:`pidpipe.panel.check`).

    Attributes
    ----------
    environment : int
        Index into ``environments``: the mode checked is the lowest of its band.
    design : str
        The design kind whose layout is checked (``peak``, ``band_mean``, ``worst_case``).
    layout : str
        ``optimised``, ``source_antinode`` or ``source_uniform``.
    force_n : float or None
        The modal force F_0, N; None: the force that drives the panel model's layout, at its
        resonance, to the middle of the environment's band of G.
    groups, cells_per_group : int
        Groups of the filled cells by |phi|, and DEM cells per group.
    freq_points : int
        Frequencies of the sweep.
    freq_span_fraction : float
        The sweep runs from the fully loaded mode's frequency x (1 - span) to the bare one's x
        (1 + span).
    transient_cycles, measured_cycles, sem_block_cycles : int
    """

    environment: int = 0
    design: str = "band_mean"
    layout: str = "optimised"
    force_n: float | None = None
    groups: int = 3
    cells_per_group: int = 2
    freq_points: int = 13
    freq_span_fraction: float = 0.03
    transient_cycles: int = 40
    measured_cycles: int = 40
    sem_block_cycles: int = 2

    def __post_init__(self) -> None:
        if self.design not in ("peak", "band_mean", "worst_case"):
            raise ConfigError(f"config key panel.check.design = {self.design!r} is not allowed: "
                              "one of peak, band_mean, worst_case")
        if self.layout not in ("optimised", "source_antinode", "source_uniform"):
            raise ConfigError(f"config key panel.check.layout = {self.layout!r} is not allowed: "
                              "one of optimised, source_antinode, source_uniform")
        if self.force_n is not None and not (math.isfinite(self.force_n) and self.force_n > 0):
            raise ConfigError(f"config key panel.check.force_n = {self.force_n!r} is not allowed: "
                              "a force > 0 N, or null")
        counts = {"environment": (self.environment, 0), "groups": (self.groups, 1),
                  "cells_per_group": (self.cells_per_group, 1), "freq_points": (self.freq_points, 3),
                  "transient_cycles": (self.transient_cycles, 0),
                  "measured_cycles": (self.measured_cycles, 2),
                  "sem_block_cycles": (self.sem_block_cycles, 1)}
        for name, (value, low) in counts.items():
            if value < low:
                raise ConfigError(f"config key panel.check.{name} = {value} is not allowed: it must "
                                  f"be >= {low}")
        if not 0.0 < self.freq_span_fraction < 0.5:
            raise ConfigError(f"config key panel.check.freq_span_fraction = "
                              f"{self.freq_span_fraction} is not allowed: it must lie in (0, 0.5)")
        if self.measured_cycles < 2 * self.sem_block_cycles:
            raise ConfigError(f"config key panel.check.measured_cycles = {self.measured_cycles} is "
                              f"not allowed: it must hold two blocks of sem_block_cycles "
                              f"({self.sem_block_cycles})")

    @classmethod
    def from_config(cls, config: dict) -> "PanelCheckSettings":
        """Parse a validated config's ``panel.check``; the environment must exist."""
        check = dict(config["panel"].get("check", {}))
        force = check.get("force_n")
        settings = cls(**{**check, "force_n": None if force is None else float(force)})
        if settings.environment >= len(config["environments"]):
            raise ConfigError(f"config key panel.check.environment = {settings.environment} is not "
                              f"allowed: there are {len(config['environments'])} environments")
        return settings


def panel_check_params(config: dict) -> dict:
    """What the DEM check of a mode depends on (a rule's ``params``): the modal stage's part of
    the config and a packing's (pours, contact, timestep)."""
    from pidpipe.config.stages import stage_config

    return {**stage_config(config, "packing"), **panel_params(config)}
