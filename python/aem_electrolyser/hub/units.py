"""Unit factors read from the FMU's model description, so that no copy of them lives here."""

from fmpy import read_model_description


def kg_per_nl(fmu):
    """kg per normal litre: the factor of the display unit kg of the FMU's hydrogen unit Nl."""
    unit = next(u for u in read_model_description(str(fmu)).unitDefinitions if u.name == "Nl")
    return next(d.factor for d in unit.displayUnits if d.name == "kg")
