#!/usr/bin/env bash
# One-time (and idempotent) set-up: a Python 3.11 virtual environment in .venv with geocode
# and everything it needs. Reruns take a second when nothing changed.
#   --slurm (or GEOCODE_SLURM=1): also the SLURM executor plugin, for profiles/slurm
set -euo pipefail
cd "$(dirname "$0")/.."

extras=dev
for arg in "$@"; do
  case $arg in
    --slurm) GEOCODE_SLURM=1 ;;
    *) echo "setup: unknown option $arg; the only one is --slurm" >&2; exit 2 ;;
  esac
done
[ "${GEOCODE_SLURM:-0}" = 1 ] && extras=dev,slurm

python=${GEOCODE_PYTHON:-}
for candidate in python3.11 python3; do
  [ -n "$python" ] && break
  if command -v "$candidate" >/dev/null && "$candidate" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))'; then
    python=$candidate
  fi
done
[ -n "$python" ] || { echo "setup: Python 3.11 is required (bpy 5.0.1 supports no other); install it and rerun, or set GEOCODE_PYTHON=/path/to/python3.11" >&2; exit 1; }

# open3d links libusb-1.0; install it when we may, else say the exact line to run.
if ! ldconfig -p 2>/dev/null | grep -q 'libusb-1.0.so.0'; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    apt-get install -y -q libusb-1.0-0 >/dev/null 2>&1 || { apt-get update -q >/dev/null && apt-get install -y -q libusb-1.0-0 >/dev/null; }
  else
    echo "setup: open3d needs the system library libusb-1.0; run: sudo apt-get install -y libusb-1.0-0" >&2
    exit 1
  fi
fi

# The report's test opens the page in headless Chromium (Debian's package); without it that test is skipped.
if ! command -v chromium >/dev/null; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    apt-get install -y -q chromium >/dev/null 2>&1 || { apt-get update -q >/dev/null && apt-get install -y -q chromium >/dev/null; }
  else
    echo "setup: the report test needs Chromium; run: sudo apt-get install -y chromium" >&2
  fi
fi

[ -x .venv/bin/python ] || "$python" -m venv .venv
stamp=.venv/.geocode-installed
want=$( (cat pyproject.toml scripts/setup.sh; echo "$extras") | sha1sum | cut -d' ' -f1)
if [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
  .venv/bin/python -m pip install -q --upgrade pip
  # torch first, pinned: where a CPU wheel is on hand (this workplace) pip takes it instead
  # of a multi-GB CUDA build; elsewhere this is the usual registry install.
  .venv/bin/python -c 'import torch' 2>/dev/null || .venv/bin/python -m pip install -q "${GEOCODE_TORCH:-torch==2.13.0}"
  .venv/bin/python -m pip install -q -e ".[$extras]"
  echo "$want" > "$stamp"
fi
# Blender is a hard dependency: stop here, with its error, rather than let the tests find out.
if ! bpy_error=$(.venv/bin/python -c 'import bpy' 2>&1 >/dev/null); then
  echo "setup: bpy does not import in .venv ($(printf '%s\n' "$bpy_error" | tail -n 1)); install what it names (a system library: apt-get) or remove .venv and rerun" >&2
  exit 1
fi
echo "setup: ready (.venv, $(.venv/bin/python --version))"
