//! What a worker runs for one job: execute inputs in, stored outputs out.
//!
//! Invariant: [`Pipeline::run`] is called on a CPU (rayon) thread, never on an async
//! runtime thread, and returns [`JobFailure::Cancelled`] soon after its `Progress`
//! starts answering `is_cancelled() == true`.

use crate::contour::{self, ContourError};
use crate::export::{self, OutputOptions};
use crate::progress::Progress;
use crate::wells::{Input, SampleSet};

use super::{ProcessInputs, StoredOutput};

/// Why a job produced no outputs.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum JobFailure {
    /// The inputs could not be read or contoured; the message names the field or row.
    #[error("{0}")]
    Input(String),
    /// The job was dismissed, its lease was lost, or its time ran out.
    #[error("cancelled")]
    Cancelled,
    /// Something the user cannot fix.
    #[error("internal error: {0}")]
    Internal(String),
}

/// Turns execute inputs into outputs. The service uses [`ContourPipeline`]; tests of
/// the queue plug in pipelines whose duration and outcome they control.
pub trait Pipeline: Send + Sync + 'static {
    fn run(
        &self,
        inputs: &ProcessInputs,
        progress: &dyn Progress,
    ) -> Result<Vec<StoredOutput>, JobFailure>;
}

/// The real pipeline: read wells, `contour::run`, export every output.
#[derive(Debug, Default, Clone, Copy)]
pub struct ContourPipeline;

impl Pipeline for ContourPipeline {
    fn run(
        &self,
        inputs: &ProcessInputs,
        progress: &dyn Progress,
    ) -> Result<Vec<StoredOutput>, JobFailure> {
        progress.report("read wells", 0.0);
        let samples = load_samples(&inputs.wells_input())?;
        progress.report("read wells", 1.0);
        if progress.is_cancelled() {
            return Err(JobFailure::Cancelled);
        }
        let request = inputs
            .contour_request(samples)
            .map_err(|e| JobFailure::Input(e.to_string()))?;
        let result = contour::run(&request, progress).map_err(|e| match e {
            ContourError::Cancelled => JobFailure::Cancelled,
            other => JobFailure::Input(other.to_string()),
        })?;
        if progress.is_cancelled() {
            return Err(JobFailure::Cancelled);
        }
        progress.report("export", 0.0);
        let defaults = OutputOptions::default();
        let options = OutputOptions {
            well_traces: inputs.well_traces.unwrap_or(defaults.well_traces),
            well_samples: inputs.well_samples.unwrap_or(defaults.well_samples),
            ..defaults
        };
        let outputs = export::all_outputs(&result, &options)
            .map_err(|e| JobFailure::Internal(format!("exporting the results: {e}")))?;
        progress.report("export", 1.0);
        Ok(outputs
            .into_iter()
            .map(|output| StoredOutput {
                id: output.id.to_string(),
                file_name: output.file_name,
                media_type: output.media_type.to_string(),
                bytes: output.bytes,
            })
            .collect())
    }
}

fn load_samples(input: &Input) -> Result<SampleSet, JobFailure> {
    input.load().map_err(|e| JobFailure::Input(e.to_string()))
}
