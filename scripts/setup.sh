#!/usr/bin/env bash
# Installs what building and testing need, and nothing when it is already there (the demo needs
# far less: scripts/demo.sh installs its own; scripts/prerequisites.sh says what is supported):
# - libclang (fmi-sys runs bindgen on the FMI 2.0 headers), from Debian's packages;
# - gcc and valgrind (tests/python/fmu/test_importers.py compiles the C master in tests/c_master
#   and runs it under valgrind memcheck and AddressSanitizer), from Debian's packages;
# - the cross toolchains of the packaged FMU's binaries (packaging/platforms.py): mingw-w64's
#   gcc and Debian's rustc-web, cargo-web and rust-web-src (win64: the std built from source),
#   and wine64 to test the Windows binaries here, from Debian's packages (about 300 MB to
#   download, 1.9 GB installed, under a minute); cargo-zigbuild and
#   ziglang (linux64 against glibc 2.17) come with requirements.txt;
# - libtbb12 (Ecos, an importer in the tests); cargo-fuzz (scripts/fuzz.sh) comes built with
#   requirements.txt (a wheel that carries the binary), instead of a minute of cargo install;
# - .venv with the Python tools of requirements.txt (fmpy, numpy, scipy, pytest, ...; uv installs
#   them) and the package aem_electrolyser itself, editable, with its commands (pyproject.toml).
set -euo pipefail
cd "$(dirname "$0")/.."

source scripts/prerequisites.sh
require_toolchains

# Every missing Debian package in one apt-get call.
missing=()
{ /sbin/ldconfig -p 2>/dev/null || true; } | grep -E 'libclang(-[0-9.]+)?\.so' >/dev/null || [ -n "${LIBCLANG_PATH:-}" ] \
  || missing+=(libclang-dev)                                   # bindgen (fmi-sys)
command -v gcc >/dev/null || missing+=(gcc libc6-dev)          # the C master of the tests
command -v valgrind >/dev/null || missing+=(valgrind)          # its memory test
command -v x86_64-w64-mingw32-gcc >/dev/null || missing+=(gcc-mingw-w64-x86-64-win32)  # win64 linker
[ -x /usr/bin/rustc ] || missing+=(rustc-web)                  # win64: Debian's rustc ...
[ -x /usr/bin/cargo ] || missing+=(cargo-web)                  # ... and cargo
[ -d /usr/lib/rustlib/src/rust/library ] || missing+=(rust-web-src)  # ... with the std's sources
[ -x /usr/lib/wine/wine64 ] || missing+=(wine64)               # the win64 binaries' tests
[ -e /usr/lib/x86_64-linux-gnu/libtbb.so.12 ] || missing+=(libtbb12)  # Ecos, an importer of the tests
python3 -c 'import ensurepip' 2>/dev/null || missing+=(python3-venv)
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]} (Debian's packages)"
  apt_install "${missing[@]}"
fi

# uv installs the pins (from the registry and its cache) in seconds where pip takes minutes.
# --compile-bytecode writes every module's .pyc once, at install (about 40 s of CPU): without
# them an interpreter compiles each module it imports, every time, wherever
# PYTHONDONTWRITEBYTECODE is set (as on CI machines): importing pandapower took 7.5 s instead of
# 3.3, and the tests start hundreds of interpreters.
if [ ! -x .venv/bin/python ] || ! cmp -s requirements.txt .venv/requirements.installed; then
  echo "setup: installing requirements.txt into .venv"
  [ -x .venv/bin/python ] || python3 -m venv .venv
  [ -x .venv/bin/uv ] || .venv/bin/python -m pip install -q --disable-pip-version-check "$(grep '^uv==' requirements.txt)"
  .venv/bin/uv pip install --quiet --compile-bytecode --python .venv/bin/python -r requirements.txt
  cp requirements.txt .venv/requirements.installed
fi

# The package aem_electrolyser (pyproject.toml), editable: python/ of this checkout, and its commands.
if [ ! -x .venv/bin/aem-prequalify ]; then
  echo "setup: installing the aem-electrolyser package (editable) into .venv"
  .venv/bin/uv pip install --quiet --python .venv/bin/python --no-deps --no-build-isolation -e .
fi
# Its modules' .pyc too (the editable install links python/, which uv does not compile); a module
# edited since is compiled again where it is imported.
.venv/bin/python -m compileall -q python >/dev/null
