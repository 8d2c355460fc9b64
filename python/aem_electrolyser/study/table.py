"""The study's table: one row per scenario in the study's order, its axis values, its KPIs
(with units), how it ran."""

import numpy as np
import pandas as pd

from .kpis import KPIS, RUN_COLUMNS


def table(scenarios, axis_columns, records):
    """DataFrame of the scenarios that have a record (`records`: key -> record)."""
    rows = []
    for s in scenarios:
        record = records.get(s.key)
        if record is None:
            continue
        row = {column: s.labels.get(column) for column in axis_columns}
        kpis = record.get("kpis") or {}
        row.update({name: np.nan if kpis.get(name) is None else kpis[name] for name in KPIS})
        row.update({"run time [s]": record.get("run time [s]", np.nan), "worker": record.get("worker", "")})
        row.update(scenario=s.key, status=record["status"], message=record.get("message", ""))
        rows.append(row)
    columns = list(axis_columns) + list(KPIS) + RUN_COLUMNS + ["scenario", "status", "message"]
    frame = pd.DataFrame(rows, columns=columns)
    frame["modules [1]"] = frame["modules [1]"].astype("Int64")
    return frame
