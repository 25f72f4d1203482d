"""Bad config values stop the run with one message naming the key, the value and what is allowed."""

import copy

import pytest
import yaml

from pidpipe.config import (
    DEFAULT_CONFIG_PATH,
    budget_spheres,
    load_config,
    spheres_for_fill,
    validate_config,
)
from pidpipe.config.schema import check_environments_in_reach
from pidpipe.errors import ConfigError
from pidpipe.steps.params import workflow_config

RAW = yaml.safe_load(DEFAULT_CONFIG_PATH.read_text())


def _mutated(change):
    raw = copy.deepcopy(RAW)
    change(raw)
    return raw


BAD = [
    ("negative frequency", lambda c: c["grid"].update(freq_hz=[-50, 100]), ["grid.freq_hz[0]", "-50", "> 0"]),
    ("fill over 100 %", lambda c: c["grid"].update(fill_pct=[25, 120]), ["grid.fill_pct[1]", "120", "<= 100"]),
    ("missing material", lambda c: c.update(particle_material="steel"), ["particle_material", "steel", "acrylic"]),
    ("pair of an unknown material", lambda c: c["pairs"].append({"materials": ["steel", "acrylic"], "friction": 0.1, "restitution": 0.5}),
     ["pairs[3].materials", "steel"]),
    ("unknown pour engine", lambda c: c["fidelity"].update(pour_engine="lammps"), ["fidelity.pour_engine", "'lammps'", "liggghts"]),
    ("wrong type", lambda c: c["fidelity"].update(measured_cycles="forty"), ["fidelity.measured_cycles", "'forty'", "integer"]),
    ("unknown key", lambda c: c["fidelity"].update(timestpe_rayleigh_fraction=0.1), ["timestpe_rayleigh_fraction", "not a known key", "timestep_rayleigh_fraction"]),
    ("empty grid", lambda c: c["grid"].update(accel_g=[]), ["grid.accel_g", "[]", "at least 1"]),
    ("restitution above 1", lambda c: c["pairs"][1].update(restitution=1.2), ["pairs[1].restitution", "1.2", "<= 1"]),
    ("restitution 0", lambda c: c["pairs"][1].update(restitution=0.0), ["pairs[1].restitution", "0.0", "> 0"]),
    ("budget below one cell", lambda c: c["budget"].update(mode="spheres", spheres=2), ["budget", "2 spheres", "lowest fill"]),
    ("band with lo > hi", lambda c: c["environments"][0].update(accel_g=[6, 5]), ["environments[0].accel_g", "[6, 5]", "low <= high"]),
    ("command in a number field", lambda c: c["materials"]["acrylic"].update(density_kg_m3="1180\nshell rm -rf /"),
     ["materials.acrylic.density_kg_m3", "shell rm -rf", "number"]),
    ("command in a material name", lambda c: c["materials"].update({"x; shell touch pwned": c["materials"]["acrylic"]}),
     ["materials", "x; shell touch pwned", "must match"]),
    ("missing pair for the particles", lambda c: c.update(pairs=[p for p in c["pairs"] if p["materials"] != ["acrylic", "acrylic"]]),
     ["pairs", "acrylic, acrylic"]),
]


@pytest.mark.parametrize("name, change, fragments", BAD, ids=[b[0] for b in BAD])
def test_bad_value_gives_one_clear_message(name, change, fragments):
    with pytest.raises(ConfigError) as info:
        validate_config(_mutated(change))
    message = str(info.value)
    assert "\n" not in message
    for fragment in fragments:
        assert fragment in message, f"{fragment!r} missing from: {message}"


def test_defaults_are_filled_and_exponents_read_as_numbers():
    raw = _mutated(lambda c: (c.pop("fidelity"), c["materials"]["acrylic"].update(youngs_modulus_pa="2.84e9")))
    cfg = validate_config(raw)
    assert cfg["fidelity"]["timestep_rayleigh_fraction"] == 0.2
    assert cfg["materials"]["acrylic"]["youngs_modulus_pa"] == 2.84e9


def test_fill_definitions():
    cfg = load_config()
    assert [spheres_for_fill(cfg, r) for r in (25, 50, 75, 90)] == [5, 11, 16, 19]
    cfg["fill"]["definition"] = "source_36"
    assert [spheres_for_fill(cfg, r) for r in (25, 50, 75, 90)] == [9, 18, 27, 32]


def test_budget_from_mass_fraction():
    cfg = load_config()
    # coupon: 2 sheets 0.1 x 0.1 x 0.25 mm at 2800 kg/m^3 + core 0.1 x 0.1 x 25.4 mm at 32.1 kg/m^3
    coupon = 2 * 0.01 * 0.25e-3 * 2800 + 0.01 * 25.4e-3 * 32.1
    sphere = 1180 * 4 / 3 * 3.141592653589793 * 1.25e-3**3
    assert budget_spheres(cfg) == int(0.1 * coupon / sphere)


def test_missing_file(tmp_path):
    with pytest.raises(ConfigError, match="does not exist"):
        load_config(tmp_path / "nope.yaml")


def test_schema_lists_exactly_the_surrogate_methods():
    from pidpipe.config import load_schema
    from pidpipe.design.surrogate import METHODS

    allowed = load_schema()["properties"]["surrogate"]["properties"]["method"]["enum"]
    assert sorted(allowed) == sorted(METHODS)


def test_unknown_surrogate_method_is_refused():
    with pytest.raises(ConfigError, match="surrogate.method"):
        validate_config(_mutated(lambda c: c["surrogate"].update(method="kriging")))



OUT_OF_REACH = [
    ("band beyond the grid's frequencies", lambda c: c["environments"][0].update(freq_hz=[2000, 3000]),
     ["environments[0].freq_hz", "[2000, 3000]", "[50, 1000] Hz", "extend grid.freq_hz"]),
    ("band below the grid's accelerations", lambda c: c["grid"].update(accel_g=[5, 10]),
     ["environments[1].accel_g", "[1, 2]", "[5, 10] g", "extend grid.accel_g"]),
]


@pytest.mark.parametrize("name, change, fragments", OUT_OF_REACH, ids=[b[0] for b in OUT_OF_REACH])
def test_an_environment_out_of_the_grids_reach_is_refused_before_the_campaign(name, change, fragments):
    """The workflow's config check and check-config refuse it in one line; validate_config
    alone does not (``pidpipe case`` validates a config whose grid is its one case)."""
    raw = _mutated(change)
    validate_config(raw)
    for check in (workflow_config, lambda raw: check_environments_in_reach(validate_config(raw))):
        with pytest.raises(ConfigError) as info:
            check(raw)
        message = str(info.value)
        assert "\n" not in message
        for fragment in fragments:
            assert fragment in message, f"{fragment!r} missing from: {message}"


def test_an_external_table_lifts_the_grid_reach_check():
    """With optimisation.external_ceq_table the surrogate's domain is that table's: the grid's
    range says nothing about it (the file's existence is checked by the workflow)."""
    raw = _mutated(lambda c: (c["environments"][0].update(freq_hz=[2000, 3000]),
                              c["optimisation"].update(external_ceq_table="table.csv")))
    config = validate_config(raw)
    check_environments_in_reach(config)
    assert config["environments"][0]["freq_hz"] == [2000, 3000]
