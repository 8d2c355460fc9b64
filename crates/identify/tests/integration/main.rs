//! aem-identify's integration tests, one binary (one build and one link instead of five):
//!
//! - `cli`: the command line, its errors and its exit statuses;
//! - `flags`: the options of `fit` and `validate`;
//! - `input`: the CSV reader's dialects, gaps and broken rows;
//! - `modules`: several modules in one campaign;
//! - `recovery`: synthetic campaigns with known parameters, recovered.
//!
//! One group: `cargo test -p aem-identify --test integration recovery`.

mod cli;
mod flags;
mod input;
mod modules;
mod recovery;
