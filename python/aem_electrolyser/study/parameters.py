"""FMU parameters by their model-description names: the value a study file gives, checked
against the variable's type and, for enumerations, its items, as the text `aem-run` sets."""

from dataclasses import dataclass
from pathlib import Path

from fmpy import read_model_description

from aem_electrolyser.cli import did_you_mean


@dataclass(frozen=True)
class Variable:
    name: str
    type: str  # Real, Integer, Boolean, String or Enumeration
    unit: str | None
    items: dict | None  # enumeration: item name -> code


class ModelParameters:
    """The FMU's parameters, read from the model description inside the .fmu."""

    #: Set by aem-study itself (from the series' kind and the hub-size axis).
    RESERVED = {"powerInput"}

    def __init__(self, fmu: Path):
        md = read_model_description(str(fmu))
        self.variables = {
            v.name: Variable(
                v.name,
                v.type,
                v.unit or (v.declaredType.unit if v.declaredType else None),
                {i.name: int(i.value) for i in v.declaredType.items} if v.type == "Enumeration" else None,
            )
            for v in md.modelVariables
            if v.causality == "parameter"
        }

    def variable(self, name):
        """The parameter `name`, or a ValueError naming the FMU's parameters."""
        if name in self.RESERVED:
            raise ValueError(f"{name} is set by aem-study from the series (power or setpoint)")
        var = self.variables.get(name)
        if var is None:
            names = [n for n in self.variables if n not in self.RESERVED]
            raise ValueError(
                f"the FMU has no parameter {name!r}{did_you_mean(name, names)}; parameters: {', '.join(names)}"
            )
        return var

    def column(self, name):
        """Table column of a parameter axis: its name with its unit."""
        unit = self.variable(name).unit
        return f"{name} [{unit}]" if unit else name

    def text(self, name, value):
        """`value` of parameter `name` as the text aem-run sets (enumerations as codes)."""
        var = self.variable(name)
        if var.type == "Real" and isinstance(value, (int, float)) and not isinstance(value, bool):
            return repr(float(value))
        if var.type == "Integer" and isinstance(value, int) and not isinstance(value, bool):
            return str(value)
        if var.type == "Boolean" and isinstance(value, bool):
            return "true" if value else "false"
        if var.type == "String" and isinstance(value, str):
            return value
        if var.type == "Enumeration":
            if isinstance(value, str) and value in var.items:
                return str(var.items[value])
            if isinstance(value, int) and not isinstance(value, bool) and value in var.items.values():
                return str(value)
            raise ValueError(f"{name} = {value!r}: one of {', '.join(var.items)}{did_you_mean(value, var.items)}")
        raise ValueError(f"{name} = {value!r} is not {'an' if var.type[0] in 'IE' else 'a'} {var.type}")

    def label(self, name, value):
        """How the table shows `value` (enumerations by item name)."""
        var = self.variables[name]
        if var.type == "Enumeration" and isinstance(value, int):
            return next(item for item, code in var.items.items() if code == value)
        return value
