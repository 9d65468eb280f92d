//! Where tests find the shared corpus of real data, and what they do without it. The corpus
//! (`../shared/data` beside the repository: public data sets too large or too restricted to
//! ship, each folder with its source and licence in `SOURCES.md`) is not part of a clone. A
//! test that needs it asks [`shared_data`] first: absent, the test prints a note naming
//! itself and the data, and returns. CI has the corpus and sets
//! `WELLMESH_REQUIRE_SHARED_DATA=1`, which makes an absent corpus a failure, so no test
//! skips unseen there. Used by the integration tests (`mod common;`) and by unit tests
//! (`#[path]` to this file).

use std::io::Write;
use std::path::PathBuf;

/// The variable that turns a skip for want of the corpus into a failure (CI sets it to `1`).
pub const REQUIRE_SHARED_DATA: &str = "WELLMESH_REQUIRE_SHARED_DATA";

/// `path` (a file or a folder) in the shared corpus, when it is there. Otherwise `None`,
/// after a note on standard error naming the running test and the data it needs; or a
/// panic with that note when `WELLMESH_REQUIRE_SHARED_DATA=1`.
pub fn shared_data(path: &str) -> Option<PathBuf> {
    let full = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data")
        .join(path);
    if full.exists() {
        return Some(full);
    }
    // The test harness names each test's thread after the test.
    let thread = std::thread::current();
    let test = thread.name().unwrap_or("a test");
    let note =
        format!("{test}: skipped: needs ../shared/data/{path} (the shared corpus); CI provides it");
    if std::env::var(REQUIRE_SHARED_DATA).is_ok_and(|v| v == "1") {
        panic!("{note}, and {REQUIRE_SHARED_DATA}=1 forbids the skip");
    }
    // Written to the process's standard error, past the harness's capture of `eprintln!`,
    // so the note shows in a plain `cargo test`.
    let _ = writeln!(std::io::stderr(), "{note}");
    None
}
