"""CSV records of what a federate published and received, against simulated time.

Header `time [s]` then one column per value, named `<publication> [<unit>]` (the HELICS name of
the publication the value is, or comes from, e.g. `wind/power [W]`), so that a value received
can be matched with the same column of its publisher's record. Values are written with Python's
repr (shortest round trip), so reading them back with float() gives the very bits sent; a row
is flushed as soon as it is written, so a federate that dies leaves what it had.
"""

import csv


class Record:
    def __init__(self, path, columns):
        """columns: (name, unit) pairs."""
        self.path = path
        self._file = open(path, "w", newline="")
        self._csv = csv.writer(self._file)
        self._csv.writerow(["time [s]"] + [f"{name} [{unit}]" for name, unit in columns])
        self._file.flush()

    def write(self, t, values):
        self._csv.writerow([repr(float(x)) for x in (t, *values)])
        self._file.flush()

    def close(self):
        self._file.close()


def read(path):
    """(header, rows of floats) of a record."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], [[float(x) for x in row] for row in rows[1:]]
