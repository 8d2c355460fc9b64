"""hatchling build hook: puts the FMU, the native commands and the hub runner's native stepping
loop (aem_drive) into the wheel and tags it for their platform.

Why hatchling and not maturin: maturin ships the binaries of one crate built by one toolchain,
while this wheel carries the two-platform FMU that packaging/package.py assembles (linux64 by
cargo-zigbuild against glibc 2.17, win64 by Debian's rustc with the std built from source) and
the commands of two crates (aem-identify, aem-run). The hook runs the project's own build;
hatchling does the rest of a standard wheel (metadata, entry points, the sdist).

Two ways to build:

- A release (packaging/release.py): AEM_WHEEL_PLATFORM=linux64 or win64 takes what the release
  built, target/fmu/AemElectrolyser.fmu (both binaries) and target/dist/<platform>/aem-identify,
  aem-run, aem_drive (portable builds), and tags the wheel manylinux2014_x86_64 or win_amd64.
- From source (pip install of the sdist, or of the checkout without -e; Linux x86-64, Rust and
  libclang needed): builds the FMU's linux64 binary and the commands in one cargo build, with
  cargo-zigbuild against glibc 2.17 when it is installed (a manylinux2014 wheel), else with
  plain cargo for this machine (a linux_x86_64 wheel).

An editable install (pip install -e .) takes nothing: the package then finds the build tree.
"""

import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

from hatchling.builders.hooks.plugin.interface import BuildHookInterface

MODEL = "AemElectrolyser"
TOOLS = ("aem-identify", "aem-run")
#: The native stepping loop of the package's hub runner (crates/drive), per platform.
DRIVE = {"linux64": "libaem_drive.so", "win64": "aem_drive.dll"}
RELEASE_TAGS = {"linux64": "py3-none-manylinux_2_17_x86_64.manylinux2014_x86_64", "win64": "py3-none-win_amd64"}
EXE = {"linux64": "", "win64": ".exe"}


class BuildError(RuntimeError):
    """What the wheel cannot be built without; the message says what to do."""


class ArtefactHook(BuildHookInterface):
    PLUGIN_NAME = "custom"

    def initialize(self, version, build_data):
        if self.target_name != "wheel" or version == "editable":
            return
        root = Path(self.root)
        target = Path(os.environ.get("CARGO_TARGET_DIR", root / "target"))
        platform = os.environ.get("AEM_WHEEL_PLATFORM")
        if platform:
            if platform not in RELEASE_TAGS:
                raise BuildError(f"AEM_WHEEL_PLATFORM={platform}: choose from {', '.join(RELEASE_TAGS)}")
            fmu, tools, tag = _release_artefacts(target, platform)
        else:
            fmu, tools, tag = _build_from_source(root, target)
        build_data["pure_python"] = False
        build_data["tag"] = tag
        build_data["force_include"][str(fmu)] = f"aem_electrolyser/data/{MODEL}.fmu"
        for tool in tools:
            build_data["force_include"][str(tool)] = f"aem_electrolyser/bin/{tool.name}"


def _release_artefacts(target, platform):
    fmu = target / "fmu" / f"{MODEL}.fmu"
    if not fmu.is_file():
        raise BuildError(f"{fmu} not found: packaging/release.py builds it")
    with zipfile.ZipFile(fmu) as z:
        shipped = {n.split("/")[1] for n in z.namelist() if n.startswith("binaries/")}
    if shipped != set(RELEASE_TAGS):
        raise BuildError(f"{fmu} holds binaries for {sorted(shipped)}; a release wheel ships {sorted(RELEASE_TAGS)}")
    tools = [target / "dist" / platform / f"{tool}{EXE[platform]}" for tool in TOOLS]
    tools.append(target / "dist" / platform / DRIVE[platform])
    for tool in tools:
        if not tool.is_file():
            raise BuildError(f"{tool} not found: packaging/release.py builds it")
    return fmu, tools, RELEASE_TAGS[platform]


def _build_from_source(root, target):
    if sys.platform != "linux" or sysconfig.get_platform() != "linux-x86_64":
        raise BuildError(
            f"aem-electrolyser builds from source on Linux x86-64 only (this is {sysconfig.get_platform()}); "
            "install a platform wheel instead"
        )
    if shutil.which("cargo") is None:
        raise BuildError(
            "building aem-electrolyser from source needs Rust (cargo) and libclang: install them "
            "(rustup; apt install libclang-dev) or a platform wheel"
        )
    out = target / "wheel-artefacts"
    out.mkdir(parents=True, exist_ok=True)
    fmu = out / f"{MODEL}.fmu"
    # cargo-zigbuild with zig (pip install cargo-zigbuild ziglang) links against glibc 2.17: then
    # the wheel is a manylinux2014 one; without it, plain cargo builds for this machine's glibc.
    here = str(Path(sys.executable).parent)
    portable = shutil.which("cargo-zigbuild", path=f"{here}{os.pathsep}{os.environ.get('PATH', '')}") is not None
    native = [] if portable else ["--native"]
    env = dict(os.environ, PYTHONPATH=str(root / "python"), CARGO_TARGET_DIR=str(target))
    packaging = root / "packaging"
    subprocess.run(
        [sys.executable, str(packaging / "platforms.py"), "all", "--platforms", "linux64", *native, "--dest", str(out)],
        cwd=root,
        env=env,
        check=True,
    )
    subprocess.run(
        [
            sys.executable,
            str(packaging / "package.py"),
            "--no-build",
            "--platforms",
            "linux64",
            *native,
            "--output",
            str(fmu),
        ],
        cwd=root,
        env=env,
        check=True,
    )
    tag = (
        RELEASE_TAGS["linux64"]
        if portable
        else "py3-none-" + sysconfig.get_platform().replace("-", "_").replace(".", "_")
    )
    return fmu, [out / tool for tool in TOOLS] + [out / DRIVE["linux64"]], tag
