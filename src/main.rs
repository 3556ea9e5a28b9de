//! The `reckon` command: see [`reckon::cli`].

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args = reckon::cli::Args::parse();
    match reckon::cli::dispatch(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // a closed stderr must not turn a clean failure into a panic
            use std::io::Write;
            let _ = writeln!(std::io::stderr(), "reckon: {e}");
            ExitCode::FAILURE
        }
    }
}
