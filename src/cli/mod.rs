//! Subcommands of the `wellmesh` binary, one file each.

use std::io::IsTerminal;
use std::process::ExitCode;

use indicatif::{ProgressBar, ProgressStyle};
use wellmesh::progress::{Progress, Stage};

pub mod contour;
pub mod grid_input;
pub mod input;
pub mod inspect;
pub mod openapi;
pub mod outputs;
pub mod report;
pub mod serve;
pub mod service_flags;
pub mod tetrahedralize;
pub mod worker;

/// Exit code for an error the user can fix (bad input, bad arguments are clap's 2).
pub const EXIT_FAILURE: u8 = 1;

/// Exit code for bad command-line arguments, as clap uses it.
pub const EXIT_USAGE: u8 = 2;

/// Prints a refused option as the flag the user typed and returns the usage exit code.
pub fn bad_option(error: &wellmesh::contour::OptionError) -> ExitCode {
    let flag = match error.field {
        "thresholds" => "threshold".to_string(),
        field => field.replace('_', "-"),
    };
    eprintln!("error: --{flag}: {}", error.reason);
    ExitCode::from(EXIT_USAGE)
}

/// A progress bar on standard error when it is a terminal; silent otherwise.
pub struct Bar(Option<ProgressBar>);

impl Bar {
    pub fn new(quiet: bool) -> Self {
        if quiet || !std::io::stderr().is_terminal() {
            return Bar(None);
        }
        let bar = ProgressBar::new(100);
        bar.set_style(
            ProgressStyle::with_template("{spinner} {msg:24} [{bar:30}] {percent:>3}% {elapsed}")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        Bar(Some(bar))
    }

    pub fn finish(&self) {
        if let Some(bar) = &self.0 {
            bar.finish_and_clear();
        }
    }
}

impl Progress for Bar {
    fn report(&self, stage: Stage, fraction: f64) {
        if let Some(bar) = &self.0 {
            bar.set_message(stage.name());
            bar.set_position((fraction.clamp(0.0, 1.0) * 100.0) as u64);
        }
    }
}
