"""install.sh's compile step (pidpipe.dem.compile_ahead): the kernel's entry points compiled for
exactly the argument types a pour and a shaking run pass, so that neither compiles again."""

from __future__ import annotations

import json
import subprocess
import sys

# In a fresh process: compile (or load) ahead, count the kernel's compiled signatures, then pour
# and shake a short DEM case as the campaign does, and count them again.
SCRIPT = r"""
import json
from pidpipe.cases import CaseSpec
from pidpipe.config.settings import PourSettings, ShakeSettings
from pidpipe.dem import kernel
from pidpipe.dem.case import run_dem_case
from pidpipe.dem.compile_ahead import compile_kernels
from pidpipe.dem.pour import pour
from tests.conftest import short_config

compile_kernels()
ahead = {name: len(getattr(kernel, name).signatures) for name in ("set_up", "run")}
config = short_config(transient=2, measured=4)
packing = pour(PourSettings.from_config(config), 25, 0)
record = run_dem_case(ShakeSettings.from_config(config), CaseSpec(500.0, 5.0, 25.0), packing)
after = {name: len(getattr(kernel, name).signatures) for name in ("set_up", "run")}
print(json.dumps({"ahead": ahead, "after": after, "status": record.status}))
"""


def test_the_campaigns_calls_find_the_kernels_compiled_ahead():
    done = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True,
                          check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    counts = json.loads(done.stdout.strip().splitlines()[-1])
    assert counts["ahead"] == {"set_up": 1, "run": 1}
    assert counts["after"] == counts["ahead"], "a pour or a case compiled the kernel again"
    assert counts["status"] in ("ok", "flagged")


# In a fresh process after the command: where each entry point came from (Numba's own counts).
LOADED = r"""
import json
from pidpipe.dem import kernel
from pidpipe.dem.compile_ahead import compile_kernels

compile_kernels()
print(json.dumps({name: {"hits": sum(getattr(kernel, name).stats.cache_hits.values()),
                         "misses": sum(getattr(kernel, name).stats.cache_misses.values())}
                  for name in ("set_up", "run")}))
"""


def test_the_command_says_the_kernels_are_in_the_cache_and_a_new_process_loads_them():
    done = subprocess.run([sys.executable, "-m", "pidpipe.dem.compile_ahead"],
                          capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "kernels are in Numba's cache" in done.stdout
    loaded = subprocess.run([sys.executable, "-c", LOADED], capture_output=True, text=True,
                            check=False)
    assert loaded.returncode == 0, loaded.stderr[-3000:]
    counts = json.loads(loaded.stdout.strip().splitlines()[-1])
    # every entry point the command compiled is read from the cache, none compiled again
    assert counts == {"set_up": {"hits": 1, "misses": 0}, "run": {"hits": 1, "misses": 0}}
