//! `wellmesh openapi`: prints the service's OpenAPI document.
use std::process::ExitCode;

#[derive(Debug, clap::Args)]
pub struct Args {}

pub fn run(_args: Args) -> anyhow::Result<ExitCode> {
    print!("{}", wellmesh::api::openapi_json());
    Ok(ExitCode::SUCCESS)
}
