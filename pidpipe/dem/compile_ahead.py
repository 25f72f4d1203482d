"""Compile the DEM's kernels into Numba's cache before the first campaign needs them.

Numba compiles :mod:`pidpipe.dem.kernel` the first time a process calls it and keeps the
machine code in its cache (``__pycache__`` beside the kernel's source, or ``NUMBA_CACHE_DIR``);
every later process loads it from there in about a second. Compiling costs about 50 CPU
seconds, and in a fresh checkout the campaign's first DEM jobs (its pours, two at a time on two
cores) would each pay it at once. ``install.sh`` runs this module instead, once, as it installs
the rest, so that a campaign or a test run starts from compiled kernels
(``benchmarks/bench_campaign.py`` records the campaign's wall either way).

It pours one packing of the default config (:func:`pidpipe.dem.pour.pour`, 5 spheres at 25 %),
which calls both of the kernel's entry points as the pours and the shaking runs do, so they are
compiled for the argument types the campaign passes.
The host-coupled kernels (:mod:`pidpipe.dem.coupled`, used by ``snakemake host`` and the
panel's check only) are left to compile on their first use.

Run: python -m pidpipe.dem.compile_ahead
"""

from __future__ import annotations

import sys
import time


def compile_kernels() -> tuple[float, float]:
    """Compile (or load from the cache) the kernel's entry points; return (CPU s, wall s) spent.

    Raises
    ------
    pidpipe.dem.compiled.KernelError
        Numba could not compile the kernel (the message names the fix).
    """
    cpu, wall = time.process_time(), time.perf_counter()
    from pidpipe.config import load_config
    from pidpipe.config.settings import PourSettings
    from pidpipe.dem.pour import pour

    pour(PourSettings.from_config(load_config()), fill_pct=25.0, replicate=0)
    return time.process_time() - cpu, time.perf_counter() - wall


def main() -> int:
    """Compile the kernels and say what it took; exit status 1 with the reason if Numba fails."""
    from pidpipe.errors import PidpipeError

    try:
        cpu_s, wall_s = compile_kernels()
    except (PidpipeError, ImportError) as error:
        print(f"pidpipe: the compiled DEM's kernels could not be built: {error}", file=sys.stderr)
        return 1
    print(f"pidpipe: the compiled DEM's kernels are in Numba's cache ({cpu_s:.1f} CPU-s, "
          f"{wall_s:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
