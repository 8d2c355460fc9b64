# Sourced by scripts/demo.sh and scripts/setup.sh: what both need before anything is built, and
# how they install a missing Debian package (apt-get; sudo when not root).
#
# Supported: Debian 12 or Ubuntu 22.04 and newer on x86-64, with Rust >= 1.89 (rustup) and
# Python >= 3.11. Root or sudo is needed only when a Debian package is missing.

sudo=""
[ "$(id -u)" -ne 0 ] && sudo="sudo"
apt_updated=""
apt_install() {
  if ! command -v apt-get >/dev/null; then
    echo "error: $* needed and this is not a Debian or Ubuntu system: install the equivalent packages" >&2
    exit 1
  fi
  [ -n "$apt_updated" ] || $sudo apt-get update -qq
  apt_updated=1
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "$@" >/dev/null
}

# The minimum versions: Cargo.toml's rust-version and pyproject.toml's requires-python.
require_toolchains() {
  if ! command -v cargo >/dev/null || ! command -v rustc >/dev/null; then
    echo "error: Rust is not installed: https://rustup.rs (1.89 or newer), then run this again" >&2
    exit 1
  fi
  local rust
  rust=$(rustc --version | awk '{print $2}')
  if ! printf '1.89.0\n%s\n' "${rust%%-*}" | sort -V -C; then
    echo "error: Rust $rust is older than 1.89: rustup update" >&2
    exit 1
  fi
  if ! python3 -c 'import sys; sys.exit(sys.version_info < (3, 11))' 2>/dev/null; then
    echo "error: Python 3.11 or newer is needed as python3 (this is $(python3 --version 2>&1))" >&2
    exit 1
  fi
}

# libclang: fmi-sys runs bindgen on the FMI 2.0 headers.
# (grep without -q reads all of ldconfig's output, so pipefail never sees a SIGPIPE.)
require_libclang() {
  if [ -z "${LIBCLANG_PATH:-}" ] && ! { /sbin/ldconfig -p 2>/dev/null || true; } | grep -E 'libclang(-[0-9.]+)?\.so' >/dev/null; then
    echo "setup: installing libclang-dev (needed by bindgen)"
    apt_install libclang-dev
  fi
}

# Debian's own python3 needs python3-venv for `python3 -m venv`.
require_venv() {
  python3 -c 'import ensurepip' 2>/dev/null || apt_install python3-venv
}
