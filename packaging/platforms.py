"""How this Linux x86-64 machine builds the project's binaries for each FMI 2.0 platform.

- linux64: `cargo zigbuild` (cargo-zigbuild with zig from the ziglang wheel, both in .venv)
  links against glibc 2.17, so the library loads on RHEL/CentOS 7, Ubuntu 18.04 and newer;
- win64: Debian's rustc-web/cargo-web build the standard library from source for
  x86_64-pc-windows-gnu (`-Zbuild-std`; rustup here has no Windows std), linked by mingw-w64;
  the DLL imports only system DLLs (Windows 10 or later).

`build(platform, cargo_args)` runs the build and returns the release directory that holds its
outputs (packaging/package.py builds the FMU's library with it). As a command it builds the
identification tool and aem-study's native master for users of each platform:

    .venv/bin/python packaging/platforms.py aem-identify|aem-run [--platforms win64]
        -> target/dist/<platform>/aem-identify[.exe], aem-run[.exe]
    .venv/bin/python packaging/platforms.py test [-- CARGO TEST ARGUMENTS]
        -> the workspace's Rust tests, built as the linux64 release is (cargo zigbuild test
           --release), reusing its crates
    .venv/bin/python packaging/platforms.py all [--platforms win64]
        -> the whole workspace in one build per platform (the FMU's library, which
           packaging/package.py --no-build then zips; both commands and the Python package's
           stepping library, aem_drive, into target/dist/)

Build times go to stderr; the output paths are checked for writing before anything is built.

Standard library and aem_electrolyser.cli only (the hook of a build from source puts python/ on
PYTHONPATH); scripts/setup.sh installs the toolchains.
"""

import argparse
import os
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from aem_electrolyser.cli import quiet_on_closed_stdout, writable

ROOT = Path(__file__).resolve().parent.parent
TARGET = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))


@dataclass(frozen=True)
class Platform:
    """One FMI platform folder and how its binaries are named and built."""

    name: str  # FMI 2.0 platform folder
    triple: str  # Rust target triple
    library_prefix: str  # cargo's cdylib name: <prefix><crate><suffix>
    library_suffix: str
    exe_suffix: str

    def library(self, crate):
        return f"{self.library_prefix}{crate}{self.library_suffix}"


LINUX64 = Platform("linux64", "x86_64-unknown-linux-gnu", "lib", ".so", "")
WIN64 = Platform("win64", "x86_64-pc-windows-gnu", "", ".dll", ".exe")
PLATFORMS = {p.name: p for p in (LINUX64, WIN64)}
#: linux64 built with plain `cargo build` against this machine's glibc: no zig, fast; for a build
#: from source (the demo, a wheel built from the sdist), not for a release.
HOST = Platform("linux64", "x86_64-unknown-linux-gnu", "lib", ".so", "")
#: The native stepping loop the Python package's hub runner loads (crates/drive).
DRIVE = "aem_drive"


def platform(name, native=False):
    """The Platform of FMI platform folder `name`; with native, linux64 is this machine's build."""
    return HOST if native and name == LINUX64.name else PLATFORMS[name]


#: The oldest glibc the linux64 binary links against (manylinux2014).
GLIBC = "2.17"
#: Debian's rustc-web and cargo-web (a newer Rust than rustup's, with the std sources).
DEBIAN_RUSTC, DEBIAN_CARGO = "/usr/bin/rustc", "/usr/bin/cargo"


def _require(tool, hint):
    path = shutil.which(tool)
    if path is None:
        sys.exit(f"platforms.py: {tool} not found; {hint} (scripts/setup.sh installs it)")
    return path


def _gcc_include(gcc):
    """A gcc's own include folder (stddef.h, mm_malloc.h, ...), which bindgen's clang needs to
    parse the FMI headers when the build points it at another target's sysroot."""
    return subprocess.run([gcc, "-print-file-name=include"], check=True, capture_output=True, text=True).stdout.strip()


def release_dir(platform):
    """Where `build(platform, ...)` leaves its release outputs."""
    if platform is HOST:
        return TARGET / "release"
    if platform is LINUX64:
        return TARGET / f"{LINUX64.triple}" / "release"
    return TARGET / platform.name / platform.triple / "release"


def command(platform, cargo_args):
    """(argv, environment) of the build of `cargo_args` (e.g. --lib -p x) for `platform`."""
    env = dict(os.environ)
    # cargo-zigbuild, and zig via `python -m ziglang`, live beside this interpreter (.venv/bin).
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    if platform is HOST:
        return ["cargo", "build", "--release", *cargo_args], env
    if platform is LINUX64:
        if shutil.which("cargo-zigbuild", path=env["PATH"]) is None:
            sys.exit(
                "platforms.py: cargo-zigbuild not found; pip install cargo-zigbuild ziglang (scripts/setup.sh does)"
            )
        # bindgen parses the FMI headers for their types only: this machine's gcc and libc
        # headers give the same x86-64 Linux types as glibc 2.17's. (cargo-zigbuild sets the
        # dashed form of the variable, which bindgen reads first, so it is replaced here.)
        gcc = _gcc_include(_require("gcc", "install gcc"))
        env[f"BINDGEN_EXTRA_CLANG_ARGS_{LINUX64.triple}"] = f"-I{gcc} -I/usr/include/x86_64-linux-gnu -I/usr/include"
        argv = ["cargo", "zigbuild", "--release", *cargo_args, "--target", f"{LINUX64.triple}.{GLIBC}"]
        return argv, env
    if platform is WIN64:
        for tool in (DEBIAN_RUSTC, DEBIAN_CARGO):
            if not Path(tool).is_file():
                sys.exit(f"platforms.py: {tool} not found; install Debian's rustc-web, cargo-web and rust-web-src")
        mingw_gcc = _require("x86_64-w64-mingw32-gcc", "install Debian's mingw-w64")
        env.update(
            {
                # -Zbuild-std is unstable: Debian's stable rustc allows it with RUSTC_BOOTSTRAP.
                "RUSTC_BOOTSTRAP": "1",
                "RUSTC": DEBIAN_RUSTC,
                "CARGO_TARGET_X86_64_PC_WINDOWS_GNU_LINKER": mingw_gcc,
                "BINDGEN_EXTRA_CLANG_ARGS_x86_64_pc_windows_gnu": f"-I{_gcc_include(mingw_gcc)}",
                # The std built from source carries its DWARF symbols: 1.9 MB unstripped.
                "CARGO_PROFILE_RELEASE_STRIP": "symbols",
            }
        )
        # Its own target directory: another compiler than rustup's, whose outputs must not mix.
        argv = [
            DEBIAN_CARGO,
            "build",
            "--release",
            *cargo_args,
            "-Zbuild-std=std,panic_unwind",
            "--target",
            WIN64.triple,
            "--target-dir",
            str(TARGET / WIN64.name),
        ]
        return argv, env
    raise ValueError(platform)


def build(platform, cargo_args, extra_env=None):
    """Builds `cargo_args` for `platform`; prints (on stderr) and returns (release directory, seconds)."""
    argv, env = command(platform, cargo_args)
    env.update(extra_env or {})
    started = time.monotonic()
    subprocess.run(argv, cwd=ROOT, check=True, env=env)
    seconds = time.monotonic() - started
    print(f"built {platform.name} ({' '.join(cargo_args)}) in {seconds:.1f} s", file=sys.stderr)
    return release_dir(platform), seconds


def test(cargo_test_args):
    """Runs the workspace's tests built for linux64 by cargo zigbuild as the release is (its
    profile, target folder and compiled crates: only the test targets are compiled anew), so the
    tests run the code that ships. Debug assertions and overflow checks are the fast lane's
    (scripts/check.sh: the unit tests in the dev profile) and the fuzzers'. Returns cargo's exit
    status."""
    build_argv, env = command(LINUX64, ["--workspace", "--locked"])
    assert build_argv[:3] == ["cargo", "zigbuild", "--release"], build_argv
    # `cargo zigbuild` knows no test; the binary itself does (cargo-zigbuild test).
    zigbuild = shutil.which("cargo-zigbuild", path=env["PATH"])
    argv = [zigbuild, "test", "--release", *build_argv[3:], *cargo_test_args]
    env["AEM_MODEL_DESCRIPTION"] = ""  # as the release's build: its build script's input unchanged
    return subprocess.run(argv, cwd=ROOT, env=env).returncode


def main(argv=None):
    parser = argparse.ArgumentParser(description="Build a command of the workspace for each platform.")
    parser.add_argument(
        "tool",
        choices=["aem-identify", "aem-run", "all", "test"],
        help="the command to build, all: the workspace (the FMU's library and both commands), "
        "or test: run the workspace's tests built for linux64",
    )
    parser.add_argument("cargo_test_args", nargs="*", help="with test: after --, passed to cargo test")
    parser.add_argument("--platforms", default=",".join(PLATFORMS), help="comma-separated FMI platforms")
    parser.add_argument(
        "--native",
        action="store_true",
        help="linux64 built with plain cargo against this machine's glibc (no zig; not for a release)",
    )
    parser.add_argument(
        "--dest", type=Path, help="copy the commands into this folder [default: target/dist/<platform>/]"
    )
    args = parser.parse_args(argv)
    if args.tool == "test":
        sys.exit(test(args.cargo_test_args))
    names = [p.strip() for p in args.platforms.split(",") if p.strip()]
    for name in names:
        if name not in PLATFORMS:
            parser.error(f"unknown platform {name}; choose from {', '.join(PLATFORMS)}")
    tools = ["aem-identify", "aem-run"] if args.tool == "all" else [args.tool]
    if args.dest is not None and len(names) > 1:
        parser.error("--dest takes the commands of one platform")

    def files(name):
        """The commands, and with all the Python package's stepping library (aem_drive)."""
        found = [f"{tool}{PLATFORMS[name].exe_suffix}" for tool in tools]
        return found + [PLATFORMS[name].library(DRIVE)] if args.tool == "all" else found

    outputs = {name: [writable((args.dest or TARGET / "dist" / name) / file) for file in files(name)] for name in names}

    def build_one(name):
        if args.tool == "all":  # the library from the repository's model description (package.py checks its GUID)
            release, _ = build(platform(name, args.native), ["--workspace", "--locked"], {"AEM_MODEL_DESCRIPTION": ""})
        else:
            release, _ = build(platform(name, args.native), ["--bin", args.tool, "--package", args.tool, "--locked"])
        for output in outputs[name]:
            shutil.copy2(release / output.name, output)

    # One after the other: run at once (each has its own target folder) they took as long on
    # two cores (364 s against 132 + 231 s).
    for name in names:
        build_one(name)
    for paths in outputs.values():
        for output in paths:
            print(f"wrote {output}")


if __name__ == "__main__":
    quiet_on_closed_stdout(main)
