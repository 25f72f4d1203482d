"""LIGGGHTS decks rendered from validated values.

The templates live in ``templates/``. Everything that reaches a deck goes through a filter
that accepts only what it expects: ``num`` a finite real number (written in its shortest exact
form), ``int`` a non-negative integer, ``filename`` a plain file name, ``label`` a case id.
A string from the config therefore can never become a LIGGGHTS command (``shell``,
``include``, ``variable`` ...): it is refused with a :class:`~pidpipe.errors.ConfigError`.
"""

from __future__ import annotations

import math
import numbers
import re
from pathlib import Path

import jinja2
import numpy as np

from pidpipe.cell.geometry import HexCell
from pidpipe.cell.scene import CellScene
from pidpipe.errors import ConfigError
from pidpipe.physics.contact import STANDARD_GRAVITY_M_S2

TEMPLATE_DIR = Path(__file__).resolve().parents[2] / "templates"
_FILENAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]{0,127}$")
_LABEL = re.compile(r"^[A-Za-z0-9_.]{1,128}$")


def _given(value):
    if isinstance(value, jinja2.Undefined):
        raise ConfigError(f"deck template needs a value that was not given: {value._undefined_name}")
    return value


def _num(value) -> str:
    _given(value)
    if isinstance(value, bool) or not isinstance(value, (numbers.Real, np.floating, np.integer)):
        raise ConfigError(f"deck value {value!r} is not allowed: only finite numbers reach a LIGGGHTS deck")
    value = float(value)
    if not math.isfinite(value):
        raise ConfigError(f"deck value {value!r} is not allowed: it must be finite")
    return repr(value)


def _int(value) -> str:
    _given(value)
    if isinstance(value, bool) or not isinstance(value, (numbers.Integral, np.integer)) or value < 0:
        raise ConfigError(f"deck value {value!r} is not allowed: it must be a non-negative integer")
    return str(int(value))


def _filename(value) -> str:
    _given(value)
    if not isinstance(value, str) or not _FILENAME.match(value):
        raise ConfigError(f"deck file name {value!r} is not allowed: only letters, digits, _ . - "
                          "and no directories")
    return value


def _label(value) -> str:
    _given(value)
    if not isinstance(value, str) or not _LABEL.match(value):
        raise ConfigError(f"case label {value!r} is not allowed: only letters, digits, _ and .")
    return value


def template_environment() -> jinja2.Environment:
    """The Jinja environment of the deck templates (StrictUndefined, trimmed blocks)."""
    env = jinja2.Environment(loader=jinja2.FileSystemLoader(TEMPLATE_DIR),
                             undefined=jinja2.StrictUndefined, trim_blocks=True,
                             lstrip_blocks=True, keep_trailing_newline=True, autoescape=False)
    env.filters.update(num=_num, int=_int, filename=_filename, label=_label)
    return env


def material_values(scene: CellScene) -> dict:
    """Contact and material values of atom types 1 (particles) and 2 (walls).

    Young's moduli carry the fidelity's softening factor; with friction off every friction
    coefficient is 0. The wall-wall pair never touches anything but LIGGGHTS needs a value
    (:class:`~pidpipe.config.settings.Materials`).

    Parameters
    ----------
    scene : CellScene
    """
    particle, wall = scene.particle, scene.wall
    pairs = {kind: scene.pair(kind) for kind in ("pp", "pw", "ww")}
    return {
        "youngs_pa": {"particle": particle.youngs_modulus_pa, "wall": wall.youngs_modulus_pa},
        "poisson": {"particle": particle.poisson_ratio, "wall": wall.poisson_ratio},
        "restitution": {kind: pair.restitution for kind, pair in pairs.items()},
        "friction": {kind: pair.friction for kind, pair in pairs.items()},
        "diameter_m": 2.0 * particle.radius_m,
        "density_kg_m3": particle.density_kg_m3,
        "rotation": scene.fidelity.rotation,
        "gravity_m_s2": STANDARD_GRAVITY_M_S2,
    }


def simulation_box(cell: HexCell, top_z_m: float, travel_m: float, radius_m: float) -> dict:
    """A fixed simulation box around the cell's whole travel, m.

    Parameters
    ----------
    cell : HexCell
    top_z_m : float
        Top of the side walls (the lid, or the top of the open pouring cell), m.
    travel_m : float
        How far below its start the cell moves (2 W for z = W(cos wt - 1)), m.
    radius_m : float
        Sphere radius, m (the margin around the cell).
    """
    margin = 2.0 * radius_m
    half = cell.circumradius_m + margin
    return {"xlo": -half, "xhi": half, "ylo": -half, "yhi": half,
            "zlo": cell.floor_z_m - travel_m - margin, "zhi": top_z_m + margin}


def render(template: str, values: dict) -> str:
    """Render one deck template with the given (already computed) values."""
    try:
        return template_environment().get_template(template).render(**values)
    except jinja2.UndefinedError as exc:
        raise ConfigError(f"deck template {template} needs a value that was not given: {exc}") from None


def common_values(scene: CellScene, positions_m: np.ndarray, timestep_s: float, mesh_file: str,
                  case_label: str, deck_kind: str, box: dict, thermo_every: int) -> dict:
    """Values every deck needs (materials, particles, mesh, box, timestep)."""
    radius = scene.radius_m
    positions = np.asarray(positions_m, dtype=float).reshape(-1, 3)
    return {
        **material_values(scene),
        "deck_kind": deck_kind,
        "case_label": case_label,
        "box": box,
        "neighbor_skin_m": 0.5 * radius,
        "timestep_s": timestep_s,
        "positions_m": positions.tolist(),
        "mesh_file": mesh_file,
        "thermo_every": thermo_every,
    }
