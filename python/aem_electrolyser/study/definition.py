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
    rating = "50 MW"             # what hub_size is a % of (power series; default: the largest value)

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

Everything in the file is checked when it is read, before anything runs: a mistake is a
StudyError, one line naming the file, the table and the key, what is allowed there and the
nearest allowed name ("did you mean ...").
"""

import hashlib
import itertools
import json
import math
import os
import tomllib
from dataclasses import dataclass
from pathlib import Path

from dataclasses import fields

from aem_electrolyser import locate
from aem_electrolyser.cli import did_you_mean
from aem_electrolyser.wind.year import WindClimate

from .parameters import ModelParameters
from .quantities import duration, power
from .series import TIME_COLUMN, GeneratedWind, SeriesFile, series_columns, series_input

YEAR = 365 * 86400.0
#: Bumped when the KPIs' definitions change: stored results of older ones are not reused.
KPI_VERSION = 3
SPECIAL_AXES = ("series", "seed", "hub_size", "step", "horizon")
TABLES = ("study", "parameters", "series", "axes")
STUDY_KEYS = ("title", "fmu", "horizon", "step")
FILE_SERIES_KEYS = ("file", "time", "column", "interpolation", "rating")


class StudyError(ValueError):
    """A mistake in a study file, as one line: the file, the table and key, what is allowed."""


@dataclass
class Scenario:
    key: str
    definition: dict  # what is run (hashed into the key)
    labels: dict  # axis column -> value, for the table


def scenario_key(definition):
    """sha256 of the definition's canonical JSON (sorted keys, floats as their repr)."""
    text = json.dumps(definition, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def _known(table, keys, where):
    """Refuses the first key of `table` that is not one of `keys`, suggesting the nearest."""
    for key in table:
        if key not in keys:
            raise ValueError(f"{where}: unknown key {key!r}{did_you_mean(key, keys)}; keys: {', '.join(keys)}")


def _table(value, where):
    """`value` if it is a TOML table, else a ValueError naming `where`."""
    if not isinstance(value, dict):
        raise ValueError(f"{where} must be a table, not {value!r}")
    return value


def _number(value):
    return isinstance(value, (int, float)) and not isinstance(value, bool) and value == value


def _positive_duration(value, where):
    seconds = duration(value, where)
    if not 0 < seconds < float("inf"):
        raise ValueError(f"{where}: {value!r} is not a positive duration")
    return seconds


class Study:
    """A study file read and checked: its series, its fixed parameters and its axes."""

    def __init__(self, path):
        self.path = Path(path)
        self._scenarios = None
        try:
            self._read(self._load())
        except StudyError:
            raise
        except (ValueError, TypeError) as e:
            raise StudyError(f"{self.path}: {' '.join(str(e).split())}") from None

    def _load(self):
        try:
            with open(self.path, "rb") as f:
                return tomllib.load(f)
        except FileNotFoundError:
            raise StudyError(f"{self.path}: no such study file") from None
        except IsADirectoryError:
            raise StudyError(f"{self.path}: a folder, not a study file") from None
        except OSError as e:
            raise StudyError(f"{self.path}: cannot read the study file ({e.strerror})") from None
        except UnicodeDecodeError:
            raise StudyError(f"{self.path}: not UTF-8 text, not a study file (TOML)") from None
        except tomllib.TOMLDecodeError as e:
            raise StudyError(f"{self.path}: not valid TOML: {e}") from None

    def _read(self, doc):
        here = self.path.resolve().parent
        for name in doc:
            if name not in TABLES:
                raise ValueError(
                    f"unknown table [{name}]{did_you_mean(name, TABLES)}; tables: {', '.join(f'[{t}]' for t in TABLES)}"
                )
            _table(doc[name], f"[{name}]")
        head = doc.get("study", {})
        _known(head, STUDY_KEYS, "[study]")
        for key in ("title", "fmu"):
            if key in head and not isinstance(head[key], str):
                raise ValueError(f"[study] {key} must be a string, not {head[key]!r}")
        self.title = head.get("title", self.path.stem)
        # Without fmu = ... the environment variable AEM_FMU names the FMU if set: an error is its.
        variable = locate.FMU_VARIABLE
        from_environment = "fmu" not in head and bool(os.environ.get(variable))
        try:
            self.fmu = locate.fmu_path((here / head["fmu"]).resolve() if "fmu" in head else None)
        except locate.NotBuilt as e:
            if from_environment:
                raise StudyError(
                    f"{variable}: {os.environ[variable]}: no such FMU (the environment variable {variable} "
                    f"names the FMU of a study without fmu = ... in [study]: correct it or unset it)"
                ) from None
            raise ValueError(f"[study] fmu: {e} (set fmu = ... in [study])") from None
        try:
            self.fmu_bytes = self.fmu.read_bytes()
            self.model = ModelParameters(self.fmu)
        except Exception as e:  # noqa: BLE001 - an unreadable file or no FMU: fmpy's words
            why = f"{self.fmu} is not an FMU ({' '.join(str(e).split())})"
            if from_environment:
                raise StudyError(f"{variable}: {why}; the environment variable {variable} names the FMU") from None
            raise ValueError(f"[study] fmu: {why}") from None
        self.step = _positive_duration(head.get("step", 1.0), "[study] step")
        self.horizon = _positive_duration(head["horizon"], "[study] horizon") if "horizon" in head else None
        self.files = {}  # sha256 -> bytes of files that String parameters name
        self.parameters = {}
        for name, value in doc.get("parameters", {}).items():
            if name in SPECIAL_AXES:
                raise ValueError(
                    f"[parameters] {name} is an axis, not an FMU parameter: give it under [axes] ({name} = [...])"
                )
            self.parameters[name] = self._parameter(name, value, here, "[parameters]")
        self.series = {
            name: self._series(name, _table(spec, f"[series.{name}]"), here)
            for name, spec in doc.get("series", {}).items()
        }
        if not self.series:
            raise ValueError('no [series.NAME] table: give a generated wind year (generator = "wind") or a file')
        self.axes = self._axes(doc.get("axes", {}), here)
        self._check_hub_sizes()

    def _check_hub_sizes(self):
        """A hub_size axis needs a rating for every series it is crossed with: a power series
        with a positive rating (its own or its largest value)."""
        axes = dict(self.axes)
        if "hub size [%]" not in axes:
            return
        for name in dict.fromkeys(sets["series"] for _, sets in axes["series"]):
            series = self.series[name]
            if series.input != "power":
                raise ValueError(
                    f"[axes] hub_size: series {name!r} is a setpoint series (%); hub sizes are % of a power "
                    "series' rating"
                )
            if getattr(series, "error", None) is None and not series.rating > 0:
                raise ValueError(
                    f"[axes] hub_size: series {name!r} has no positive value to size hubs against: "
                    f'give rating = "... MW" in [series.{name}]'
                )

    def valid_axes(self):
        """The names an [axes] key may have: the special axes and the FMU's parameters."""
        return list(SPECIAL_AXES) + [p for p in self.model.variables if p not in self.model.RESERVED]

    def _parameter(self, name, value, here, where):
        """The text aem-run sets; a String parameter naming a file ships the file by its hash."""
        try:
            text = self.model.text(name, value)
        except ValueError as e:
            raise ValueError(f"{where} {e}") from None
        if self.model.variables[name].type == "String" and text:
            try:
                data = (here / text).read_bytes()
            except OSError as e:
                raise ValueError(f"{where} {name} = {value!r}: cannot read {here / text} ({e.strerror})") from None
            digest = hashlib.sha256(data).hexdigest()
            self.files[digest] = data
            return f"file:sha256:{digest}"
        return text

    def _series(self, name, spec, here):
        where = f"[series.{name}]"
        spec = dict(spec)
        if "generator" in spec:
            generator = spec.pop("generator")
            if generator != "wind":
                raise ValueError(f'{where} generator = {generator!r}: the one generator is "wind"')
            _known(spec, ("climate",), where)
            climate = _table(spec.pop("climate", {}), f"{where} climate")
            known = [f.name for f in fields(WindClimate)]
            for key, value in climate.items():
                if key not in known:
                    raise ValueError(
                        f"{where} climate: unknown field {key!r}{did_you_mean(key, known)}; fields: {', '.join(known)}"
                    )
                if not _number(value):
                    raise ValueError(f"{where} climate: {key} = {value!r} is not a number")
            return GeneratedWind(name, climate)
        if "file" not in spec:
            raise ValueError(f'{where}: give generator = "wind" or file = "..."')
        _known(spec, FILE_SERIES_KEYS, where)
        for key in ("file", "time", "column", "interpolation"):
            if key in spec and not isinstance(spec[key], str):
                raise ValueError(f"{where} {key} must be a string, not {spec[key]!r}")
        if "column" not in spec:
            raise ValueError(f'{where}: give column = "NAME [unit]" (W, kW, MW or %)')
        path = here / spec.pop("file")
        if not path.is_file():
            raise ValueError(f"{where} file: no file {path}")
        # The file's header against the keys that name its columns, now: the rows are the
        # scenarios' to fail alone ("row 2: the value is not a number"), its columns the file's.
        try:
            columns = series_columns(path)
        except Exception as e:  # noqa: BLE001 - pandas', pyarrow's or the csv sniffer's words
            raise ValueError(f"{where} file: cannot read the columns of {path} ({' '.join(str(e).split())})") from None
        for key, default in (("time", TIME_COLUMN), ("column", None)):
            wanted = spec.get(key, default)
            if wanted not in columns:
                given = "" if key in spec else ' (the default: give time = "NAME")'
                raise ValueError(
                    f"{where} {key}: no column {wanted!r}{given} in {path}{did_you_mean(wanted, columns)}; "
                    f"its columns: {', '.join(map(repr, columns))}"
                )
        kind = series_input(spec["column"])
        if kind is None:
            raise ValueError(
                f"{where} column: {spec['column']!r} names no unit W, kW, MW or % in brackets "
                '(e.g. "power [MW]" or "setpoint [%]")'
            )
        rating = spec.pop("rating", None)
        if rating is not None:
            if kind != "power":
                raise ValueError(
                    f"{where} rating: {spec['column']!r} is a setpoint series (%); rating is for power series "
                    "(W, kW, MW): the power hub sizes are % of"
                )
            rating_value = power(rating, f"{where} rating")
            if not 0 < rating_value < math.inf:
                raise ValueError(f"{where} rating: {rating!r} is not a positive power")
        try:
            series = SeriesFile(name, path, **spec)
        except ValueError as e:
            raise ValueError(f"{where} {e}") from None
        if rating is not None:
            series.rating = rating_value
        return series

    def _axes(self, spec, here):
        """[(column, [(label, settings)])]: settings are what the value sets in a scenario."""
        axes = []
        for name, values in spec.items():
            where = f"[axes] {name}"
            if isinstance(values, dict):  # named cases
                if not values:
                    raise ValueError(f"[axes.{name}]: give at least one named case")
                cases = []
                for case, settings in values.items():
                    settings = _table(settings, f"[axes.{name}] {case}")
                    if not settings:
                        raise ValueError(f"[axes.{name}] {case}: set at least one FMU parameter")
                    cases.append(
                        (case, {p: self._parameter(p, v, here, f"[axes.{name}] {case}:") for p, v in settings.items()})
                    )
                axes.append((name, [(label, {"parameters": s}) for label, s in cases]))
                continue
            valid = self.valid_axes()
            if name not in valid:
                if name in self.model.RESERVED:
                    raise ValueError(f"{where}: {name} is set by aem-study from the series (power or setpoint)")
                parameters = valid[len(SPECIAL_AXES) :]
                raise ValueError(
                    f"[axes]: unknown axis {name!r}{did_you_mean(name, valid)}; valid axes: "
                    f"{', '.join(SPECIAL_AXES)}, a table of named cases [axes.NAME], or an FMU parameter "
                    f"({', '.join(parameters)})"
                )
            if not isinstance(values, list) or not values:
                raise ValueError(
                    f"{where}: give a non-empty list of values (or a table of named cases), not {values!r}"
                )
            if name == "series":
                missing = [v for v in values if v not in self.series]
                if missing:
                    raise ValueError(
                        f"{where}: no series {missing[0]!r}{did_you_mean(missing[0], self.series)}; "
                        f"series: {', '.join(self.series)}"
                    )
                axes.append(("series", [(v, {"series": v}) for v in values]))
            elif name == "seed":
                bad = [v for v in values if not isinstance(v, int) or isinstance(v, bool) or v < 0]
                if bad:
                    raise ValueError(f"{where}: {bad[0]!r} is not a seed (an integer, 0 or more)")
                axes.append(("seed", [(v, {"seed": v}) for v in values]))
            elif name == "hub_size":
                bad = [v for v in values if not _number(v) or not 0 < v < float("inf")]
                if bad:
                    raise ValueError(
                        f"{where}: {bad[0]!r} is not a hub size (a positive number, % of the series' rating)"
                    )
                axes.append(("hub size [%]", [(float(v), {"hub_size": float(v) / 100.0}) for v in values]))
            elif name in ("step", "horizon"):
                col = "step [s]" if name == "step" else "horizon [h]"
                seconds = [_positive_duration(v, where) for v in values]
                axes.append((col, [(t / (1 if name == "step" else 3600), {name: t}) for t in seconds]))
            else:
                axes.append(
                    (
                        self.model.column(name),
                        [
                            (
                                self.model.label(name, v),
                                {"parameters": {name: self._parameter(name, v, here, "[axes]")}},
                            )
                            for v in values
                        ],
                    )
                )
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
            horizon = (
                settings.get("horizon")
                or self.horizon
                or (YEAR if isinstance(series, GeneratedWind) else series.span())
            )
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
