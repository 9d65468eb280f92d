//! API keys and the principal a request acts as: which jobs it may list, read, download
//! and dismiss.
//!
//! Invariant: a key is kept only as its SHA-256 digest, and a presented key is compared
//! against every configured digest in constant time over the fixed 32 bytes, so neither
//! a key's length nor how much of it matched shows in the time taken. A job is visible
//! to its owner and to admin keys only; to anyone else it does not exist (404).

use std::fmt;

use axum::extract::{Request, State};
use axum::http::{HeaderValue, StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use sha2::{Digest, Sha256};
use subtle::ConstantTimeEq;

use super::AppState;
use super::problem::Problem;
use crate::jobs::JobRecord;

/// One accepted bearer key.
#[derive(Clone, PartialEq, Eq)]
pub struct ApiKey {
    digest: [u8; 32],
    /// The principal recorded as the owner of the jobs this key submits: `key-` and the
    /// first 8 bytes of the digest in hex (the key itself is never stored).
    owner: String,
    /// Sees and dismisses every job.
    admin: bool,
}

impl fmt::Debug for ApiKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ApiKey")
            .field("owner", &self.owner)
            .field("admin", &self.admin)
            .finish()
    }
}

impl ApiKey {
    /// A key that sees its own jobs only.
    pub fn new(secret: &str) -> Self {
        Self::with_role(secret, false)
    }

    /// A key that sees and dismisses every job.
    pub fn admin(secret: &str) -> Self {
        Self::with_role(secret, true)
    }

    fn with_role(secret: &str, admin: bool) -> Self {
        let digest: [u8; 32] = Sha256::digest(secret.as_bytes()).into();
        let owner = format!(
            "key-{}",
            digest[..8]
                .iter()
                .map(|b| format!("{b:02x}"))
                .collect::<String>()
        );
        ApiKey {
            digest,
            owner,
            admin,
        }
    }

    pub fn owner(&self) -> &str {
        &self.owner
    }

    pub fn is_admin(&self) -> bool {
        self.admin
    }
}

/// Reads a key file: one key per line, optionally followed by `admin`; blank lines and
/// lines starting with `#` are skipped.
pub fn parse_key_file(text: &str) -> Result<Vec<ApiKey>, String> {
    let mut keys = Vec::new();
    for (number, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut words = line.split_whitespace();
        let secret = words.next().unwrap_or_default();
        let key = match words.next() {
            None => ApiKey::new(secret),
            Some("admin") => ApiKey::admin(secret),
            Some(other) => {
                return Err(format!(
                    "line {}: expected a key, optionally followed by `admin`, not {other:?}",
                    number + 1
                ));
            }
        };
        if words.next().is_some() {
            return Err(format!("line {}: more than a key and a role", number + 1));
        }
        keys.push(key);
    }
    Ok(keys)
}

/// Who a request acts as.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Principal {
    /// No keys are configured: everyone sees everything, jobs have no owner.
    Anonymous,
    /// The request presented this key.
    Key { owner: String, admin: bool },
}

impl Principal {
    /// The owner recorded on the jobs this principal submits.
    pub fn owner(&self) -> Option<&str> {
        match self {
            Principal::Anonymous => None,
            Principal::Key { owner, .. } => Some(owner),
        }
    }

    /// The owner a job listing is limited to: `None` for anonymous and admin principals.
    pub fn listing_owner(&self) -> Option<String> {
        match self {
            Principal::Key {
                owner,
                admin: false,
            } => Some(owner.clone()),
            _ => None,
        }
    }

    /// `true` when this principal may read, download or dismiss `job`.
    pub fn may_see(&self, job: &JobRecord) -> bool {
        match self {
            Principal::Anonymous | Principal::Key { admin: true, .. } => true,
            Principal::Key { owner, .. } => job.owner.as_deref() == Some(owner.as_str()),
        }
    }
}

/// The configured key `presented` is, comparing its digest with every key's.
pub fn find_key<'k>(keys: &'k [ApiKey], presented: &str) -> Option<&'k ApiKey> {
    let digest: [u8; 32] = Sha256::digest(presented.as_bytes()).into();
    let mut found = None;
    for key in keys {
        let equal = bool::from(key.digest.ct_eq(&digest));
        if equal && found.is_none() {
            found = Some(key);
        }
    }
    found
}

/// Rejects requests without a valid `Authorization: Bearer KEY` when keys are set, and
/// hands the handlers the [`Principal`] the request acts as.
pub async fn require_api_key(
    State(state): State<AppState>,
    mut request: Request,
    next: Next,
) -> Response {
    let keys = &state.config.api_keys;
    if keys.is_empty() || request.method() == axum::http::Method::OPTIONS {
        request.extensions_mut().insert(Principal::Anonymous);
        return next.run(request).await;
    }
    let presented = request
        .headers()
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| {
            v.strip_prefix("Bearer ")
                .or_else(|| v.strip_prefix("bearer "))
        })
        .map(str::trim);
    match presented.and_then(|key| find_key(keys, key)) {
        Some(key) => {
            request.extensions_mut().insert(Principal::Key {
                owner: key.owner.clone(),
                admin: key.admin,
            });
            next.run(request).await
        }
        None => {
            let mut response = Problem::new(
                StatusCode::UNAUTHORIZED,
                "about:blank",
                "send a valid API key as `Authorization: Bearer KEY`",
            )
            .into_response();
            response
                .headers_mut()
                .insert(header::WWW_AUTHENTICATE, HeaderValue::from_static("Bearer"));
            response
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_match_exactly() {
        let keys = vec![ApiKey::new("alpha"), ApiKey::admin("beta-key")];
        assert_eq!(find_key(&keys, "beta-key"), Some(&keys[1]));
        assert_eq!(find_key(&keys, "alpha"), Some(&keys[0]));
        assert_eq!(find_key(&keys, "beta"), None);
        assert_eq!(find_key(&keys, "alphaa"), None);
        assert_eq!(find_key(&keys, ""), None);
        assert_eq!(find_key(&[], "alpha"), None);
    }

    #[test]
    fn a_key_is_kept_only_as_its_digest() {
        let key = ApiKey::new("s3cret-value");
        assert!(!format!("{key:?}").contains("s3cret"));
        assert!(key.owner().starts_with("key-"));
        assert_eq!(key.owner().len(), 4 + 16);
        assert_ne!(key.owner(), ApiKey::new("other").owner());
    }

    #[test]
    fn a_key_file_gives_keys_and_roles() {
        let keys = parse_key_file("# team keys\n\nk1\n  k2 admin \n").unwrap();
        assert_eq!(keys, vec![ApiKey::new("k1"), ApiKey::admin("k2")]);
        assert!(parse_key_file("k1 root\n").unwrap_err().contains("line 1"));
    }

    #[test]
    fn owners_see_their_jobs_and_admins_see_all() {
        let mine = Principal::Key {
            owner: "key-a".into(),
            admin: false,
        };
        let admin = Principal::Key {
            owner: "key-b".into(),
            admin: true,
        };
        let job = |owner: Option<&str>| JobRecord {
            id: uuid::Uuid::from_u128(1),
            state: crate::jobs::JobState::Accepted,
            message: String::new(),
            progress: 0,
            attempt: 0,
            max_attempts: 3,
            failure: None,
            failure_field: None,
            owner: owner.map(str::to_string),
            created_ms: 0,
            started_ms: None,
            finished_ms: None,
            updated_ms: 0,
        };
        assert!(mine.may_see(&job(Some("key-a"))));
        assert!(!mine.may_see(&job(Some("key-c"))));
        assert!(!mine.may_see(&job(None)));
        assert!(admin.may_see(&job(Some("key-c"))));
        assert!(Principal::Anonymous.may_see(&job(None)));
        assert_eq!(mine.listing_owner().as_deref(), Some("key-a"));
        assert_eq!(admin.listing_owner(), None);
    }
}
