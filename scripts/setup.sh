#!/usr/bin/env bash
# Installs what building and testing need, and nothing when it is already there:
# - libclang (fmi-sys runs bindgen on the FMI 2.0 headers), from Debian's packages;
# - .venv with the Python tools of requirements.txt (fmpy, numpy, scipy, pytest, ...).
set -euo pipefail
cd "$(dirname "$0")/.."

if [ -z "${LIBCLANG_PATH:-}" ] && ! ldconfig -p 2>/dev/null | grep -qE 'libclang(-[0-9.]+)?\.so'; then
  echo "setup: installing libclang-dev (needed by bindgen)"
  sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq libclang-dev >/dev/null
fi

if [ ! -x .venv/bin/python ] || ! cmp -s requirements.txt .venv/requirements.installed; then
  echo "setup: creating .venv from requirements.txt"
  python3 -m venv .venv
  .venv/bin/python -m pip install -q --disable-pip-version-check -r requirements.txt
  cp requirements.txt .venv/requirements.installed
fi
