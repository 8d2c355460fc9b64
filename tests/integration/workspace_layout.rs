//! The workspace's dependencies point one way: the FMU → `aem-model` ← `aem-identify`, and
//! `aem-run` drives the packaged FMU through its C interface only.
//! `cargo tree` of each package (normal and build dependencies) must not reach what lies
//! above or beside it, so the FMU binary carries none of the identification tool's crates.

use std::collections::BTreeSet;
use std::process::Command;

/// Every crate in the normal and build dependency tree of `package`.
fn dependency_tree(package: &str) -> BTreeSet<String> {
    let manifest = concat!(env!("CARGO_MANIFEST_DIR"), "/Cargo.toml");
    let output = Command::new(env!("CARGO"))
        .args([
            "tree",
            "--locked",
            "--manifest-path",
            manifest,
            "--package",
            package,
        ])
        .args([
            "--edges",
            "normal,build",
            "--prefix",
            "none",
            "--format",
            "{p}",
        ])
        .output()
        .expect("cargo tree runs");
    assert!(
        output.status.success(),
        "cargo tree -p {package}: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8(output.stdout)
        .expect("cargo tree prints UTF-8")
        .lines()
        .filter_map(|line| line.split_whitespace().next())
        .map(str::to_owned)
        .collect()
}

fn assert_absent(package: &str, tree: &BTreeSet<String>, forbidden: &[&str]) {
    let found: Vec<&&str> = forbidden
        .iter()
        .filter(|name| tree.contains(**name))
        .collect();
    assert!(
        found.is_empty(),
        "{package} depends on {found:?}; its tree: {tree:?}"
    );
}

/// The identification tool's crates (command line, CSV, timestamps, progress bar, fits).
/// nalgebra is not among them: the model's ODE solver (ode_solvers, for the stack
/// temperature) is built on it too.
const TOOL_CRATES: [&str; 6] = [
    "aem-identify",
    "clap",
    "csv",
    "chrono",
    "indicatif",
    "levenberg-marquardt",
];

#[test]
fn the_fmu_builds_on_the_model_and_carries_nothing_of_the_tool() {
    let tree = dependency_tree("aem-electrolyser-fmu");
    assert!(
        tree.contains("aem-model") && tree.contains("fmi-sys"),
        "{tree:?}"
    );
    assert_absent("aem-electrolyser-fmu", &tree, &TOOL_CRATES);
}

#[test]
fn the_model_knows_neither_the_fmu_nor_the_tool() {
    let tree = dependency_tree("aem-model");
    assert_absent("aem-model", &tree, &["aem-electrolyser-fmu", "fmi-sys"]);
    assert_absent("aem-model", &tree, &TOOL_CRATES);
}

#[test]
fn the_identification_uses_the_model_and_never_the_fmu() {
    let tree = dependency_tree("aem-identify");
    assert!(tree.contains("aem-model"), "{tree:?}");
    assert_absent("aem-identify", &tree, &["aem-electrolyser-fmu", "fmi-sys"]);
}

#[test]
fn the_runner_knows_the_model_only_through_the_packaged_fmu() {
    let tree = dependency_tree("aem-run");
    assert!(tree.contains("fmi"), "{tree:?}");
    assert_absent(
        "aem-run",
        &tree,
        &["aem-model", "aem-electrolyser-fmu", "aem-identify"],
    );
}
