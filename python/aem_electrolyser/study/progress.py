"""Progress of a study on stderr: scenarios done, running, failed, and the time left.

As every command of the package (aem_electrolyser.cli.shows_progress): nothing with --quiet; a
tqdm bar (its rate gives the estimate) only when stdout is a terminal and so is the stream the
bar is drawn on; elsewhere (CI logs, files, pipes) one line per finished scenario."""

import sys
import time

from tqdm import tqdm

from aem_electrolyser.cli import shows_progress


def draws_bar(stream, quiet=False):
    """Whether the progress is a bar: not --quiet, stdout a terminal (the package's rule) and
    `stream` a terminal too (a bar in a log file is a pile of carriage returns)."""
    isatty = getattr(stream, "isatty", None)
    return shows_progress(quiet) and bool(isatty and isatty())


class Progress:
    def __init__(self, total, stored, stream=None, quiet=False):
        self.total, self.done, self.failed = total, stored, 0
        self.todo = total - stored
        self.started = time.monotonic()
        self.stream = stream = stream or sys.stderr  # the stderr of now (a test may capture it)
        self.quiet = quiet
        self.bar = (
            tqdm(total=total, initial=stored, unit="scenario", file=stream, dynamic_ncols=True, leave=False)
            if draws_bar(stream, quiet)
            else None
        )

    def finished(self, record, running, labels):
        """One more scenario finished; `running` are executing now."""
        self.done += 1
        self.failed += record["status"] != "done"
        if self.quiet:
            return
        status = f"finished {self.done}/{self.total}, running {running}, failed {self.failed}"
        if self.bar is not None:
            self.bar.set_postfix_str(f"running {running}, failed {self.failed}", refresh=False)
            self.bar.update(1)
            return
        ran = self.done - (self.total - self.todo)
        elapsed = time.monotonic() - self.started
        left = elapsed / ran * (self.total - self.done) if ran else float("nan")
        what = ", ".join(f"{k}={v}" for k, v in labels.items() if v is not None)
        print(
            f"[{status}, {_clock(elapsed)} elapsed, ~{_clock(left)} left] {record['status']}: {what}",
            file=self.stream,
            flush=True,
        )

    def close(self):
        if self.bar is not None:
            self.bar.close()


def _clock(seconds):
    if seconds != seconds:
        return "?"
    seconds = int(round(seconds))
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"
