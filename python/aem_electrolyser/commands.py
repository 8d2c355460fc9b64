"""The Python commands of the package (console entry points): each checks its extra first, so a
missing one gives its `pip install` line, not a traceback."""

import sys

from .extras import require


def study():
    """aem-study: year-long studies of hubs on Dask."""
    require("study", "aem-study")
    from .study.cli import main

    sys.exit(main())


def prequalify():
    """aem-prequalify: the frequency-reserve prequalification of a hub."""
    require("reserves", "aem-prequalify")
    from .reserves.prequalify import main
    from .cli import quiet_on_closed_stdout

    quiet_on_closed_stdout(main)
