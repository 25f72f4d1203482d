"""Material and contact-pair properties: what a contact law is made of, in SI units."""

from __future__ import annotations

from dataclasses import dataclass, replace


@dataclass(frozen=True)
class Material:
    """An isotropic elastic material.

    Parameters
    ----------
    youngs_modulus_pa : float
        Young's modulus E, Pa.
    poisson_ratio : float
        Poisson's ratio nu.
    density_kg_m3 : float
        Density, kg/m^3 (used for particles only).
    radius_m : float
        Sphere radius, m (used for particles only).
    name : str
        The material's key in the config (for messages and records).
    """

    youngs_modulus_pa: float
    poisson_ratio: float
    density_kg_m3: float = 0.0
    radius_m: float = 0.0
    name: str = ""

    def scaled(self, youngs_modulus_scale: float) -> "Material":
        """The same material with E multiplied by ``youngs_modulus_scale``."""
        return replace(self, youngs_modulus_pa=self.youngs_modulus_pa * youngs_modulus_scale)


@dataclass(frozen=True)
class PairProperties:
    """Contact properties of a pair of materials.

    Parameters
    ----------
    friction : float
        Sliding (Coulomb) friction coefficient mu >= 0.
    restitution : float
        Normal coefficient of restitution e_n in (0, 1].
    """

    friction: float
    restitution: float
