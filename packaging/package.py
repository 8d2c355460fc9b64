#!/usr/bin/env python3
"""Build the release library and zip it with the model description into an FMU.

    .venv/bin/python packaging/package.py [--output target/fmu/AemElectrolyser.fmu] [--no-build]
    .venv/bin/python packaging/package.py --parameters params.json [--module ID] --output my.fmu

With --integer-enumerations, dispatch, belowMinimum and operatingState are declared as plain
Integers (same value references, same codes, ranges from the enumerations' items) in the
shipped model description: for importers that ignore FMI enumerations (libcosim and Ecos
do), so that their users can still set a hub's dispatch. The binary is the same; with
--from FMU an FMU already built is repackaged that way, without building:

    .venv/bin/python packaging/package.py --integer-enumerations --from target/fmu/AemElectrolyser.fmu --output AemInteger.fmu

With --parameters (a file written by `aem-identify fit -o`), the FMU's parameter start values
are the identified ones: the copy of modelDescription.xml that goes into the zip gets them
(and a GUID derived from them), and the binary is built from that copy (build.rs reads the
AEM_MODEL_DESCRIPTION environment variable), so the model description and the binary's
defaults agree. The repository's modelDescription.xml is never changed. Unknown parameter
names, wrong units and non-finite values are refused before anything is built.

Layout of the FMU (FMI 2.0, section 2.3):
    modelDescription.xml
    binaries/linux64/AemElectrolyser.so    glibc >= 2.17 (cargo zigbuild)
    binaries/win64/AemElectrolyser.dll     Windows 10 or later (mingw-w64, std built from source)
    documentation/index.html
Both binaries are built on this Linux x86-64 machine (packaging/platforms.py says how);
--platforms picks some of them. The time each build takes is printed on stderr; the output
path is checked for writing before anything is built.
The archive is deterministic: fixed timestamps and sorted entries, so the same sources give
the same bytes. Standard library and aem_electrolyser.cli only (run it with .venv/bin/python, or
with python/ on PYTHONPATH as the wheel's build hook does).
"""

import argparse
import json
import math
import platform as host
import re
import uuid
import xml.etree.ElementTree as ET
import sys
import zipfile
from pathlib import Path

import docs_reference
from platforms import PLATFORMS, TARGET, build, platform, release_dir

from aem_electrolyser.cli import quiet_on_closed_stdout, writable

ROOT = Path(__file__).resolve().parent.parent
MODEL_IDENTIFIER = "AemElectrolyser"
CRATE = "aem-electrolyser-fmu"
CRATE_LIB = "aem_electrolyser"
FIXED_DATE = (2026, 1, 1, 0, 0, 0)


def build_release(platforms, model_description=None, native=False):
    """Release builds of the FMU's library for `platforms`, from the repository's model
    description or from `model_description`."""
    if host.system() != "Linux" or host.machine() != "x86_64":
        sys.exit(f"package.py: the binaries are built on Linux x86-64 (this is {host.system()} {host.machine()})")
    # Always set, so that a build from an edited copy is never reused for the repository's.
    env = {"AEM_MODEL_DESCRIPTION": str(model_description) if model_description is not None else ""}
    # A release builds the whole workspace (packaging/platforms.py all): the same selection here
    # keeps the features of shared dependencies, so only this crate is compiled again. The
    # native build (the demo) needs the libraries alone: the FMU's and the Python hub runner's
    # stepping loop (aem_drive, which the prequalification in this checkout then finds).
    selection = ["--lib", "--package", CRATE, "--package", "aem-drive"] if native else ["--workspace"]
    for name in platforms:
        build(platform(name, native), [*selection, "--locked"], env)


class ParameterFileError(Exception):
    """A parameter file that cannot be applied; the message says why."""


def read_parameters(path: Path, module=None):
    """{name: value} of one module of an `aem-identify` parameter file."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as e:
        raise ParameterFileError(f"{path}: cannot read: {e}") from e
    except json.JSONDecodeError as e:
        raise ParameterFileError(f"{path}:{e.lineno}: not JSON: {e.msg}") from e
    modules = data.get("modules") if isinstance(data, dict) else None
    if not isinstance(modules, list) or not modules:
        raise ParameterFileError(f'{path}: no "modules" list (write it with aem-identify fit -o)')
    ids = [m.get("module") for m in modules if isinstance(m, dict)]
    if module is None:
        if len(modules) != 1:
            raise ParameterFileError(
                f"{path}: {len(modules)} modules; choose one with --module ({', '.join(map(str, ids))})"
            )
        entry = modules[0]
    else:
        matches = [m for m in modules if isinstance(m, dict) and m.get("module") == module]
        if not matches:
            raise ParameterFileError(f"{path}: no module {module!r} (modules: {', '.join(map(str, ids))})")
        entry = matches[0]
    parameters = entry.get("parameters") if isinstance(entry, dict) else None
    if not isinstance(parameters, dict):
        raise ParameterFileError(f'{path}: module entry without a "parameters" object')
    return parameters


def apply_parameters(xml_text: str, parameters: dict, origin: str):
    """The model description with the parameters' start values and a GUID derived from them.

    Every name must be a parameter of the model description with the same unit, and every
    value a finite number not below the variable's min; anything else is refused."""
    root = ET.fromstring(xml_text)
    declared = {}
    for sv in root.iter("ScalarVariable"):
        real = sv.find("Real")
        if sv.get("causality") == "parameter" and real is not None:
            declared[sv.get("name")] = (real.get("unit"), real.get("min"))
    values = {}
    for name, entry in parameters.items():
        if name not in declared:
            raise ParameterFileError(
                f"{origin}: unknown parameter {name!r} (the FMU's parameters: {', '.join(declared)})"
            )
        unit, minimum = declared[name]
        if not isinstance(entry, dict) or "value" not in entry or "unit" not in entry:
            raise ParameterFileError(f'{origin}: parameter {name!r} needs "value" and "unit"')
        if entry["unit"] != unit:
            raise ParameterFileError(f"{origin}: parameter {name!r} has unit {entry['unit']!r}, the FMU's is {unit!r}")
        value = entry["value"]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ParameterFileError(f"{origin}: parameter {name!r} = {value!r} is not a finite number")
        if minimum is not None and value < float(minimum):
            raise ParameterFileError(f"{origin}: parameter {name!r} = {value!r} is below its min {minimum}")
        values[name] = float(value)
    text = xml_text
    for name, value in values.items():
        # Edit the start attribute inside this variable's element only, keeping the file as written.
        pattern = re.compile(
            r'(<ScalarVariable\s+name="' + re.escape(name) + r'"[^>]*>.*?<Real\b[^>]*?\bstart=")([^"]*)(")', re.S
        )
        text, count = pattern.subn(lambda m: m.group(1) + repr(value) + m.group(3), text, count=1)
        if count != 1:
            raise ParameterFileError(f"{origin}: no start attribute for {name!r} in modelDescription.xml")
    old_guid = root.get("guid")
    fingerprint = old_guid + json.dumps(values, sort_keys=True)
    new_guid = "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, fingerprint)) + "}"
    text = text.replace(f'guid="{old_guid}"', f'guid="{new_guid}"', 1)
    return text, values, new_guid


def integer_enumerations(xml_text: str) -> str:
    """The model description with every Enumeration variable declared as an Integer with the
    items' range (min, max) and its start, and without <TypeDefinitions>; the rest as written."""
    root = ET.fromstring(xml_text)
    items = {}
    for simple in root.iter("SimpleType"):
        values = [int(i.get("value")) for i in simple.iter("Item")]
        items[simple.get("name")] = (min(values), max(values))

    def as_integer(m):
        attrs = dict(re.findall(r'(\w+)="([^"]*)"', m.group(1)))
        lo, hi = items[attrs.pop("declaredType")]
        start = f' start="{attrs["start"]}"' if "start" in attrs else ""
        return f'<Integer min="{lo}" max="{hi}"{start}/>'

    text, count = re.subn(r"<Enumeration\b([^>]*)/>", as_integer, xml_text)
    if count != len([v for v in root.iter("ScalarVariable") if v.find("Enumeration") is not None]):
        raise ValueError("an Enumeration variable is not written as a single empty element")
    # Integer descriptions name the codes and end with their unit, as the repository's own do.
    codes = {
        s.get("name"): ", ".join(f"{i.get('value')} {i.get('name')}" for i in s.iter("Item"))
        for s in root.iter("SimpleType")
    }
    for sv in root.iter("ScalarVariable"):
        enumeration = sv.find("Enumeration")
        if enumeration is not None:
            pattern = r'(<ScalarVariable\s+name="' + re.escape(sv.get("name")) + r'"[^>]*?description="[^"]*)(")'
            text = re.sub(
                pattern,
                lambda m: f"{m.group(1)} (codes: {codes[enumeration.get('declaredType')]}) [1]{m.group(2)}",
                text,
                count=1,
                flags=re.S,
            )
    return re.sub(r"\s*<TypeDefinitions>.*?</TypeDefinitions>", "", text, flags=re.S)


def entries(model_description: bytes, platforms, native=False):
    """(archive name, bytes) of every file in the FMU."""
    guid = ET.fromstring(model_description).get("guid")
    yield "modelDescription.xml", model_description
    for name in platforms:
        built = platform(name, native)
        library = release_dir(built) / built.library(CRATE_LIB)
        if not library.is_file():
            sys.exit(f"package.py: {library} not found; run without --no-build")
        binary = library.read_bytes()
        if guid.encode() not in binary:
            sys.exit(
                f"package.py: {library} was not built from this model description (GUID {guid} not in it); "
                "run without --no-build"
            )
        yield f"binaries/{name}/{MODEL_IDENTIFIER}{built.library_suffix}", binary
    docs = ROOT / "documentation"
    for path in sorted(docs.rglob("*")):
        if path.is_file():
            data = path.read_bytes()
            if path == docs / "index.html":  # generated from the model description packed here
                data = docs_reference.fmu_documentation(model_description).encode("utf-8")
            yield f"documentation/{path.relative_to(docs).as_posix()}", data


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
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter, allow_abbrev=False
    )
    parser.add_argument(
        "-o",
        "--output",
        dest="out",
        type=Path,
        metavar="FILE.fmu",
        default=TARGET / "fmu" / f"{MODEL_IDENTIFIER}.fmu",
        help="the FMU file to write (as aem-identify fit's --output; --out names folders) "
        f"[default: target/fmu/{MODEL_IDENTIFIER}.fmu]",
    )
    parser.add_argument("--no-build", action="store_true", help="use the libraries already built")
    parser.add_argument(
        "--platforms",
        default=",".join(PLATFORMS),
        help=f"comma-separated FMI platforms to build and ship (default: {','.join(PLATFORMS)})",
    )
    parser.add_argument(
        "--native",
        action="store_true",
        help="linux64 built with plain cargo against this machine's glibc (no zig; not for a release)",
    )
    parser.add_argument(
        "--parameters", type=Path, help="parameter file of aem-identify: its values become the start values"
    )
    parser.add_argument("--module", help="module of the parameter file (when it holds several)")
    parser.add_argument(
        "--integer-enumerations",
        action="store_true",
        help="declare the enumerations as plain Integers (for libcosim and Ecos, which ignore enumerations)",
    )
    parser.add_argument(
        "--from",
        dest="from_fmu",
        type=Path,
        metavar="FMU",
        help="with --integer-enumerations: repackage this FMU instead of building",
    )
    args = parser.parse_args(argv)
    platforms = [p.strip() for p in args.platforms.split(",") if p.strip()]
    unknown = [p for p in platforms if p not in PLATFORMS]
    if unknown or not platforms:
        parser.error(f"--platforms: {', '.join(unknown) or 'none given'}; choose from {', '.join(PLATFORMS)}")
    if args.from_fmu is not None:
        if not args.integer_enumerations or args.parameters is not None:
            parser.error("--from goes with --integer-enumerations only")
        writable(args.out)
        with zipfile.ZipFile(args.from_fmu) as fmu:
            files = [(name, fmu.read(name)) for name in fmu.namelist() if not name.endswith("/")]
        files = [
            (
                name,
                integer_enumerations(data.decode("utf-8")).encode("utf-8") if name == "modelDescription.xml" else data,
            )
            for name, data in files
        ]
        write_fmu(args.out, files)
        print(f"wrote {args.out.relative_to(ROOT) if args.out.is_relative_to(ROOT) else args.out}")
        return
    writable(args.out)
    xml_path = ROOT / "modelDescription.xml"
    if args.parameters is None:
        if args.module is not None:
            parser.error("--module needs --parameters")
        if not args.no_build:
            build_release(platforms, native=args.native)
        model_description = xml_path.read_bytes()
    else:
        try:
            parameters = read_parameters(args.parameters, args.module)
            text, values, guid = apply_parameters(
                xml_path.read_text(encoding="utf-8"), parameters, str(args.parameters)
            )
        except ParameterFileError as e:
            sys.exit(f"package.py: {e}")
        # The edited copy lives beside the output, never over the repository's file.
        edited = args.out.with_name(args.out.stem + ".modelDescription.xml")
        edited.parent.mkdir(parents=True, exist_ok=True)
        edited.write_text(text, encoding="utf-8")
        if not args.no_build:
            build_release(platforms, edited.resolve(), native=args.native)
        model_description = text.encode("utf-8")
    if args.integer_enumerations:
        model_description = integer_enumerations(model_description.decode("utf-8")).encode("utf-8")
    write_fmu(args.out, list(entries(model_description, platforms, args.native)))
    if args.parameters is not None:
        print(
            f"start values from {args.parameters}: "
            + ", ".join(f"{k}={v!r}" for k, v in values.items())
            + f"; GUID {guid}"
        )
    print(f"wrote {args.out.relative_to(ROOT) if args.out.is_relative_to(ROOT) else args.out}")


if __name__ == "__main__":
    quiet_on_closed_stdout(main)
