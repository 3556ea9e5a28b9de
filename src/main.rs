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

/// Arguments of `reckon demo`.
#[derive(clap::Args)]
struct DemoArgs {
    /// Folder for the HTML report and its SVG figures.
    #[arg(long, default_value = "report")]
    out: std::path::PathBuf,
    /// Shorter studies (for tests and quick looks).
    #[arg(long)]
    fast: bool,
}

#[derive(Subcommand)]
enum Command {
    /// Every method on built-in problems (printed tables), then the report: vehicle
    /// scenarios, SLAM, UMBmark, IMU drift, convergence and stiffness studies, pitfalls.
    Demo(DemoArgs),
    /// Simulate a vehicle model driven by a controls CSV; write t,x,y,theta[,steer].
    Simulate(cli::simulate::SimulateArgs),
    /// Dead-reckon a differential-drive robot from encoder pulse increments.
    Odometry(cli::odometry::OdometryArgs),
    /// Observed order of convergence over a sequence of fixed steps.
    Convergence(cli::studies::ConvergenceArgs),
    /// Step-size behaviour, stiffness ratio, stability regions and the Dahlquist threshold.
    Stiffness(cli::studies::StiffnessArgs),
    /// Error against rhs evaluations and wall time over a tolerance sweep.
    WorkPrecision(cli::studies::WorkPrecisionArgs),
}

fn main() -> ExitCode {
    let args = Args::parse();
    let result = match args.command {
        Command::Demo(a) => cli::demo::run(&mut std::io::stdout().lock()).and_then(|()| {
            let n = cli::report::run(&a.out, a.fast)?;
            println!("\nwrote {} ({n} figures)", a.out.join("index.html").display());
            Ok(())
        }),
        Command::Simulate(a) => cli::simulate::run(&a),
        Command::Odometry(a) => cli::odometry::run(&a),
        Command::Convergence(a) => cli::studies::convergence(&a),
        Command::Stiffness(a) => cli::studies::stiffness(&a),
        Command::WorkPrecision(a) => cli::studies::work_precision(&a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("reckon: {e}");
            ExitCode::FAILURE
        }
    }
}
