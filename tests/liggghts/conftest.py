import pytest

from pidpipe.config.settings import PourSettings
from pidpipe.liggghts.pour import pour
from tests.conftest import short_config


@pytest.fixture(scope="session")
def half_fill_packing(tmp_path_factory):
    """The default config's 50 % packing (11 spheres), poured and tapped once per session."""
    return pour(PourSettings.from_config(short_config()), 50, 0, tmp_path_factory.mktemp("pour50"))
