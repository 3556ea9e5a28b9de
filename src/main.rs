//! The `reckon` command.

mod cli;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Integrate ordinary differential equations and dead-reckon vehicles.
#[derive(Parser)]
#[command(name = "reckon", version, about)]
struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Integrate built-in problems and a unicycle scenario with every method and print
    /// a table of error, steps and work.
    Demo,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let result = match args.command {
        Command::Demo => cli::demo::run(&mut std::io::stdout().lock()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("reckon: {e}");
            ExitCode::FAILURE
        }
    }
}
