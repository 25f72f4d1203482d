"""The physical scene of a cell, as both solvers see it: the cell, its materials, the contact law's inputs, the timestep.

The LIGGGHTS decks (:func:`pidpipe.liggghts.decks.material_values`) and the in-repo DEM
(:func:`pidpipe.dem.from_scene.dem_scene`) both build their contact law from one
:class:`CellScene`, so the two solvers cannot drift apart on an input: the same Young's modulus
scale, the same friction switch, the same timestep rule.
"""

from __future__ import annotations

from dataclasses import dataclass

from pidpipe.cell.geometry import HexCell
from pidpipe.config.settings import (
    Fidelity,
    Geometry,
    Materials,
    PourSettings,
    ShakeSettings,
)
from pidpipe.physics.contact import rayleigh_time
from pidpipe.physics.materials import Material, PairProperties
from pidpipe.physics.timestep import TimestepPlan, plan_timestep


@dataclass(frozen=True)
class CellScene:
    """One honeycomb cell, its spheres' and walls' materials and how the contact is resolved.

    Attributes
    ----------
    cell : HexCell
        The cell's geometry, m.
    materials : Materials
        Particle and wall materials (unscaled) and their pairs' friction and restitution.
    fidelity : Fidelity
        Timestep fraction, Young's modulus scale, rotation and friction switches.
    """

    cell: HexCell
    materials: Materials
    fidelity: Fidelity

    @classmethod
    def from_settings(cls, geometry: Geometry, materials: Materials,
                      fidelity: Fidelity) -> "CellScene":
        """The scene of the configured cell."""
        return cls(HexCell(geometry.cell_inscribed_diameter_m, geometry.core_height_m),
                   materials, fidelity)

    @classmethod
    def of(cls, settings: "PourSettings | ShakeSettings") -> "CellScene":
        """The scene of a stage's settings (anything with geometry, materials and fidelity)."""
        return cls.from_settings(settings.geometry, settings.materials, settings.fidelity)

    @classmethod
    def from_config(cls, config: dict) -> "CellScene":
        """The scene of a validated config (or of a stage's part of one)."""
        return cls.from_settings(Geometry.from_config(config), Materials.from_config(config),
                                 Fidelity.from_config(config))

    @property
    def radius_m(self) -> float:
        """Sphere radius, m."""
        return self.materials.particle.radius_m

    @property
    def particle(self) -> Material:
        """The particles' material with the fidelity's Young's modulus scale applied."""
        return self.materials.particle.scaled(self.fidelity.youngs_modulus_scale)

    @property
    def wall(self) -> Material:
        """The walls' material with the fidelity's Young's modulus scale applied."""
        return self.materials.wall.scaled(self.fidelity.youngs_modulus_scale)

    def pair(self, kind: str) -> PairProperties:
        """Friction and restitution of ``kind`` (``pp``, ``pw`` or ``ww``) as simulated:
        friction 0 when the fidelity switches the tangential contact off."""
        props = {"pp": self.materials.particle_particle, "pw": self.materials.particle_wall,
                 "ww": self.materials.wall_wall}[kind]
        friction = props.friction if self.fidelity.friction else 0.0
        return PairProperties(friction=friction, restitution=props.restitution)

    @property
    def rayleigh_time_s(self) -> float:
        """Rayleigh time of the (softened) particles, s."""
        p = self.particle
        return rayleigh_time(p.radius_m, p.density_kg_m3, p.youngs_modulus_pa, p.poisson_ratio)

    def timestep(self, freq_hz: float) -> TimestepPlan:
        """The timestep at ``freq_hz`` (Hz): at most the configured fraction of the Rayleigh
        time, a whole number of steps per cycle."""
        return plan_timestep(self.rayleigh_time_s, self.fidelity.timestep_rayleigh_fraction, freq_hz)
