#!/usr/bin/env python3
"""The release bundle in one command: every file a user downloads, in dist/.

    .venv/bin/python packaging/release.py [--out dist]

Builds (each with its own tool, printing its time on stderr) and writes:

    AemElectrolyser-<version>.fmu                       the FMU, linux64 (glibc >= 2.17) and win64 binaries
    aem_electrolyser-<version>-py3-none-manylinux_2_17_x86_64.manylinux2014_x86_64.whl
    aem_electrolyser-<version>-py3-none-win_amd64.whl   each: the package, that FMU, aem-identify and aem-run
    aem_electrolyser-<version>.tar.gz                   the sdist: builds a wheel from source (Rust, libclang)
    aem-identify-<version>-linux-x86_64                 the identification tool as a plain download
    aem-identify-<version>-windows-x86_64.exe
    SHA256SUMS                                          `sha256sum -c SHA256SUMS` verifies the others

The version is the Cargo workspace's; the model description's and the FMU documentation's must
equal it (checked before anything is built). Needs the toolchains of scripts/setup.sh and runs
in its .venv (hatchling and build, pinned in requirements.txt).
"""

import argparse
import hashlib
import os
import re
import shutil
import subprocess
import sys
import time
import tomllib
import xml.etree.ElementTree as ET
from pathlib import Path

from aem_electrolyser.cli import quiet_on_closed_stdout, writable_folder

ROOT = Path(__file__).resolve().parent.parent
TARGET = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
PLATFORMS = {"linux64": ("linux-x86_64", ""), "win64": ("windows-x86_64", ".exe")}


def versions():
    """{where: version} of every place that states the release's version."""
    cargo = tomllib.loads((ROOT / "Cargo.toml").read_text(encoding="utf-8"))["workspace"]["package"]["version"]
    model = ET.parse(ROOT / "modelDescription.xml").getroot().get("version")
    docs = re.search(r'<span id="version">([^<]+)</span>', (ROOT / "documentation" / "index.html").read_text("utf-8"))
    citation = re.search(r"(?m)^version: *\"?([^\"\s]+)", (ROOT / "CITATION.cff").read_text("utf-8"))
    changelog = re.search(r"(?m)^## \[?([0-9][^\]\s]*)", (ROOT / "CHANGELOG.md").read_text("utf-8"))
    return {
        "Cargo.toml [workspace.package]": cargo,
        "modelDescription.xml": model,
        "documentation/index.html": docs.group(1) if docs else None,
        "CITATION.cff": citation.group(1) if citation else None,
        "CHANGELOG.md (latest release)": changelog.group(1) if changelog else None,
    }


def step(what, argv, **env):
    print(f"release: {what}", file=sys.stderr, flush=True)
    started = time.monotonic()
    subprocess.run([str(a) for a in argv], cwd=ROOT, check=True, env={**os.environ, **env})
    print(f"release: {what}: {time.monotonic() - started:.0f} s", file=sys.stderr, flush=True)


def sha256(path):
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=ROOT / "dist", help="the bundle's folder [default: dist]")
    args = parser.parse_args(argv)
    found = versions()
    version = found["Cargo.toml [workspace.package]"]
    wrong = {where: v for where, v in found.items() if v != version}
    if wrong:
        sys.exit("release.py: one version for everything: " + ", ".join(f"{w} says {v}" for w, v in found.items()))
    out = writable_folder(args.out)
    for old in out.iterdir():  # a bundle holds one release
        if old.is_file():
            old.unlink()
    python = sys.executable
    step("the workspace for linux64 and win64", [python, "packaging/platforms.py", "all"])
    step("the FMU (linux64 and win64)", [python, "packaging/package.py", "--no-build"])
    for platform in PLATFORMS:
        step(
            f"the {platform} wheel",
            [python, "-m", "build", "--wheel", "--no-isolation", "--outdir", out],
            AEM_WHEEL_PLATFORM=platform,
        )
    step("the sdist", [python, "-m", "build", "--sdist", "--no-isolation", "--outdir", out])
    shutil.copyfile(TARGET / "fmu" / "AemElectrolyser.fmu", out / f"AemElectrolyser-{version}.fmu")
    for platform, (name, suffix) in PLATFORMS.items():
        download = out / f"aem-identify-{version}-{name}{suffix}"
        shutil.copyfile(TARGET / "dist" / platform / f"aem-identify{suffix}", download)
        download.chmod(0o755)
    files = sorted(p for p in out.iterdir() if p.is_file() and p.name != "SHA256SUMS")
    (out / "SHA256SUMS").write_text("".join(f"{sha256(p)}  {p.name}\n" for p in files))
    for p in files + [out / "SHA256SUMS"]:
        print(f"{p.stat().st_size:>12,d}  {p.relative_to(ROOT) if p.is_relative_to(ROOT) else p}")


if __name__ == "__main__":
    quiet_on_closed_stdout(main)
