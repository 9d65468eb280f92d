//! The `wellmesh` command line: contour wells into ore bodies, tetrahedralize points,
//! inspect inputs, and run the service.
#![forbid(unsafe_code)]

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod cli;

/// Closed ore-body surfaces from well logs and drill holes.
#[derive(Debug, Parser)]
#[command(name = "wellmesh", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Contour samples into closed ore bodies (GLB + summary JSON).
    Contour(Box<cli::contour::Args>),
    /// Delaunay-tetrahedralize a point file and print `points N tets T seconds S`.
    Tetrahedralize(cli::tetrahedralize::Args),
    /// Serve OGC API - Processes with embedded workers (SQLite in --data-dir by default).
    Serve(Box<cli::serve::Args>),
    /// Run workers only, against a shared job database.
    Worker(cli::worker::Args),
    /// Print the service's OpenAPI document.
    Openapi(cli::openapi::Args),
    /// Report what was read from the inputs: holes, samples, ranges, what was dropped and why.
    Inspect(Box<cli::inspect::Args>),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let outcome = match cli.command {
        Command::Contour(args) => cli::contour::run(*args),
        Command::Tetrahedralize(args) => cli::tetrahedralize::run(args),
        Command::Serve(args) => cli::serve::run(*args),
        Command::Worker(args) => cli::worker::run(args),
        Command::Openapi(args) => cli::openapi::run(args),
        Command::Inspect(args) => cli::inspect::run(*args),
    };
    match outcome {
        Ok(code) => code,
        Err(err) => {
            eprintln!("error: {}", describe(&err));
            ExitCode::from(cli::EXIT_FAILURE)
        }
    }
}

/// The error and its causes, `: `-separated as `{:#}` prints them, but without a cause
/// whose message the text before it already holds (errors such as the contour's
/// "tetrahedralization: ..." print their source themselves).
fn describe(err: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in err.chain() {
        let part = cause.to_string();
        if text.contains(&part) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&part);
    }
    text
}
