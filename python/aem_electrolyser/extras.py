"""Optional dependencies (the extras of `pip install aem-electrolyser[...]`): a feature whose
extra is not installed ends with one line naming the `pip install` that brings it, not with a
traceback.

    require("study", "aem-study")            # a command: exits (status 1) with the line
    with needs("mosaik", __name__):          # a module's imports: MissingExtra (an ImportError),
        import mosaik                        # or that line and exit when run as the program
"""

import contextlib
import importlib.util
import sys

#: extra -> the modules it brings (checked in this order).
EXTRAS = {
    "plots": ("matplotlib",),
    "study": ("distributed", "pyarrow", "pandas", "tqdm", "matplotlib"),
    "reserves": ("matplotlib",),
    "mosaik": (
        "mosaik",
        "mosaik_api_v3",
        "mosaik_components.pandapower",
        "mosaik_csv",
        "pandapower",
        "loguru",
        "matplotlib",
    ),
    "helics": ("helics", "pandapower", "matplotlib"),
    "grid": ("tops", "matplotlib"),
}


class MissingExtra(ImportError):
    """An optional dependency is not installed; the message names the extra that brings it."""


def message(extra, module, who):
    return f"{who} needs the [{extra}] extra ({module} is not installed): pip install 'aem-electrolyser[{extra}]'"


def missing(extra):
    """The first module of `extra` that is not installed, or None. Found, not imported: a check
    costs milliseconds where importing pandapower and matplotlib takes seconds, and a command
    answers a bad argument before any of it."""
    for module in EXTRAS[extra]:
        try:
            if importlib.util.find_spec(module) is None:
                return module
        except ImportError:  # a parent package of a dotted name is missing
            return module
    return None


def require(extra, who):
    """Ends the program (status 1) with one line if a module of `extra` is missing."""
    module = missing(extra)
    if module is not None:
        sys.exit(message(extra, module, who))


def _program():
    """`python -m NAME` when the program is a module of this package, else None."""
    spec = getattr(sys.modules.get("__main__"), "__spec__", None)
    return f"python -m {spec.name}" if spec is not None and spec.name.startswith("aem_electrolyser.") else None


@contextlib.contextmanager
def needs(extra, importer):
    """Imports of the module named `importer` (its __name__) that need `extra`: an ImportError in
    them ends the program with the one-line message when the program is a module of this
    package, and becomes MissingExtra (an ImportError with that message) otherwise."""
    try:
        yield
    except ImportError as e:
        if isinstance(e, MissingExtra):
            raise
        program = _program()
        if program is not None:
            raise SystemExit(message(extra, e.name or e, program)) from None
        raise MissingExtra(message(extra, e.name or e, importer)) from e
