"""Finished scenarios on disk, one JSON file per scenario named by its key, written the
moment the scenario finishes (atomically: a stopped study never leaves half a record), so a
study resumes where it stopped and never runs a stored scenario again."""

import json
import os
from pathlib import Path


class Store:
    def __init__(self, out_dir: Path, create=True):
        """The store in out_dir/scenarios (made unless `create` is false: reading only)."""
        self.dir = Path(out_dir) / "scenarios"
        if create:
            self.dir.mkdir(parents=True, exist_ok=True)

    def _path(self, key):
        return self.dir / f"{key}.json"

    def get(self, key):
        """The stored record of scenario `key`, or None."""
        try:
            return json.loads(self._path(key).read_text())
        except FileNotFoundError:
            return None

    def put(self, record):
        """Stores a finished scenario's record (floats as their shortest repr: bit for bit)."""
        path = self._path(record["scenario"])
        partial = path.with_suffix(f".{os.getpid()}.part")
        partial.write_text(json.dumps(record, indent=1))
        os.replace(partial, path)
