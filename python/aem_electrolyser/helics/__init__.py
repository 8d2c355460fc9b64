"""The FMU in a HELICS 3 federation: broker, wind, hub and pandapower grid federates as
processes (`python -m aem_electrolyser.helics.NAME`), launched together by the runner file
`federation.json` of this folder. Needs the [helics] extra."""
