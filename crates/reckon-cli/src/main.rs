//! The `reckon` command: see [`reckon_cli`].

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args = reckon_cli::Args::parse();
    match reckon_cli::dispatch(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // a closed stderr must not turn a clean failure into a panic
            use std::io::Write;
            let _ = writeln!(std::io::stderr(), "reckon: {e}");
            ExitCode::FAILURE
        }
    }
}
