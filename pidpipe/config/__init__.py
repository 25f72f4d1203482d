"""The config: ``config.yaml`` validated against its JSON schema, and what follows from it.

:mod:`.schema` loads and validates (:func:`load_config`, :func:`validate_config`);
:mod:`.settings` parses a validated config (or a stage's part of it) once into the frozen,
typed settings a pour or a shaking run takes; :mod:`.sections` types the campaign's other
sections and parses the whole config once (:class:`~pidpipe.config.sections.Settings`);
:mod:`.studies` types the studies' sections; :mod:`.stages` cuts out the part each rule
depends on;
:mod:`.derived` computes what follows from a validated config (pair properties, spheres per
fill, the sphere budget).
"""

from pidpipe.config.derived import (
                                    budget_spheres,
                                    coupon_mass_kg,
                                    full_cell_spheres,
                                    pair_properties,
                                    panel_mass_kg,
                                    panel_n_cells,
                                    particle_properties,
                                    spheres_for_fill,
                                    wall_properties,
)
from pidpipe.config.schema import (
                                    DEFAULT_CONFIG_PATH,
                                    REPO_ROOT,
                                    SCHEMA_PATH,
                                    load_config,
                                    load_schema,
                                    validate_config,
)

__all__ = [
    "DEFAULT_CONFIG_PATH", "REPO_ROOT", "SCHEMA_PATH", "budget_spheres", "coupon_mass_kg",
    "full_cell_spheres", "load_config", "panel_mass_kg", "panel_n_cells", "load_schema", "pair_properties", "particle_properties",
    "spheres_for_fill", "validate_config", "wall_properties",
]
