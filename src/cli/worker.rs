//! `wellmesh worker`: flags mapped to the library's [`Settings`], then workers only,
//! sharing a PostgreSQL (or SQLite) job store, as [`WorkerNode`] runs them.
use std::process::ExitCode;

use wellmesh::startup::{Settings, WorkerNode, init_telemetry};

use super::service_flags::{DEFAULTS, WorkerArgs, runtime};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// The shared job store: `postgres://...` (or `sqlite://PATH` on one machine).
    #[arg(long, env = "WELLMESH_DATABASE_URL")]
    pub database_url: String,
    /// Jobs run at once by this process.
    #[arg(long, default_value_t = DEFAULTS.worker.concurrency, env = "WELLMESH_WORKERS")]
    pub workers: usize,
    #[command(flatten)]
    pub worker: WorkerArgs,
}

impl Args {
    /// The settings these flags ask for, over the library's defaults.
    pub fn settings(self) -> Settings {
        let mut settings = Settings::default();
        self.worker.apply(&mut settings);
        settings.database_url = Some(self.database_url);
        settings.worker.concurrency = self.workers.max(1);
        settings
    }
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let settings = args.settings();
    init_telemetry(settings.log_format);
    runtime()?
        .block_on(async move { WorkerNode::build(settings).await?.run_until_stopped().await })?;
    Ok(ExitCode::SUCCESS)
}
