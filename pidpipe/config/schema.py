"""Load ``config.yaml`` and validate it against the JSON schema, with the checks a schema cannot make.

Everything a deck, a packing or an optimisation uses comes through :func:`validate_config`:
the JSON schema (``workflow/schemas/config.schema.yaml``) checks types, bounds and unknown
keys and fills defaults; :func:`_check_semantics` checks what a schema cannot (materials that
exist, bands with low <= high, cases that a budget can hold). A failure raises
:class:`~pidpipe.errors.ConfigError` with one message naming the key, the value and what is
allowed.
"""

from __future__ import annotations

import copy
import functools
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from pidpipe.config.derived import (
    budget_spheres,
    full_cell_spheres,
    pair_properties,
    spheres_for_fill,
)
from pidpipe.errors import ConfigError

if TYPE_CHECKING:
    import jsonschema

REPO_ROOT = Path(__file__).resolve().parents[2]


SCHEMA_PATH = REPO_ROOT / "workflow" / "schemas" / "config.schema.yaml"


DEFAULT_CONFIG_PATH = REPO_ROOT / "config.yaml"


# YAML 1.1 (PyYAML, and so Snakemake) reads 2.84e9 as text; YAML 1.2 and every engineer read it
# as a number. Strings that are exactly a number in exponent notation are read as that number.
_EXPONENT_NUMBER = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)[eE][-+]?\d+$")


def load_schema() -> dict:
    """The configuration's JSON schema as a dict (a copy: changing it changes no validation)."""
    return copy.deepcopy(_parsed_schema())


@functools.lru_cache(maxsize=1)
def _parsed_schema() -> dict:
    """The schema file, parsed once per process (libyaml's parser where PyYAML has it).

    Snakemake validates the config about a dozen times while it reads the Snakefile (once per
    variant of a fidelity study, for one); parsing the schema each time in pure Python cost
    several CPU-seconds per ``snakemake`` command. Never changed: it is only read.
    """
    loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
    with open(SCHEMA_PATH, encoding="utf-8") as handle:
        return yaml.load(handle, Loader=loader)  # noqa: S506 (a safe loader)


@functools.lru_cache(maxsize=1)
def _schema_validator():
    """The validator of :func:`_parsed_schema` that fills defaults, built once per process."""
    import jsonschema   # here, not at the top: a case job reads validated config only

    return _with_defaults(jsonschema.Draft202012Validator)(_parsed_schema())


def load_config(path: str | Path = DEFAULT_CONFIG_PATH) -> dict:
    """Read a YAML config file and return it validated, with defaults filled.

    Raises
    ------
    ConfigError
        If the file is missing, is not YAML, or holds an invalid value.
    """
    path = Path(path)
    try:
        with open(path, encoding="utf-8") as handle:
            raw = yaml.safe_load(handle)
    except FileNotFoundError:
        raise ConfigError(f"config file {path} does not exist") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"config file {path} is not valid YAML: {exc}") from None
    return validate_config(raw)


def validate_config(raw: Any) -> dict:
    """Validate a config mapping and return a copy with defaults filled.

    Parameters
    ----------
    raw : Any
        The config as loaded from YAML (or assembled by Snakemake).

    Returns
    -------
    dict
        The validated config.
    """
    if not isinstance(raw, dict):
        raise ConfigError(f"the config must be a mapping of keys to values, got {type(raw).__name__}")
    config = _read_exponent_numbers(copy.deepcopy(_plain(raw)))
    errors = list(_schema_validator().iter_errors(config))
    if errors:
        import jsonschema

        raise ConfigError(_describe_schema_error(jsonschema.exceptions.best_match(errors)))
    _check_semantics(config)
    return config


def _plain(value: Any) -> Any:
    """Convert mapping/sequence subclasses (Snakemake's OrderedDict, ruamel types) to dict/list."""
    if isinstance(value, dict):
        return {str(k) if not isinstance(k, str) else k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def _read_exponent_numbers(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _read_exponent_numbers(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_read_exponent_numbers(v) for v in value]
    if isinstance(value, str) and _EXPONENT_NUMBER.match(value.strip()):
        return float(value)
    return value


def _with_defaults(validator_class):
    """A validator class that fills ``default`` values of missing properties while validating."""
    import jsonschema

    validate_properties = validator_class.VALIDATORS["properties"]

    def set_defaults(validator, properties, instance, schema):
        if isinstance(instance, dict):
            for name, subschema in properties.items():
                if "default" in subschema and name not in instance:
                    instance[name] = copy.deepcopy(subschema["default"])
        yield from validate_properties(validator, properties, instance, schema)

    return jsonschema.validators.extend(validator_class, {"properties": set_defaults})


def _key_path(path) -> str:
    text = ""
    for part in path:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text or "(top level)"


def _describe_schema_error(error: jsonschema.ValidationError) -> str:
    key = _key_path(error.absolute_path)
    value = error.instance
    kind, limit = error.validator, error.validator_value
    allowed = {
        "type": lambda: f"must be of type {limit}",
        "minimum": lambda: f"must be >= {limit}",
        "maximum": lambda: f"must be <= {limit}",
        "exclusiveMinimum": lambda: f"must be > {limit}",
        "exclusiveMaximum": lambda: f"must be < {limit}",
        "enum": lambda: f"must be one of {', '.join(map(str, limit))}",
        "minItems": lambda: f"must have at least {limit} item(s)",
        "maxItems": lambda: f"must have at most {limit} item(s)",
        "uniqueItems": lambda: "must not repeat a value",
        "minLength": lambda: f"must have at least {limit} character(s)",
        "maxLength": lambda: f"must have at most {limit} character(s)",
        "minProperties": lambda: f"must have at least {limit} entr{'y' if limit == 1 else 'ies'}",
        "pattern": lambda: f"must match {limit} (plain names and numbers only)",
    }
    if kind == "additionalProperties":
        known = sorted(error.schema.get("properties", {}))
        unknown = sorted(set(value) - set(known)) if isinstance(value, dict) else []
        where = key if error.absolute_path else "the top level"
        return (f"config key {', '.join(repr(u) for u in unknown)} under {where} is not a known key; "
                f"allowed keys: {', '.join(known)}")
    if kind == "required":
        return f"config key {key} is missing a required entry: {error.message}"
    if kind == "propertyNames":
        return f"config key {key}: a name {error.message}; names must start with a letter and hold only letters, digits and _"
    description = error.schema.get("description", "")
    text = allowed.get(kind, lambda: error.message)()
    shown = _short(value)
    message = f"config key {key} = {shown} is not allowed: it {text}"
    if description and kind != "pattern":
        message += f" ({description.strip()})"
    return message


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def _check_semantics(config: dict) -> None:
    materials = config["materials"]
    for role in ("particle_material", "wall_material"):
        name = config[role]
        if name not in materials:
            raise ConfigError(f"config key {role} = {name!r} is not allowed: it must name one of the "
                              f"materials ({', '.join(sorted(materials))})")
    particle = config["particle_material"]
    if "radius_m" not in materials[particle]:
        raise ConfigError(f"config key materials.{particle}.radius_m is missing: the particle material "
                          "needs a sphere radius")
    seen = set()
    for index, pair in enumerate(config["pairs"]):
        for name in pair["materials"]:
            if name not in materials:
                raise ConfigError(f"config key pairs[{index}].materials = {pair['materials']!r} is not allowed: "
                                  f"{name!r} is not one of the materials ({', '.join(sorted(materials))})")
        key = frozenset(pair["materials"])
        if key in seen:
            raise ConfigError(f"config key pairs[{index}].materials = {pair['materials']!r} is not allowed: "
                              "this pair is defined twice")
        seen.add(key)
    for a, b in ((particle, particle), (particle, config["wall_material"])):
        pair_properties(config, a, b)
    for index, env in enumerate(config["environments"]):
        for band in ("freq_hz", "accel_g"):
            low, high = env[band]
            if not low <= high:
                raise ConfigError(f"config key environments[{index}].{band} = {env[band]!r} is not allowed: "
                                  "it must be [low, high] with low <= high")
            if low <= 0:
                raise ConfigError(f"config key environments[{index}].{band} = {env[band]!r} is not allowed: "
                                  "both ends must be > 0")
    fidelity = config["fidelity"]
    if fidelity["max_measured_cycles"] < fidelity["measured_cycles"]:
        raise ConfigError(f"config key fidelity.max_measured_cycles = {fidelity['max_measured_cycles']!r} "
                          f"is not allowed: it must be at least fidelity.measured_cycles "
                          f"({fidelity['measured_cycles']})")
    far_cycles = config["refine"].get("far_pilot_measured_cycles")
    if far_cycles is not None and far_cycles < 2 * fidelity["sem_block_cycles"]:
        raise ConfigError(f"config key refine.far_pilot_measured_cycles = {far_cycles!r} is not "
                          "allowed: a short pilot must hold two blocks of "
                          f"fidelity.sem_block_cycles ({fidelity['sem_block_cycles']}) for its "
                          "standard error")
    cell_spheres = [spheres_for_fill(config, r) for r in config["grid"]["fill_pct"]]
    for fill, count in zip(config["grid"]["fill_pct"], cell_spheres):
        if count < 1:
            raise ConfigError(f"config key grid.fill_pct contains {fill!r}, which gives {count} spheres per "
                              f"cell with full_cell_spheres = {full_cell_spheres(config)}: every fill must "
                              "give at least one sphere")
    if config["environments"]:
        budget = budget_spheres(config)
        least = min(cell_spheres)
        if budget < least:
            raise ConfigError(f"config key budget = {_short(config['budget'])} is not allowed: it gives "
                              f"{budget} spheres, fewer than one cell at the lowest fill needs ({least})")


def check_environments_in_reach(config: dict) -> None:
    """Refuse an environment whose band leaves the grid's range of f or G.

    A campaign's check (the workflow's and ``pidpipe check-config``'s), not
    :func:`validate_config`'s: ``pidpipe case`` validates a config whose grid is its one case.

    The surrogate is fitted over the grid's bounding box and the optimisation refuses a band
    outside it (:func:`pidpipe.design.optimisation.environment_bounds`), so without this check
    such a config ran the whole campaign and failed only at the optimise step. With
    ``optimisation.external_ceq_table`` the domain is that table's, read later, and nothing is
    checked here.

    Parameters
    ----------
    config : dict
        A validated config (:func:`validate_config`).

    Raises
    ------
    ConfigError
        One line naming the environment, its band, the grid's range and what to change.
    """
    if config["optimisation"].get("external_ceq_table") is not None:
        return
    grid = config["grid"]
    for index, env in enumerate(config["environments"]):
        for band, unit in (("freq_hz", "Hz"), ("accel_g", "g")):
            low, high = env[band]
            reach = (min(grid[band]), max(grid[band]))
            if low < reach[0] or high > reach[1]:
                raise ConfigError(
                    f"config key environments[{index}].{band} = {env[band]!r} is not allowed: the "
                    f"band of {env['name']!r} leaves the grid's range [{reach[0]:g}, {reach[1]:g}] "
                    f"{unit}, where the campaign measures C_eq; extend grid.{band} to cover it, or "
                    "narrow the band")
