#!/usr/bin/env python3
"""Plot measured against simulated values from `aem-identify validate --csv`.

    python -m aem_electrolyser.plot_validation out/validation.csv out/validation.png

Four panels against time (hours since the day's first running row): stack current, voltage,
DC power and hydrogen flow, measured (grey) and the identified model (colour). Rows within the
settle time after a start-up, which the RMSE leaves out, are shaded. The PNG's path is checked
for writing before the CSV is read.
"""

import csv
from pathlib import Path

import numpy as np

from aem_electrolyser import cli
from aem_electrolyser.extras import needs

with needs("plots", __name__):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

PANELS = [("current", "Current [A]"), ("voltage", "Voltage [V]"), ("power", "Power [W]"), ("h2_flow", "H2 flow [Nl/h]")]
#: The columns of `aem-identify validate --csv` that the figure reads.
COLUMNS = ("time", *(f"{key}_{side}" for key, _ in PANELS for side in ("measured", "model")), "compared")


def missing_columns(path: Path):
    """The COLUMNS that the CSV's header lacks (none for a file without a header: it has no rows)."""
    with path.open(newline="") as f:
        header = next(csv.reader(f), None)
    return [c for c in COLUMNS if header and c not in {h.strip() for h in header}]


def load(path: Path):
    with path.open(newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise ValueError(f"{path}: no rows")
    columns = {}
    for key in rows[0]:
        columns[key] = np.array([float(r[key]) if r[key] != "" else np.nan for r in rows])
    return columns


def main(argv=None):
    parser = cli.CommandLine(description=__doc__.splitlines()[0], quiet=False)
    parser.add_argument("csv", type=Path, help="the CSV of `aem-identify validate --csv`")
    parser.add_argument("png", type=Path, help="the figure to write")
    args = parser.parse_args(argv)
    if not args.csv.is_file():
        parser.error(f"csv: {args.csv} {'is a folder' if args.csv.is_dir() else 'does not exist'}; give the CSV file")
    try:
        missing = missing_columns(args.csv)
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        parser.error(f"csv: cannot read {args.csv}: {cli.one_line(e)}")
    if missing:
        parser.error(
            f"csv: {args.csv} lacks the column(s) {', '.join(missing)}: give the CSV of aem-identify validate --csv"
        )
    cli.writable(args.png)
    d = load(args.csv)
    hours = (d["time"] - d["time"][0]) / 3600.0
    fig, axes = plt.subplots(len(PANELS), 1, figsize=(11, 9), sharex=True)
    for ax, (key, label) in zip(axes, PANELS):
        measured, model = d[f"{key}_measured"], d[f"{key}_model"]
        ax.plot(hours, measured, color="0.6", lw=0.6, label="measured")
        ax.plot(hours, model, color="tab:blue", lw=0.9, label="identified model")
        ax.fill_between(
            hours,
            0,
            1,
            where=d["compared"] == 0,
            transform=ax.get_xaxis_transform(),
            color="tab:orange",
            alpha=0.12,
            lw=0,
        )
        compared = d["compared"] == 1
        if np.any(np.isfinite(measured[compared])):
            rmse = np.sqrt(np.nanmean((measured[compared] - model[compared]) ** 2))
            ax.set_title(
                f"{label.split(' [')[0]}: RMSE {rmse:.4g} {label.split('[')[1].rstrip(']')}", fontsize=9, loc="left"
            )
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="lower right", fontsize=8)
    axes[-1].set_xlabel("time since the first running row [h] (shaded: start-up settle, not compared)")
    fig.tight_layout()
    fig.savefig(args.png, dpi=110)
    print(f"wrote {args.png}")


if __name__ == "__main__":
    cli.run_command(main)
