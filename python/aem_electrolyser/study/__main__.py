"""python -m aem_electrolyser.study: the aem-study command."""

import sys

from aem_electrolyser.extras import require

require("study", "python -m aem_electrolyser.study")
from aem_electrolyser.study.cli import main  # noqa: E402

sys.exit(main())
