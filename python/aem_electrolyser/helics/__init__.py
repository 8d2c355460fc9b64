"""The FMU in a HELICS 3 federation: broker, wind, hub and pandapower grid federates as
processes (`python -m aem_electrolyser.helics.NAME`), run together by
`python -m aem_electrolyser.helics.run`, which makes a runner file for helics-cli from the
template `federation.json` of this folder. Needs the [helics] extra."""
