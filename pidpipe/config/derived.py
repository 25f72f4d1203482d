"""Quantities derived from a validated config: material and pair properties, spheres per fill, the budget.
"""

from __future__ import annotations

import math

from pidpipe.errors import ConfigError
from pidpipe.physics.contact import sphere_mass


def pair_properties(config: dict, material_a: str, material_b: str) -> dict:
    """Friction and restitution of a material pair, in either order.

    Returns
    -------
    dict
        ``{"friction": mu, "restitution": e_n}``.
    """
    wanted = {material_a, material_b}
    for pair in config["pairs"]:
        if set(pair["materials"]) == wanted:
            return {"friction": float(pair["friction"]), "restitution": float(pair["restitution"])}
    raise ConfigError(f"config key pairs has no entry for materials [{material_a}, {material_b}]: "
                      "add {materials: [" f"{material_a}, {material_b}" "], friction: ..., restitution: ...}")


def particle_properties(config: dict) -> dict:
    """The particle material's properties (radius_m, density_kg_m3, youngs_modulus_pa, poisson_ratio)."""
    return dict(config["materials"][config["particle_material"]])


def wall_properties(config: dict) -> dict:
    """The wall material's properties (density_kg_m3, youngs_modulus_pa, poisson_ratio)."""
    return dict(config["materials"][config["wall_material"]])


def full_cell_spheres(config: dict) -> int:
    """Spheres in a cell at 100 % fill under the configured fill definition."""
    fill = config["fill"]
    if fill["definition"] == "source_36":
        return int(fill["source_full_cell_spheres"])
    return int(fill["poured_capacity_spheres"])


def spheres_at_fill(full_cell_spheres: int, fill_pct: float) -> int:
    """Spheres per cell at fill r (percent): round half up of full_cell_spheres * r / 100."""
    return int(math.floor(full_cell_spheres * float(fill_pct) / 100.0 + 0.5))


#: Decimals of a fill (%) that names what a cell holds: enough that 100 n / s_full gives n back.
FILL_DECIMALS = 3


def cell_fill_pct(n_spheres: int, full_cell_spheres: int) -> float:
    """The fill (%) of a cell holding ``n_spheres``: 100 n / full_cell_spheres, rounded to
    :data:`FILL_DECIMALS` (5 of 21 spheres: 23.81 %).

    Every table row, surrogate and verifying case takes a cell's fill as this, the count it
    holds, not the nominal fill it was poured for (25 % of 21 spheres pours 5 of them).
    """
    return round(100.0 * int(n_spheres) / int(full_cell_spheres), FILL_DECIMALS)


def poured_fill(fill_pct: float, full_cell_spheres: int) -> tuple[float, int]:
    """The fill (%) and sphere count a cell poured for ``fill_pct`` holds.

    Parameters
    ----------
    fill_pct : float
        A nominal fill, percent (a fractional number of spheres per cell in general).
    full_cell_spheres : int
        Spheres at 100 %.

    Returns
    -------
    (float, int)
        :func:`cell_fill_pct` of n, and n = :func:`spheres_at_fill` (round half up).

    Raises
    ------
    ConfigError
        The fill holds no whole sphere.
    """
    n_spheres = spheres_at_fill(int(full_cell_spheres), float(fill_pct))
    if n_spheres < 1:
        raise ConfigError(f"a fill of {fill_pct:g} % holds no whole sphere "
                          f"({full_cell_spheres} spheres fill a cell)")
    fill = cell_fill_pct(n_spheres, full_cell_spheres)
    if spheres_at_fill(int(full_cell_spheres), fill) != n_spheres:    # cannot happen for
        raise ConfigError(f"fill {fill:g} % does not give {n_spheres} spheres back")  # sane sizes
    return fill, n_spheres


def spheres_for_fill(config: dict, fill_pct: float) -> int:
    """Spheres per cell at fill r (percent) under the configured fill definition."""
    return spheres_at_fill(full_cell_spheres(config), fill_pct)


def coupon_mass_kg(config: dict) -> float:
    """Mass of the empty coupon (two face sheets and the core), kg."""
    geo = config["geometry"]
    area = geo["coupon_width_m"] * geo["coupon_length_m"]
    sheets = 2.0 * area * geo["face_sheet_thickness_m"] * geo["face_sheet_density_kg_m3"]
    core = area * geo["core_height_m"] * geo["core_density_kg_m3"]
    return sheets + core


def panel_n_cells(config: dict) -> int:
    """Cells of the structure that may be filled: ``panel.n_cells``, or the coupon's N if null."""
    n_cells = config.get("panel", {}).get("n_cells")
    return int(config["geometry"]["coupon_n_cells"] if n_cells is None else n_cells)


def panel_mass_kg(config: dict) -> float:
    """Mass of the empty panel, kg: the coupon's, scaled by panel cells / coupon cells."""
    return coupon_mass_kg(config) * panel_n_cells(config) / int(config["geometry"]["coupon_n_cells"])


def budget_spheres(config: dict) -> int:
    """The particle budget n_b of the panel (``panel.n_cells`` cells), in spheres."""
    budget = config["budget"]
    if budget["mode"] == "spheres":
        return int(budget["spheres"])
    particle = particle_properties(config)
    one = sphere_mass(particle["radius_m"], particle["density_kg_m3"])
    return int(math.floor(budget["mass_fraction"] * panel_mass_kg(config) / one))
