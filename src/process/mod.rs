//! The `dmt-contour` process of OGC API - Processes: its execute inputs and their checks,
//! its description, and the pipeline call a worker makes for a job.
//!
//! Invariant: this is the only module that knows what a job's stored inputs mean. The
//! queue (`jobs`) stores and hands over bytes; the HTTP side (`api`) parses requests into
//! [`ProcessInputs`] and serves [`process_description`]; both stay ignorant of geometry.

pub mod description;
mod inputs;
mod pipeline;

pub use description::{
    InputDescription, Link, OutputDescription, PROCESS_ID, ProcessDescription, ProcessSummary,
    process_description, process_summary,
};
pub use inputs::{InputError, ProcessInputs, Thresholds};
pub use pipeline::ContourPipeline;
