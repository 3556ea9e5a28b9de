//! The `reckon` command: see [`reckon::cli`].

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args = reckon::cli::Args::parse();
    match reckon::cli::dispatch(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("reckon: {e}");
            ExitCode::FAILURE
        }
    }
}
