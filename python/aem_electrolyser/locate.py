"""Where the installed package finds its FMU and its native commands: the one place that knows.

An installed wheel carries them inside the package (`data/AemElectrolyser.fmu`,
`bin/aem-identify`, `bin/aem-run`, and the hub runner's stepping loop `bin/libaem_drive.so` or
`bin/aem_drive.dll`); an editable install in a source checkout uses the build
tree (`target/fmu/`, `target/release/`, `target/dist/<platform>/`), which `bash scripts/demo.sh`
or `bash scripts/test.sh` fill.
"""

import os
import zipfile
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent
MODEL_IDENTIFIER = "AemElectrolyser"
FMU_NAME = f"{MODEL_IDENTIFIER}.fmu"
#: The environment variable that overrides the FMU everywhere.
FMU_VARIABLE = "AEM_FMU"


class NotBuilt(FileNotFoundError):
    """The FMU or a native command is not in this installation; the message says how to get it."""


def checkout():
    """The source checkout this package runs from (an editable install), or None."""
    root = PACKAGE.parents[1]
    return root if (root / "Cargo.toml").is_file() and (root / "modelDescription.xml").is_file() else None


def _target():
    root = checkout()
    if root is None:
        return None
    return Path(os.environ.get("CARGO_TARGET_DIR", root / "target"))


def fmu_path(path=None):
    """The FMU to use: `path` if given, else the environment variable AEM_FMU, else the FMU of
    this installation (the wheel's, or the checkout's `target/fmu/AemElectrolyser.fmu`).

    Raises NotBuilt when the chosen file does not exist (naming AEM_FMU when the path came from
    it)."""
    if path is None and fmu_from_environment():
        path = Path(os.environ[FMU_VARIABLE])
        if not path.is_file():
            raise NotBuilt(f"{FMU_VARIABLE}: {path}: no such FMU")
        return path
    if path is not None:
        path = Path(path)
        if not path.is_file():
            raise NotBuilt(f"{path}: no such FMU")
        return path
    bundled = PACKAGE / "data" / FMU_NAME
    if bundled.is_file():
        return bundled
    target = _target()
    if target is not None and (target / "fmu" / FMU_NAME).is_file():
        return target / "fmu" / FMU_NAME
    if target is not None:
        raise NotBuilt(
            f"{target / 'fmu' / FMU_NAME} not found: build it with bash scripts/demo.sh (or set {FMU_VARIABLE})"
        )
    raise NotBuilt(
        f"this installation of aem-electrolyser has no FMU ({bundled}); install a platform wheel or set {FMU_VARIABLE}"
    )


def fmu_from_environment(path=None):
    """Whether fmu_path(path) takes the FMU from the environment variable AEM_FMU (no `path`
    given and AEM_FMU set): the name an error about the FMU should give."""
    return path is None and bool(os.environ.get(FMU_VARIABLE))


def fmu_problem(path):
    """Why the file `path` is not an FMU (a zip archive with a modelDescription.xml), or None."""
    path = Path(path)
    if path.is_dir():
        return "is a folder, not an FMU file"
    try:
        with zipfile.ZipFile(path) as z:
            z.getinfo("modelDescription.xml")
    except (zipfile.BadZipFile, KeyError, OSError) as e:
        return f"is not an FMU ({'it has no modelDescription.xml' if isinstance(e, KeyError) else 'not a zip archive'})"
    return None


def exe(name):
    """`name` with this platform's executable suffix."""
    return f"{name}.exe" if os.name == "nt" else name


def library(name):
    """`name` (a crate's library name) as this platform's shared library file."""
    return f"{name}.dll" if os.name == "nt" else f"lib{name}.so"


def binary(name):
    """The native command `name` (aem-identify or aem-run) of this installation: the wheel's, or
    in a checkout the newer of this machine's build (target/release/) and the portable one
    (target/dist/<platform>/, which scripts/test.sh builds)."""
    return _native(exe(name), "cargo build --release --bins")


def drive_library():
    """The hub runner's native stepping loop (crates/drive, aem_drive), found as `binary` finds
    the commands."""
    return _native(library("aem_drive"), "cargo build --release -p aem-drive")


def _native(file, build):
    bundled = PACKAGE / "bin" / file
    if bundled.is_file():
        return bundled
    target = _target()
    if target is not None:
        own = "win64" if os.name == "nt" else "linux64"
        built = [p for p in (target / "release" / file, target / "dist" / own / file) if p.is_file()]
        if built:
            return max(built, key=lambda p: p.stat().st_mtime)
        raise NotBuilt(f"{target / 'release' / file} not found: build it with {build}")
    raise NotBuilt(
        f"this installation of aem-electrolyser has no {file} ({bundled}): "
        "install a platform wheel (pip install aem-electrolyser on Linux x86-64 or Windows x64)"
    )


#: aem-study's worker platforms (study.worker.this_platform) -> (FMI platform folder, aem-run's file).
WORKER_PLATFORMS = {"linux-x86_64": ("linux64", "aem-run"), "windows-amd64": ("win64", "aem-run.exe")}


def portable_runners():
    """{worker platform: aem-run built to run on other machines of it}: in a checkout the builds
    of target/dist/<platform>/ (packaging/platforms.py aem-run: glibc 2.17, win64); in a wheel
    its own aem-run, which is that portable build for the wheel's platform."""
    target = _target()
    if target is not None:
        found = {platform: target / "dist" / folder / file for platform, (folder, file) in WORKER_PLATFORMS.items()}
        return {platform: path for platform, path in found.items() if path.is_file()}
    bundled = PACKAGE / "bin" / exe("aem-run")
    own = "windows-amd64" if os.name == "nt" else "linux-x86_64"
    return {own: bundled} if bundled.is_file() else {}
