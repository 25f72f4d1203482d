#!/usr/bin/env bash
# Install what pidpipe needs on a Debian machine that has Python 3.10+:
#   - LIGGGHTS 3.8 from Debian's packages (without the recommended ParaView),
#   - a virtual environment .venv with pidpipe and its dependencies from PyPI.
# Safe to run again: it skips what is already there. Run as root, or with sudo available.
set -euo pipefail
cd "$(dirname "$0")"

as_root() { if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi; }
apt_updated=0
apt_install() {
    if [ "$apt_updated" -eq 0 ]; then as_root apt-get update -qq; apt_updated=1; fi
    DEBIAN_FRONTEND=noninteractive as_root apt-get install -y -qq --no-install-recommends "$@"
}

if ! command -v liggghts >/dev/null 2>&1 && [ -z "${PIDPIPE_LIGGGHTS:-}" ]; then
    echo "install.sh: installing LIGGGHTS from Debian's packages ..."
    apt_install liggghts
fi

PYTHON="${PYTHON:-python3}"
if [ ! -x .venv/bin/python ]; then
    echo "install.sh: creating the virtual environment .venv ..."
    if ! "$PYTHON" -m venv .venv 2>/dev/null; then
        rm -rf .venv
        apt_install python3-venv
        "$PYTHON" -m venv .venv
    fi
fi

stamp=.venv/.pidpipe-installed
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ]; then
    echo "install.sh: installing pidpipe and its dependencies into .venv ..."
    .venv/bin/python -m pip install -q --upgrade pip
    .venv/bin/python -m pip install -q -e '.[test]'
    touch "$stamp"
fi
echo "install.sh: ready: $(command -v liggghts || echo "${PIDPIPE_LIGGGHTS:-}"), .venv"
