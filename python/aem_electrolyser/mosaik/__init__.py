"""The FMU in mosaik 3: the simulator (`simulator.AemSimulator`) and a scenario on pandapower's
CIGRE HV grid (`python -m aem_electrolyser.mosaik.cigre_scenario`). Needs the [mosaik] extra."""
