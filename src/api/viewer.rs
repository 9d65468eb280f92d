//! The static 3D viewer: `/viewer` and the files under the viewer directory.
//!
//! Invariant: only files inside the viewer directory are served; a path with `..`,
//! a root or a prefix component is refused before touching the file system.

use std::path::{Component, Path as FsPath, PathBuf};

use axum::extract::{Path, Request, State};
use axum::http::{StatusCode, header};
use axum::response::{Html, IntoResponse, Response};
use tower::ServiceExt;
use tower_http::services::ServeFile;

use super::AppState;
use super::problem::Problem;

fn missing_page(dir: &FsPath) -> Response {
    let body = format!(
        "<!doctype html><meta charset=\"utf-8\"><title>wellmesh viewer</title>\
         <h1>The viewer is not installed</h1>\
         <p>No viewer with its JavaScript dependencies was found in <code>{}</code>. \
         From the repository, run <code>npm ci --prefix viewer</code> and reload.</p>",
        dir.display()
    );
    (StatusCode::SERVICE_UNAVAILABLE, Html(body)).into_response()
}

fn viewer_ready(dir: &FsPath) -> bool {
    dir.join("index.html").is_file() && dir.join("node_modules").is_dir()
}

/// `GET /viewer`: the viewer page (`?job=ID` opens that job).
pub async fn index(State(state): State<AppState>, request: Request) -> Response {
    let dir = &state.config.viewer_dir;
    if !viewer_ready(dir) {
        return missing_page(dir);
    }
    serve(dir.join("index.html"), request).await
}

/// `GET /viewer/{*path}`: a file under the viewer directory.
pub async fn file(
    State(state): State<AppState>,
    Path(path): Path<String>,
    request: Request,
) -> Response {
    let dir = &state.config.viewer_dir;
    if !viewer_ready(dir) {
        return missing_page(dir);
    }
    let relative = PathBuf::from(&path);
    if relative
        .components()
        .any(|c| !matches!(c, Component::Normal(_)))
    {
        return Problem::not_found(format!("no viewer file {path:?}")).into_response();
    }
    let full = dir.join(relative);
    if !full.is_file() {
        return Problem::not_found(format!("no viewer file {path:?}")).into_response();
    }
    serve(full, request).await
}

async fn serve(path: PathBuf, request: Request) -> Response {
    let is_module = path.extension().is_some_and(|e| e == "js" || e == "mjs");
    match ServeFile::new(&path).oneshot(request).await {
        Ok(response) => {
            let mut response = response.into_response();
            if is_module {
                response.headers_mut().insert(
                    header::CONTENT_TYPE,
                    header::HeaderValue::from_static("text/javascript; charset=utf-8"),
                );
            }
            response
        }
        Err(e) => {
            tracing::error!(error = %e, path = %path.display(), "could not serve a viewer file");
            Problem::internal().into_response()
        }
    }
}
