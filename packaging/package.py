#!/usr/bin/env python3
"""Build the release library and zip it with the model description into an FMU.

    python3 packaging/package.py [--out target/fmu/AemElectrolyser.fmu] [--no-build]

Layout of the FMU (FMI 2.0, section 2.3):
    modelDescription.xml
    binaries/<platform>/AemElectrolyser.<so|dylib|dll>
    documentation/index.html
The archive is deterministic: fixed timestamps and sorted entries, so the same sources give
the same bytes. Standard library only.
"""
import argparse
import os
import platform
import subprocess
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MODEL_IDENTIFIER = "AemElectrolyser"
CRATE_LIB = "aem_electrolyser"
FIXED_DATE = (2026, 1, 1, 0, 0, 0)


def platform_dir():
    """FMI 2.0 platform folder and the library's file names for this machine."""
    bits = "64" if sys.maxsize > 2**32 else "32"
    system = platform.system()
    if system == "Linux":
        return f"linux{bits}", f"lib{CRATE_LIB}.so", f"{MODEL_IDENTIFIER}.so"
    if system == "Darwin":
        return f"darwin{bits}", f"lib{CRATE_LIB}.dylib", f"{MODEL_IDENTIFIER}.dylib"
    if system == "Windows":
        return f"win{bits}", f"{CRATE_LIB}.dll", f"{MODEL_IDENTIFIER}.dll"
    sys.exit(f"package.py: unsupported platform {system}")


def build_release():
    subprocess.run(["cargo", "build", "--release", "--lib", "--locked"], cwd=ROOT, check=True)


def entries(model_description: bytes):
    """(archive name, bytes) of every file in the FMU."""
    plat, built, shipped = platform_dir()
    target_dir = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    library = target_dir / "release" / built
    if not library.is_file():
        sys.exit(f"package.py: {library} not found; build it first (cargo build --release --lib)")
    yield "modelDescription.xml", model_description
    yield f"binaries/{plat}/{shipped}", library.read_bytes()
    docs = ROOT / "documentation"
    for path in sorted(docs.rglob("*")):
        if path.is_file():
            yield f"documentation/{path.relative_to(docs).as_posix()}", path.read_bytes()


def write_fmu(out: Path, files):
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".tmp")
    with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED) as fmu:
        for name, data in sorted(files):
            info = zipfile.ZipInfo(name, date_time=FIXED_DATE)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            fmu.writestr(info, data)
    tmp.replace(out)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=ROOT / "target" / "fmu" / f"{MODEL_IDENTIFIER}.fmu")
    parser.add_argument("--no-build", action="store_true", help="use the library already in target/release")
    args = parser.parse_args(argv)
    if not args.no_build:
        build_release()
    model_description = (ROOT / "modelDescription.xml").read_bytes()
    write_fmu(args.out, list(entries(model_description)))
    print(f"wrote {args.out.relative_to(ROOT) if args.out.is_relative_to(ROOT) else args.out}")


if __name__ == "__main__":
    main()
