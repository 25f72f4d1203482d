#!/usr/bin/env bash
# Install what pidpipe needs on a Debian machine that has Python 3.11+:
#   - LIGGGHTS 3.8 from Debian's packages (without the recommended ParaView),
#   - a virtual environment .venv with pidpipe and its dependencies from PyPI, at the versions
#     pinned in requirements.lock (so a fresh machine gets the SciPy, Numba... the tests passed on).
# Safe to run again: it skips what is already there. Run as root, or with sudo available.
# `bash install.sh --refresh-lock` re-resolves pyproject.toml's dependencies (test and docs
# extras included) in a scratch environment and rewrites requirements.lock; run the tests after.
# Quiet by default: a few progress lines; the package managers' full output is kept in a log
# and printed only if a step fails. `bash install.sh --verbose` (or PIDPIPE_VERBOSE=1) shows it all.
set -euo pipefail
cd "$(dirname "$0")"

verbose="${PIDPIPE_VERBOSE:-0}"
refresh_lock=0
for argument in "$@"; do
    case "$argument" in
        -v|--verbose) verbose=1 ;;
        --refresh-lock) refresh_lock=1 ;;
        -h|--help) sed -n '2,11p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) echo "install.sh: unknown option $argument (use --verbose or --help)" >&2; exit 2 ;;
    esac
done

log="$(mktemp "${TMPDIR:-/tmp}/pidpipe-install.XXXXXX.log")"
trap 'rm -f "$log"' EXIT

# Run a command; quiet: its output goes to the log, which is printed if it fails.
step() {
    if [ "$verbose" = 1 ]; then "$@"; return; fi
    if ! "$@" >>"$log" 2>&1; then
        echo "install.sh: failed: $*" >&2
        echo "install.sh: its output follows (also rerun with --verbose):" >&2
        cat "$log" >&2
        exit 1
    fi
}

as_root() { if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi; }
apt_updated=0
apt_install() {
    if [ "$apt_updated" -eq 0 ]; then step as_root apt-get update -qq; apt_updated=1; fi
    step as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "$@"
}

if ! command -v liggghts >/dev/null 2>&1 && [ -z "${PIDPIPE_LIGGGHTS:-}" ]; then
    echo "install.sh: installing LIGGGHTS from Debian's packages ..."
    apt_install liggghts
fi

PYTHON="${PYTHON:-python3}"
lock=requirements.lock

if [ "$refresh_lock" = 1 ]; then
    scratch="$(mktemp -d "${TMPDIR:-/tmp}/pidpipe-lock.XXXXXX")"
    echo "install.sh: resolving pyproject.toml's dependencies afresh in $scratch ..."
    step "$PYTHON" -m venv "$scratch/venv"
    step "$scratch/venv/bin/python" -m pip install -q --upgrade pip
    step "$scratch/venv/bin/python" -m pip install -q '.[test]'
    {
        echo "# Pinned versions of pidpipe's dependencies (test and docs extras included), used as"
        echo "# pip constraints by install.sh. Refresh: bash install.sh --refresh-lock"
        echo "# Resolved with $("$scratch/venv/bin/python" --version) on $(uname -m)."
        "$scratch/venv/bin/python" -m pip freeze --exclude-editable | grep -iv '^pidpipe'
    } > "$lock.part"
    mv "$lock.part" "$lock"
    rm -rf "$scratch"
    echo "install.sh: wrote $lock; now run the tests: .venv/bin/python -m pytest"
    exit 0
fi
if [ ! -x .venv/bin/python ]; then
    echo "install.sh: creating the virtual environment .venv ..."
    if ! "$PYTHON" -m venv .venv >>"$log" 2>&1; then
        rm -rf .venv
        apt_install python3-venv
        step "$PYTHON" -m venv .venv
    fi
fi

stamp=.venv/.pidpipe-installed
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ] || [ "$lock" -nt "$stamp" ]; then
    echo "install.sh: installing pidpipe and its dependencies into .venv (about a minute) ..."
    step .venv/bin/python -m pip install -q --upgrade pip
    step .venv/bin/python -m pip install -q -c "$lock" -e '.[test]'
    touch "$stamp"
fi
# Numba compiles the DEM's kernels on first use (about 50 CPU seconds) and caches them; compile
# them now, once, so that neither a campaign's first jobs nor the tests each pay it. With the
# cache already filled this loads it (about a second).
echo "install.sh: compiling the DEM's kernels (once; about a minute on a fresh checkout) ..."
step .venv/bin/python -m pidpipe.dem.compile_ahead
echo "install.sh: ready: $(command -v liggghts || echo "${PIDPIPE_LIGGGHTS:-}"), .venv"
