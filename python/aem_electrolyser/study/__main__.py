"""python -m aem_electrolyser.study: the aem-study command."""

import sys

from aem_electrolyser.extras import require
from aem_electrolyser.study.cli import main, needs_extra  # imports none of the extra

if needs_extra(sys.argv[1:]):
    require("study", "python -m aem_electrolyser.study")

sys.exit(main())
