#!/usr/bin/env bash
# Installs what building and testing need, and nothing when it is already there (the demo needs
# far less: scripts/demo.sh installs its own; scripts/prerequisites.sh says what is supported):
# - libclang (fmi-sys runs bindgen on the FMI 2.0 headers), from Debian's packages;
# - gcc and valgrind (tests/python/test_importers.py compiles the C master in tests/c_master
#   and runs it under valgrind memcheck and AddressSanitizer), from Debian's packages;
# - the cross toolchains of the packaged FMU's binaries (packaging/platforms.py): mingw-w64's
#   gcc and Debian's rustc-web, cargo-web and rust-web-src (win64: the std built from source),
#   and wine64 to test the Windows binaries here, from Debian's packages (about 300 MB to
#   download, 1.9 GB installed, under a minute); cargo-zigbuild and
#   ziglang (linux64 against glibc 2.17) come with requirements.txt;
# - cargo-fuzz (scripts/fuzz.sh), from crates.io; libtbb12 (Ecos, an importer in the tests);
# - .venv with the Python tools of requirements.txt (fmpy, numpy, scipy, pytest, ...; uv installs
#   them) and the package aem_electrolyser itself, editable, with its commands (pyproject.toml).
set -euo pipefail
cd "$(dirname "$0")/.."

source scripts/prerequisites.sh
require_toolchains
require_libclang

if ! command -v gcc >/dev/null || ! command -v valgrind >/dev/null; then
  echo "setup: installing gcc, libc6-dev and valgrind (the C master and its memory test)"
  apt_install gcc libc6-dev valgrind
fi

if ! command -v x86_64-w64-mingw32-gcc >/dev/null || [ ! -x /usr/bin/rustc ] || [ ! -d /usr/lib/rustlib/src/rust/library ] \
   || [ ! -x /usr/lib/wine/wine64 ]; then
  echo "setup: installing mingw-w64, rustc-web, cargo-web, rust-web-src and wine64 (the win64 binaries and their tests)"
  apt_install gcc-mingw-w64-x86-64-win32 rustc-web cargo-web rust-web-src wine64
fi

if [ ! -e /usr/lib/x86_64-linux-gnu/libtbb.so.12 ]; then
  echo "setup: installing libtbb12 (the Ecos co-simulation engine of the tests)"
  apt_install libtbb12
fi

if ! cargo fuzz --version >/dev/null 2>&1; then
  echo "setup: installing cargo-fuzz (coverage-guided fuzzing)"
  cargo install cargo-fuzz --locked --version 0.13.2 --quiet
fi

require_venv
# uv installs the pins (from the registry and its cache) in seconds where pip takes minutes.
if [ ! -x .venv/bin/python ] || ! cmp -s requirements.txt .venv/requirements.installed; then
  echo "setup: installing requirements.txt into .venv"
  [ -x .venv/bin/python ] || python3 -m venv .venv
  [ -x .venv/bin/uv ] || .venv/bin/python -m pip install -q --disable-pip-version-check "$(grep '^uv==' requirements.txt)"
  .venv/bin/uv pip install --quiet --python .venv/bin/python -r requirements.txt
  cp requirements.txt .venv/requirements.installed
fi

# The package aem_electrolyser (pyproject.toml), editable: python/ of this checkout, and its commands.
if [ ! -x .venv/bin/aem-prequalify ]; then
  echo "setup: installing the aem-electrolyser package (editable) into .venv"
  .venv/bin/uv pip install --quiet --python .venv/bin/python --no-deps --no-build-isolation -e .
fi
