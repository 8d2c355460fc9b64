"""The Python commands of the package (console entry points): each checks its extra first, so a
missing one gives its `pip install` line, not a traceback. `--help` and `--version` (and
aem-study's `--example`) are answered without the extra: their parsers import none of its
packages."""

import sys

from .extras import require

#: What a command answers without its extra.
WITHOUT_EXTRA = {"-h", "--help", "--version"}


def _require(extra, who, answers=()):
    """require(extra, who) unless the command line asks for the help, the version or one of
    `answers` (options the command answers without its extra)."""
    if not (WITHOUT_EXTRA | set(answers)) & set(sys.argv[1:]):
        require(extra, who)


def study():
    """aem-study: year-long studies of hubs on Dask."""
    _require("study", "aem-study", answers=["--example"])
    from .study.cli import main

    sys.exit(main())


def prequalify():
    """aem-prequalify: the frequency-reserve prequalification of a hub."""
    _require("reserves", "aem-prequalify")
    from .reserves.prequalify import main
    from .cli import quiet_on_closed_stdout

    quiet_on_closed_stdout(main)
