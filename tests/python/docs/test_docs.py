"""The documentation: the MkDocs site builds in strict mode (no broken link, anchor, image or
docstring); every variable of modelDescription.xml is in the site's generated variables page and
in the FMU's documentation/index.html (both parsed as HTML), with the model description's
causality, type and start; index.html and the committed reference pages (docs/reference/: the
variables, every command's own --help) are what packaging/docs_reference.py makes now; every
command has its page with its own --help; every module of the package is on
the Python API pages; the README stays short and keeps the quick start."""

import importlib.util
import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from html.parser import HTMLParser

import pytest

from conftest import ROOT

from aem_electrolyser.locate import NotBuilt, binary


def load_generator():
    spec = importlib.util.spec_from_file_location("docs_reference_under_test", ROOT / "packaging" / "docs_reference.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


docs_reference = load_generator()


@pytest.fixture(scope="module")
def site():
    """The site, built strictly into target/site (the suite's build of it: scripts/test.sh and
    scripts/check.sh build it here, once)."""
    out = ROOT / "target" / "site"
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "mkdocs",
            "build",
            "--strict",
            "--quiet",
            "-f",
            str(ROOT / "mkdocs.yml"),
            "-d",
            str(out),
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
    )
    assert done.returncode == 0, done.stderr[-5000:]
    return out


class Tables(HTMLParser):
    """The rows of every table: {id of the first cell's <code>: [cell texts]}."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.rows, self.ids, self._row, self._cell, self._id = {}, [], None, None, None

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "tr":
            self._row, self._id = [], None
        elif tag == "td" and self._row is not None:
            self._cell = []
        elif tag == "code" and self._cell is not None and not self._row and "id" in attrs:
            self._id = attrs["id"]
            self.ids.append(attrs["id"])

    def handle_data(self, data):
        if self._cell is not None:
            self._cell.append(data)

    def handle_endtag(self, tag):
        if tag == "td" and self._cell is not None:
            self._row.append("".join(self._cell).strip())
            self._cell = None
        elif tag == "tr" and self._row is not None:
            if self._id is not None:
                self.rows[self._id] = self._row
            self._row = None


def tables(html):
    parser = Tables()
    parser.feed(html)
    return parser


def model_variables():
    """{name: (causality, type, start)} of modelDescription.xml."""
    out = {}
    for v in ET.parse(ROOT / "modelDescription.xml").getroot().iter("ScalarVariable"):
        kind = next(c for c in v if c.tag in ("Real", "Integer", "Boolean", "String", "Enumeration"))
        out[v.get("name")] = (v.get("causality", "local"), kind.tag, kind.get("start"))
    return out


def check_variables(html, where):
    """Every variable has exactly one row, with the model description's causality, type and start."""
    found = tables(html)
    wanted = model_variables()
    assert sorted(found.ids) == sorted(wanted), f"{where}: variables differ from modelDescription.xml"
    for name, (causality, kind, start) in wanted.items():
        row = found.rows[name]
        header = docs_reference.VARIABLE_HEADER
        assert row[header.index("causality")] == causality, (where, name, row)
        assert row[header.index("type")].split()[0] == kind, (where, name, row)
        shown = row[header.index("start")]
        if start is None:
            assert shown == "", (where, name, row)
        elif kind == "String":
            assert shown == f'"{start}"', (where, name, row)
        else:
            assert shown.split()[0] == start, (where, name, row)


def test_the_site_builds_strictly(site):
    assert (site / "index.html").is_file()
    for page in (
        "getting-started",
        "using-the-fmu",
        "model",
        "hub",
        "identification",
        "studies",
        "grid-services",
        "cosimulation",
        "platforms",
        "validation",
        "robustness",
        "development",
    ):
        assert (site / page / "index.html").is_file(), page


def test_every_variable_is_on_the_sites_page(site):
    check_variables((site / "reference" / "variables" / "index.html").read_text("utf-8"), "reference/variables")


def test_every_variable_is_in_the_fmus_documentation():
    html = (ROOT / "documentation" / "index.html").read_text("utf-8")
    check_variables(html, "documentation/index.html")
    version = ET.parse(ROOT / "modelDescription.xml").getroot().get("version")
    assert f'<span id="version">{version}</span>' in html


def test_the_fmus_documentation_is_what_the_generator_makes():
    committed = (ROOT / "documentation" / "index.html").read_text("utf-8")
    assert docs_reference.fmu_documentation() == committed, (
        "documentation/index.html is out of date: run .venv/bin/python packaging/docs_reference.py"
    )


def test_the_generator_follows_the_model_description():
    """A model description with other start values and an Integer for an enumeration (as
    package.py --parameters and --integer-enumerations write) gets its own tables and quoted starts."""
    text = (ROOT / "modelDescription.xml").read_text("utf-8")
    text = text.replace('<Real unit="s" start="300" min="0"/>', '<Real unit="s" start="123" min="0"/>')
    text = text.replace('<Enumeration declaredType="Dispatch" start="1"/>', '<Integer start="1" min="1" max="3"/>')
    html = docs_reference.fmu_documentation(text.encode())
    rows = tables(html).rows
    assert rows["coldStartTime"][docs_reference.VARIABLE_HEADER.index("start")] == "123"
    assert rows["dispatch"][docs_reference.VARIABLE_HEADER.index("type")] == "Integer"
    assert '<span class="start" data-variable="coldStartTime">123 s</span>' in html


def rust(command):
    return command.argv[0] == "-c" and "aem_electrolyser.native" in command.argv[1]


REGENERATE = "run .venv/bin/python packaging/docs_reference.py (Rust commands: cargo build --release --bins first)"


def test_the_committed_reference_pages_are_what_the_generator_makes():
    """docs/reference/ (committed, so that docs/ reads as files) against the pages made now from
    modelDescription.xml and every command's --help. A Rust command not built here is left out;
    the Python commands' pages are compared under the Python version their index records
    (argparse lays --help out differently from one version to the next)."""
    docs = ROOT / "docs"
    helps = docs_reference.command_helps()
    index = docs / docs_reference.COMMANDS_INDEX
    recorded = docs_reference.pages_python(index.read_text("utf-8")) if index.is_file() else None
    same_python = recorded in (None, sys.version_info[:2])
    skipped = set()
    for command in docs_reference.COMMANDS:
        status, text = helps[command.slug]
        if rust(command):
            try:
                binary(command.name.split()[0])
            except NotBuilt:
                skipped.add(docs_reference.command_page(command))
                continue
        elif not same_python:
            skipped.add(docs_reference.command_page(command))
            continue
        assert status == 0, f"{command.name} --help failed: {text}"
    if skipped:  # the index shows what failed and records the Python
        skipped.add(docs_reference.COMMANDS_INDEX)
    stale = [
        name
        for name, text in docs_reference.reference_pages(helps).items()
        if name not in skipped and (not (docs / name).is_file() or (docs / name).read_text("utf-8") != text)
    ]
    assert not stale, f"out of date in docs/: {', '.join(stale)}: {REGENERATE}"


def test_every_command_has_its_help_page(site):
    for command in docs_reference.COMMANDS:
        page = site / "reference" / "commands" / command.slug / "index.html"
        assert page.is_file(), command.name
        text = page.read_text("utf-8")
        assert f"$ {command.name} --help" in text and re.search(r"(?i)usage:", text), command.name
    index = (site / "reference" / "commands" / "index.html").read_text("utf-8")
    assert all(f'href="{c.slug}/"' in index for c in docs_reference.COMMANDS)


def test_every_command_is_listed():
    """Every console script of pyproject.toml and every module of the package that runs as a
    program has its entry in the generator's list of commands."""
    import tomllib

    names = {c.name for c in docs_reference.COMMANDS}
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text("utf-8"))["project"]["scripts"]
    assert not set(scripts) - names
    same_as = {"aem_electrolyser.reserves.prequalify": "aem-prequalify"}
    package = ROOT / "python" / "aem_electrolyser"
    for path in package.rglob("*.py"):
        if path.name != "__main__.py" and re.search(r'(?m)^if __name__ == "__main__":', path.read_text("utf-8")):
            module = ".".join(("aem_electrolyser", *path.relative_to(package).with_suffix("").parts))
            assert same_as.get(module, f"python -m {module}") in names, module


def test_every_module_is_on_the_python_api_pages(site):
    package = ROOT / "python" / "aem_electrolyser"
    modules = {
        ".".join(("aem_electrolyser", *p.relative_to(package).with_suffix("").parts)).removesuffix(".__init__")
        for p in package.rglob("*.py")
        if p.name != "__main__.py"
    }
    html = "".join(p.read_text("utf-8") for p in (site / "reference" / "python").rglob("index.html"))
    ids = set(re.findall(r'id="(aem_electrolyser[\w.]*)"', html))
    assert not modules - ids, f"not on the Python API pages: {sorted(modules - ids)}"


def test_the_readme_is_short_and_keeps_the_quick_start():
    readme = (ROOT / "README.md").read_text("utf-8")
    assert len(readme.splitlines()) <= 150
    assert "bash scripts/demo.sh    # builds target/fmu/AemElectrolyser.fmu (linux64), runs the demo in fmpy" in readme
    assert "bash scripts/test.sh    # installs everything, builds the release bundle, runs every test" in readme
    for target in re.findall(r"\]\(([^)#:]+)(?:#[^)]*)?\)", readme):
        assert (ROOT / target).exists(), f"README links to {target}, which does not exist"


def test_every_link_of_the_pages_works_as_a_file():
    """docs/ read as files (GitHub, a checkout): every relative link of its pages and of the README
    names a file that exists (the generated reference pages are committed for that)."""
    dead = []
    for page in [*(ROOT / "docs").rglob("*.md"), ROOT / "README.md"]:
        text = re.sub(r"^```.*?^```", "", page.read_text("utf-8"), flags=re.S | re.M)
        for target in re.findall(r"\]\(([^)\s]+)\)", text):
            if re.match(r"[a-z]+:", target) or target.startswith("#"):
                continue
            if not (page.parent / target.split("#")[0]).exists():
                dead.append(f"{page.relative_to(ROOT)}: {target}")
    assert not dead, "links to files that do not exist:\n" + "\n".join(dead)
