//! Command-line parsing: one place where flags become typed options.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Parser, Debug)]
#[command(
    name = "zerotile",
    version,
    about = "EZW terrain tiles: ingest, serve, evaluate"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Measure the codec and mesher on one heightmap.
    #[command(subcommand)]
    Eval(EvalCommand),
}

#[derive(Subcommand, Debug)]
pub enum EvalCommand {
    /// Rate, distortion and mesh figures of the terrain codec (placeholder).
    Terrain,
}

/// Parses the arguments and runs the command; errors print one line and exit non-zero.
pub fn run() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Eval(EvalCommand::Terrain) => {
            eprintln!("zerotile: eval terrain is not implemented yet");
            ExitCode::from(2)
        }
    }
}
