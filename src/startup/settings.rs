//! The service's settings: what `wellmesh serve` and `wellmesh worker` are told, with
//! one set of defaults that the command line shows and the tests start from.
//!
//! Invariant: every default is written once. The HTTP limits live in
//! [`ApiConfig::default`], the worker timings in [`WorkerConfig::default`], and the
//! process-wide rest in [`Settings::default`], which composes them; the command line
//! reads its defaults from here rather than restating them.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;

use anyhow::Context;

use crate::api::ApiConfig;
use crate::jobs::WorkerConfig;

/// How log lines are written on stderr.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogFormat {
    /// One human-readable line per event.
    Text,
    /// One JSON object per line, for log collectors.
    Json,
}

impl LogFormat {
    /// `json` (any case) is JSON; anything else is text.
    pub fn from_name(name: &str) -> Self {
        if name.eq_ignore_ascii_case("json") {
            LogFormat::Json
        } else {
            LogFormat::Text
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            LogFormat::Text => "text",
            LogFormat::Json => "json",
        }
    }
}

/// Everything a service process needs to start.
#[derive(Debug, Clone)]
pub struct Settings {
    /// Address the HTTP API listens on; port 0 takes any free port
    /// ([`super::Application::address`] tells which).
    pub bind: SocketAddr,
    /// Directory of the embedded SQLite database, used without `database_url`.
    pub data_dir: PathBuf,
    /// `postgres://...` to share jobs between processes, or `sqlite://PATH`.
    pub database_url: Option<String>,
    /// The HTTP side's limits and switches.
    pub api: ApiConfig,
    /// The workers' timings; `worker.concurrency` 0 serves the API only.
    pub worker: WorkerConfig,
    pub log_format: LogFormat,
    /// Limits on connections and shutdown.
    pub edge: EdgeLimits,
    /// Finished jobs older than this are deleted with their inputs and outputs by a
    /// background sweep; `None` keeps them forever.
    pub retention: Option<Duration>,
}

/// Limits at the HTTP edge: what one slow or hostile client can hold.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EdgeLimits {
    /// A connection whose request headers have not all arrived by then is closed.
    pub header_read_timeout: Duration,
    /// After SIGTERM, connections still open by then are dropped and the process ends.
    pub shutdown_deadline: Duration,
}

impl Default for EdgeLimits {
    fn default() -> Self {
        EdgeLimits {
            header_read_timeout: Duration::from_secs(10),
            shutdown_deadline: Duration::from_secs(30),
        }
    }
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            bind: SocketAddr::from(([127, 0, 0, 1], 8080)),
            data_dir: PathBuf::from("wellmesh-data"),
            database_url: None,
            api: ApiConfig::default(),
            worker: WorkerConfig::default(),
            log_format: LogFormat::Text,
            edge: EdgeLimits::default(),
            retention: Some(Duration::from_secs(3 * 24 * 3600)),
        }
    }
}

impl Settings {
    /// The job store's URL: `database_url`, or `wellmesh.db` in `data_dir` (created here
    /// if missing).
    pub fn store_url(&self) -> anyhow::Result<String> {
        if let Some(url) = &self.database_url {
            return Ok(url.clone());
        }
        std::fs::create_dir_all(&self.data_dir)
            .with_context(|| format!("creating the data directory {}", self.data_dir.display()))?;
        Ok(format!(
            "sqlite://{}",
            self.data_dir.join("wellmesh.db").display()
        ))
    }
}

/// The URL without its password, for logs and errors.
pub fn redact_url(url: &str) -> String {
    match (url.find("://"), url.rfind('@')) {
        (Some(scheme), Some(at)) if at > scheme => {
            let credentials = &url[scheme + 3..at];
            match credentials.find(':') {
                Some(colon) => format!(
                    "{}{}:***{}",
                    &url[..scheme + 3],
                    &credentials[..colon],
                    &url[at..]
                ),
                None => url.to_string(),
            }
        }
        _ => url.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_password_in_a_url_is_hidden() {
        assert_eq!(
            redact_url("postgres://u:secret@db:5432/jobs"),
            "postgres://u:***@db:5432/jobs"
        );
        assert_eq!(redact_url("postgres://u@db/jobs"), "postgres://u@db/jobs");
        assert_eq!(redact_url("sqlite://a@b.db"), "sqlite://a@b.db");
    }

    #[test]
    fn without_a_database_url_the_store_is_sqlite_in_the_data_dir() {
        let dir = std::env::temp_dir().join(format!("settings-{}", uuid::Uuid::new_v4()));
        let settings = Settings {
            data_dir: dir.clone(),
            ..Settings::default()
        };
        let url = settings.store_url().unwrap();
        assert_eq!(
            url,
            format!("sqlite://{}", dir.join("wellmesh.db").display())
        );
        assert!(dir.is_dir());
        std::fs::remove_dir_all(dir).unwrap();
    }
}
