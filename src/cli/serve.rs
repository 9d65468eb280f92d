//! `wellmesh serve`: flags mapped to the library's [`Settings`], then the HTTP API with
//! (by default) embedded workers on SQLite, as [`Application`] runs it.
use std::net::{IpAddr, SocketAddr};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::Context;
use wellmesh::api::{ApiKey, parse_key_file};
use wellmesh::startup::{Application, Settings, init_telemetry};

use super::service_flags::{DEFAULTS, WorkerArgs, runtime};

const MIB: usize = 1024 * 1024;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Address to listen on (port 0 picks a free port, printed at start).
    #[arg(long, default_value_t = DEFAULTS.bind, env = "WELLMESH_BIND")]
    pub bind: SocketAddr,
    /// Directory of the embedded SQLite database (used without --database-url).
    #[arg(long, default_value_os_t = DEFAULTS.data_dir.clone(), env = "WELLMESH_DATA_DIR")]
    pub data_dir: PathBuf,
    /// `postgres://...` to share jobs with other nodes, or `sqlite://PATH`.
    #[arg(long, env = "WELLMESH_DATABASE_URL")]
    pub database_url: Option<String>,
    /// Jobs run at once by this process; 0 serves the API only.
    #[arg(long, default_value_t = DEFAULTS.worker.concurrency, env = "WELLMESH_WORKERS")]
    pub workers: usize,
    /// Directory of the browser viewer.
    #[arg(long, default_value_os_t = DEFAULTS.api.viewer_dir.clone(), env = "WELLMESH_VIEWER_DIR")]
    pub viewer_dir: PathBuf,
    /// Largest request body, in MiB (413 beyond).
    #[arg(long, default_value_t = DEFAULTS.api.max_body_bytes / MIB, env = "WELLMESH_MAX_BODY_MB")]
    pub max_body_mb: usize,
    /// Most samples per request (422 beyond).
    #[arg(long, default_value_t = DEFAULTS.api.max_points, env = "WELLMESH_MAX_POINTS")]
    pub max_points: usize,
    /// Requests with at most this many samples run synchronously unless they send
    /// `Prefer: respond-async`.
    #[arg(long, default_value_t = DEFAULTS.api.sync_max_points, env = "WELLMESH_SYNC_MAX_POINTS")]
    pub sync_max_points: usize,
    /// Seconds a synchronous request waits before answering 201 (job continues).
    #[arg(long, default_value_t = DEFAULTS.api.sync_wait.as_secs(), env = "WELLMESH_SYNC_WAIT_SECS")]
    pub sync_wait_secs: u64,
    /// Most jobs waiting in the queue (429 beyond); 0: no limit.
    #[arg(long, default_value_t = DEFAULTS.api.max_queued.unwrap_or(0), env = "WELLMESH_MAX_QUEUED")]
    pub max_queued: i64,
    /// Bearer API key required on /jobs and executions (repeatable; comma-separated
    /// in the environment). Each key sees only the jobs it submitted. A key given here
    /// shows in `ps`: prefer the environment or --api-keys-file. None: no authentication.
    #[arg(long = "api-key", env = "WELLMESH_API_KEYS", value_delimiter = ',')]
    pub api_keys: Vec<String>,
    /// A key that sees and dismisses every job (repeatable; comma-separated in the
    /// environment).
    #[arg(long = "admin-key", env = "WELLMESH_ADMIN_KEYS", value_delimiter = ',')]
    pub admin_keys: Vec<String>,
    /// A file of keys, one per line, `KEY` or `KEY admin` (`#` starts a comment).
    #[arg(long, env = "WELLMESH_API_KEYS_FILE")]
    pub api_keys_file: Option<PathBuf>,
    /// Routes that need a key too when keys are set: metrics, viewer, docs (repeatable).
    #[arg(long = "require-key-on", env = "WELLMESH_REQUIRE_KEY_ON", value_delimiter = ',', value_parser = ["metrics", "viewer", "docs"])]
    pub require_key_on: Vec<String>,
    /// The URL clients reach this service at (`https://host/prefix`): every absolute link
    /// and `Location` starts with it. Without it, links follow the request's `Host`.
    #[arg(long, env = "WELLMESH_PUBLIC_URL")]
    pub public_url: Option<String>,
    /// Address of a reverse proxy whose `X-Forwarded-Host`/`-Proto` are believed
    /// (repeatable; comma-separated in the environment).
    #[arg(
        long = "trusted-proxy",
        env = "WELLMESH_TRUSTED_PROXIES",
        value_delimiter = ','
    )]
    pub trusted_proxies: Vec<IpAddr>,
    /// Finished jobs are deleted this long after they finish (`3d`, `12h`, `90s`; `0`
    /// keeps them forever).
    #[arg(long, default_value_t = humantime::Duration::from(DEFAULTS.retention.unwrap_or_default()), env = "WELLMESH_RETENTION")]
    pub retention: humantime::Duration,
    /// Seconds a client may take to send its request headers.
    #[arg(long, default_value_t = DEFAULTS.edge.header_read_timeout.as_secs(), env = "WELLMESH_HEADER_TIMEOUT_SECS")]
    pub header_timeout_secs: u64,
    /// Seconds a client may take to send its request body (408 beyond).
    #[arg(long, default_value_t = DEFAULTS.api.body_read_timeout.as_secs(), env = "WELLMESH_BODY_TIMEOUT_SECS")]
    pub body_timeout_secs: u64,
    /// On SIGTERM, seconds open connections get before they are dropped.
    #[arg(long, default_value_t = DEFAULTS.edge.shutdown_deadline.as_secs(), env = "WELLMESH_SHUTDOWN_DEADLINE_SECS")]
    pub shutdown_deadline_secs: u64,
    /// Executions with a body over 1 MiB read at once (429 + Retry-After beyond).
    #[arg(long, default_value_t = DEFAULTS.api.max_large_uploads, env = "WELLMESH_MAX_LARGE_UPLOADS")]
    pub max_large_uploads: usize,
    #[command(flatten)]
    pub worker: WorkerArgs,
}

impl Args {
    /// The settings these flags ask for, over the library's defaults.
    pub fn settings(self) -> anyhow::Result<Settings> {
        let mut settings = Settings::default();
        self.worker.apply(&mut settings);
        settings.bind = self.bind;
        settings.data_dir = self.data_dir;
        settings.database_url = self.database_url;
        settings.worker.concurrency = self.workers;
        let api = &mut settings.api;
        api.viewer_dir = self.viewer_dir;
        api.max_body_bytes = self.max_body_mb.saturating_mul(MIB);
        api.max_points = self.max_points;
        api.sync_max_points = self.sync_max_points;
        api.sync_wait = Duration::from_secs(self.sync_wait_secs);
        api.max_queued = (self.max_queued > 0).then_some(self.max_queued);
        let keys = self.api_keys.iter().filter(|k| !k.is_empty());
        api.api_keys = keys.map(|k| ApiKey::new(k)).collect();
        let admins = self.admin_keys.iter().filter(|k| !k.is_empty());
        api.api_keys.extend(admins.map(|k| ApiKey::admin(k)));
        if let Some(path) = &self.api_keys_file {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("reading the key file {}", path.display()))?;
            let keys = parse_key_file(&text)
                .map_err(|e| anyhow::anyhow!("the key file {}: {e}", path.display()))?;
            api.api_keys.extend(keys);
        }
        for route in &self.require_key_on {
            match route.as_str() {
                "metrics" => api.open_routes.metrics = false,
                "viewer" => api.open_routes.viewer = false,
                _ => api.open_routes.docs = false,
            }
        }
        api.public_url = self.public_url;
        api.trusted_proxies = self.trusted_proxies;
        api.body_read_timeout = Duration::from_secs(self.body_timeout_secs.max(1));
        api.max_large_uploads = self.max_large_uploads.max(1);
        let retention: Duration = self.retention.into();
        settings.retention = (!retention.is_zero()).then_some(retention);
        settings.edge.header_read_timeout = Duration::from_secs(self.header_timeout_secs.max(1));
        settings.edge.shutdown_deadline = Duration::from_secs(self.shutdown_deadline_secs);
        Ok(settings)
    }
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let settings = args.settings()?;
    init_telemetry(settings.log_format);
    runtime()?.block_on(async move {
        let app = Application::build(settings).await?;
        println!("wellmesh listening on http://{}", app.address());
        app.run_until_stopped().await
    })?;
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::*;

    #[derive(Debug, Parser)]
    struct Serve {
        #[command(flatten)]
        args: Args,
    }

    #[test]
    fn without_flags_serve_runs_on_the_library_defaults() {
        let settings = Serve::try_parse_from(["serve"])
            .unwrap()
            .args
            .settings()
            .unwrap();
        let defaults = Settings::default();
        assert_eq!(settings.bind, defaults.bind);
        assert_eq!(settings.data_dir, defaults.data_dir);
        assert_eq!(settings.database_url, None);
        assert_eq!(settings.api, defaults.api);
        assert_eq!(settings.log_format, defaults.log_format);
        assert_eq!(settings.edge, defaults.edge);
        assert_eq!(settings.retention, defaults.retention);
        let (worker, wanted) = (&settings.worker, &defaults.worker);
        assert_eq!(worker.concurrency, wanted.concurrency);
        assert_eq!(worker.lease, wanted.lease);
        assert_eq!(worker.heartbeat, wanted.heartbeat);
        assert_eq!(worker.poll, wanted.poll);
        assert_eq!(worker.time_limit, wanted.time_limit);
        assert_eq!(worker.shutdown_grace, wanted.shutdown_grace);
    }

    #[test]
    fn flags_reach_the_settings_in_their_units() {
        let settings = Serve::try_parse_from([
            "serve",
            "--max-body-mb",
            "2",
            "--max-queued",
            "0",
            "--sync-wait-secs",
            "5",
            "--heartbeat-ms",
            "10",
            "--api-key",
            "a",
            "--api-key",
            "",
            "--workers",
            "0",
        ])
        .unwrap()
        .args
        .settings()
        .unwrap();
        assert_eq!(settings.api.max_body_bytes, 2 * MIB);
        assert_eq!(settings.api.max_queued, None);
        assert_eq!(settings.api.sync_wait, Duration::from_secs(5));
        assert_eq!(settings.worker.heartbeat, Duration::from_millis(50));
        assert_eq!(settings.api.api_keys, vec![ApiKey::new("a")]);
        assert_eq!(settings.worker.concurrency, 0);
    }
}
