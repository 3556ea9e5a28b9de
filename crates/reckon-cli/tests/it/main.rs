//! The command's integration tests, one binary: they run the built `reckon` or call
//! `reckon_cli::run` in-process. Run one file's tests with
//! `cargo test --release -p reckon-cli --test it <module>::`.

#[path = "../../../../tests/it/common/golden.rs"]
mod golden_file;

mod cli;
mod cli_calibrate;
mod cli_ensemble;
mod cli_preintegrate;
mod cli_studies;
mod docs_numbers;
mod fuzz_replay;
mod golden;
mod report;
mod spectral;
