"""The FMU ships the paper's values: Table I and the operating window as tests/data/table_i.json
records them (the one copy the tests read) are the start values and units of the repository's
modelDescription.xml (read with ElementTree), of the packaged FMU's model description (read with
fmpy) and the values a fresh instance of the packaged binary holds. (aem_model's
Parameters::default() is checked against the same file by the model crate's own test.)"""

import xml.etree.ElementTree as ET

from conftest import ROOT, TABLE_I

NAMES = [row["name"] for row in TABLE_I]
#: name -> (value, unit)
WANT = {row["name"]: (row["value"], row["unit"]) for row in TABLE_I}


def test_the_file_names_each_parameter_once_with_its_source():
    assert len(set(NAMES)) == len(NAMES) == 11
    for row in TABLE_I:
        assert set(row) == {"name", "value", "unit", "source"}, row
        assert isinstance(row["value"], float) and row["source"], row


def test_the_repositorys_model_description_starts_at_table_i():
    variables = ET.parse(ROOT / "modelDescription.xml").getroot().find("ModelVariables")
    got = {}
    for sv in variables.findall("ScalarVariable"):
        if sv.get("name") in WANT:
            assert sv.get("causality") == "parameter", sv.get("name")
            real = sv.find("Real")
            got[sv.get("name")] = (float(real.get("start")), real.get("unit"))
    assert got == WANT


def test_the_packaged_model_description_starts_at_table_i(model_description):
    got = {}
    for v in model_description.modelVariables:
        if v.name in WANT:
            assert (v.causality, v.type) == ("parameter", "Real"), v.name
            got[v.name] = (float(v.start), v.unit)
    assert got == WANT


def test_a_fresh_instance_holds_table_i(driver):
    d = driver().initialize(setpoint=80.0)
    assert d.get(*NAMES) == [row["value"] for row in TABLE_I]
