"""The paper's examples and the hub's, each a command: `python -m aem_electrolyser.examples.NAME`
(`--help` for its options; results into `out/NAME/` of the working folder by default)."""
