"""A study file (TOML) and the scenarios it crosses.

    [study]
    title = "Hub size and dispatch"
    horizon = "365 d"            # default: a year (generated) or the series' span (file)
    step = "1 s"
    fmu = "my/AemElectrolyser.fmu"   # default: the installed package's FMU (aem_electrolyser.fmu_path)

    [parameters]                 # FMU parameters for every scenario, by their names
    hysteresis = 5

    [series.wind]                # a generated year of the 64 MW wind farm
    generator = "wind"
    [series.site]                # or the user's own series
    file = "site.csv"            # CSV or Parquet
    time = "time"                # seconds or RFC 3339 timestamps
    column = "power [MW]"        # unit in brackets: W, kW, MW (power) or % (setpoint)
    interpolation = "hold"       # or "linear"

    [axes]                       # crossed, in this order
    series = ["wind"]            # default: every series
    seed = [1, 2, 3]             # generated series only
    hub_size = [40, 60, 80, 100] # % of the series' rating (power series)
    hysteresis = [2, 5, 10]      # any FMU parameter
    step = ["1 s", "10 s"]       # horizon too
    [axes.mode]                  # named cases setting several parameters together
    equal = { dispatch = "equal", belowMinimum = "stayAtMinimum" }
    sequential = { dispatch = "sequential", belowMinimum = "standby" }

Paths are relative to the study file. Each scenario's definition (FMU, parameters, series,
hub size, step, horizon) is a dict whose canonical JSON hashes to its key.
"""
import hashlib
import itertools
import json
import tomllib
from dataclasses import dataclass
from pathlib import Path

from aem_electrolyser import locate

from .parameters import ModelParameters
from .quantities import duration, power
from .series import GeneratedWind, SeriesFile

YEAR = 365 * 86400.0
#: Bumped when the KPIs' definitions change: stored results of older ones are not reused.
KPI_VERSION = 1
SPECIAL_AXES = ("series", "seed", "hub_size", "step", "horizon")


@dataclass
class Scenario:
    key: str
    definition: dict   # what is run (hashed into the key)
    labels: dict       # axis column -> value, for the table


def scenario_key(definition):
    """sha256 of the definition's canonical JSON (sorted keys, floats as their repr)."""
    text = json.dumps(definition, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def _known(table, keys, where):
    unknown = set(table) - keys
    if unknown:
        raise ValueError(f"{where}: unknown keys {sorted(unknown)}; known: {sorted(keys)}")


class Study:
    """A study file read and checked: its series, its fixed parameters and its axes."""

    def __init__(self, path):
        self.path = Path(path)
        here = self.path.resolve().parent
        with open(self.path, "rb") as f:
            doc = tomllib.load(f)
        unknown = set(doc) - {"study", "parameters", "series", "axes"}
        if unknown:
            raise ValueError(f"{self.path}: unknown tables {sorted(unknown)}")
        head = doc.get("study", {})
        _known(head, {"title", "fmu", "horizon", "step"}, "[study]")
        self.title = head.get("title", self.path.stem)
        try:
            self.fmu = locate.fmu_path((here / head["fmu"]).resolve() if "fmu" in head else None)
        except locate.NotBuilt as e:
            raise ValueError(f"{e} (set fmu = ... in [study])") from None
        self.fmu_bytes = self.fmu.read_bytes()
        self.model = ModelParameters(self.fmu)
        self.step = duration(head.get("step", 1.0), "step")
        self.horizon = duration(head["horizon"], "horizon") if "horizon" in head else None
        self.files = {}  # sha256 -> bytes of files that String parameters name
        self.parameters = {name: self._parameter(name, value, here) for name, value in doc.get("parameters", {}).items()}
        self.series = {name: self._series(name, spec, here) for name, spec in doc.get("series", {}).items()}
        if not self.series:
            raise ValueError(f"{self.path}: no [series.NAME] table")
        self.axes = self._axes(doc.get("axes", {}), here)
        self._scenarios = None

    def _parameter(self, name, value, here):
        """The text aem-run sets; a String parameter naming a file ships the file by its hash."""
        text = self.model.text(name, value)
        if self.model.variables[name].type == "String" and text:
            data = (here / text).read_bytes()
            digest = hashlib.sha256(data).hexdigest()
            self.files[digest] = data
            return f"file:sha256:{digest}"
        return text

    def _series(self, name, spec, here):
        spec = dict(spec)
        if spec.pop("generator", None) == "wind":
            _known(spec, {"climate"}, f"[series.{name}]")
            try:
                return GeneratedWind(name, spec.pop("climate", {}))
            except TypeError as e:
                raise ValueError(f"series {name}: climate: {e}") from None
        if "file" not in spec:
            raise ValueError(f"series {name}: give generator = \"wind\" or file = ...")
        _known(spec, {"file", "time", "column", "interpolation", "rating"}, f"[series.{name}]")
        rating = spec.pop("rating", None)
        series = SeriesFile(name, here / spec.pop("file"), **spec)
        if rating is not None:
            series.rating = power(rating, f"series {name} rating")
        return series

    def _axes(self, spec, here):
        """[(column, [(label, settings)])]: settings are what the value sets in a scenario."""
        axes = []
        for name, values in spec.items():
            if isinstance(values, dict):  # named cases
                cases = [(case, {p: self._parameter(p, v, here) for p, v in settings.items()})
                         for case, settings in values.items()]
                axes.append((name, [(label, {"parameters": s}) for label, s in cases]))
            elif not isinstance(values, list) or not values:
                raise ValueError(f"axis {name}: give a non-empty list or a table of named cases")
            elif name == "series":
                missing = [v for v in values if v not in self.series]
                if missing:
                    raise ValueError(f"axis series: no series {missing}; series: {sorted(self.series)}")
                axes.append(("series", [(v, {"series": v}) for v in values]))
            elif name == "seed":
                axes.append(("seed", [(int(v), {"seed": int(v)}) for v in values]))
            elif name == "hub_size":
                axes.append(("hub size [%]", [(float(v), {"hub_size": float(v) / 100.0}) for v in values]))
            elif name in ("step", "horizon"):
                col = "step [s]" if name == "step" else "horizon [h]"
                axes.append((col, [(duration(v, name) / (1 if name == "step" else 3600), {name: duration(v, name)})
                                   for v in values]))
            else:
                axes.append((self.model.column(name),
                             [(self.model.label(name, v), {"parameters": {name: self._parameter(name, v, here)}})
                              for v in values]))
        if not any(col == "series" for col, _ in axes):
            axes.insert(0, ("series", [(name, {"series": name}) for name in self.series]))
        return axes

    @property
    def axis_columns(self):
        return [column for column, _ in self.axes]

    def scenarios(self):
        """Every combination of the axes' values, in the axes' order; repeats dropped (a seed
        axis crossed with a file series). Computed once per study."""
        if self._scenarios is None:
            self._scenarios = self._cross()
        return self._scenarios

    def _cross(self):
        fmu_digest = hashlib.sha256(self.fmu_bytes).hexdigest()
        seen, out = set(), []
        for combination in itertools.product(*(values for _, values in self.axes)):
            settings = {"parameters": dict(self.parameters)}
            labels = {}
            for (column, _), (label, sets) in zip(self.axes, combination):
                labels[column] = label
                for k, v in sets.items():
                    if k == "parameters":
                        settings["parameters"].update(v)
                    else:
                        settings[k] = v
            series = self.series[settings["series"]]
            seed = settings.get("seed", 1)
            if isinstance(series, SeriesFile) and "seed" in labels:
                labels["seed"] = None  # a file series has no seed
            horizon = settings.get("horizon") or self.horizon or (YEAR if isinstance(series, GeneratedWind) else series.span())
            hub_size = settings.get("hub_size")
            definition = {
                "kpi version": KPI_VERSION,
                "fmu sha256": fmu_digest,
                "parameters": dict(sorted(settings["parameters"].items())),
                "series": series.definition(seed),
                "input": series.input,
                "hub size": hub_size,
                "source rating [W]": series.rating if hub_size is not None else None,
                "step [s]": settings.get("step", self.step),
                "horizon [s]": horizon,
            }
            key = scenario_key(definition)
            if key not in seen:
                seen.add(key)
                out.append(Scenario(key, definition, labels))
        return out

    def file_series_data(self):
        """sha256 -> (times, values) of the file series, what the workers need of them."""
        return {s.digest: (s.times, s.values) for s in self.series.values() if isinstance(s, SeriesFile)}
