"""aem-study: year-long studies of electrolyser hubs on the packaged FMU, run serially or on a
Dask cluster. Scenarios are crossed from a study file (TOML); each is driven through the native
master `aem-run` (crates/runner), which computes its KPIs; results are stored per scenario
under a key of its full definition, so a study resumes where it stopped."""
