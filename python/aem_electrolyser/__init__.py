"""AEM electrolyser modules and hubs as an FMI 2.0 Co-Simulation FMU, after Omtveit, Dannappel,
You and Uhlen (IEEE ISGT 2026), with the tools around it.

    import aem_electrolyser
    aem_electrolyser.fmu_path()          # the bundled AemElectrolyser.fmu (AEM_FMU overrides)

Subpackages: `hub` (drive the hub FMU step by step through fmpy), `wind` (a 64 MW wind farm and
generated wind years), `reserves` (frequency-reserve prequalification: `aem-prequalify`),
`study` (year-long studies on Dask: `aem-study`), `mosaik` and `helics` (the FMU in those
co-simulation frameworks), `examples` (the paper's examples, `python -m
aem_electrolyser.examples.NAME`). The native commands `aem-identify` and `aem-run` come with
the platform wheels.
"""

from importlib.metadata import PackageNotFoundError, version as _version

from .locate import NotBuilt, fmu_path

try:
    __version__ = _version("aem-electrolyser")
except PackageNotFoundError:  # imported from a source tree that was not installed
    __version__ = "unknown"

__all__ = ["fmu_path", "NotBuilt", "__version__"]
