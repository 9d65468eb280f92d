//! The HTTP API end to end: the real application started on port 0 with a fresh SQLite
//! store, spoken to over HTTP, its workers running a test pipeline whose outcome and
//! duration the tests control.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use axum::body::Body;
use axum::http::{HeaderMap, Request, StatusCode, header};
use http_body_util::BodyExt;
use hyper_util::client::legacy::Client;
use hyper_util::client::legacy::connect::HttpConnector;
use hyper_util::rt::TokioExecutor;
use serde_json::{Value, json};
use tokio::sync::oneshot;
use wellmesh::api::{self, ApiConfig, ApiKey};
use wellmesh::jobs::{JobFailure, OUTPUT_PART_BYTES, Pipeline, StoredOutput};
use wellmesh::process::ProcessInputs;
use wellmesh::progress::{Progress, Stage};
use wellmesh::startup::{Application, Settings};

/// Answers a summary naming the thresholds and point count, and a GLB-like blob;
/// with `hold` set it waits (checking cancellation) until the flag is cleared.
#[derive(Default)]
struct TestPipeline {
    hold: AtomicBool,
    saw_cancel: AtomicBool,
}

impl Pipeline for TestPipeline {
    fn run(&self, inputs: &[u8], progress: &dyn Progress) -> Result<Vec<StoredOutput>, JobFailure> {
        let inputs: ProcessInputs = serde_json::from_slice(inputs).expect("stored inputs");
        progress.report(Stage::Tetrahedralize, 0.5);
        while self.hold.load(Ordering::SeqCst) {
            if progress.is_cancelled() {
                self.saw_cancel.store(true, Ordering::SeqCst);
                return Err(JobFailure::Cancelled);
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        if inputs.variable.as_deref() == Some("bad") {
            return Err(JobFailure::input_field(
                "intervals_csv",
                "intervals_csv row 2: no such column \"bad\"",
            ));
        }
        if inputs.variable.as_deref() == Some("internal") {
            return Err(JobFailure::Internal(
                "exporting the results: buffer 7 of /srv/secret out of range".into(),
            ));
        }
        if inputs.variable.as_deref() == Some("panic") {
            panic!("invariant broken at /srv/secret/tet.rs:12");
        }
        let glb = if inputs.variable.as_deref() == Some("big") {
            big_glb()
        } else {
            b"glTF\x02\0\0\0".to_vec()
        };
        let summary =
            json!({"thresholds": inputs.thresholds.values(), "points": inputs.point_count()});
        Ok(vec![
            StoredOutput {
                id: "summary".into(),
                file_name: "summary.json".into(),
                media_type: "application/json".into(),
                bytes: serde_json::to_vec(&summary).unwrap(),
            },
            StoredOutput {
                id: "glb".into(),
                file_name: "bodies.glb".into(),
                media_type: "model/gltf-binary".into(),
                bytes: glb,
            },
        ])
    }
}

/// The GLB of a job whose `variable` is "big": several of the parts outputs are stored in,
/// the last one short, every byte different from its neighbours.
fn big_glb() -> Vec<u8> {
    (0..3 * OUTPUT_PART_BYTES + 12_345)
        .map(|i| (i * 11 % 241) as u8)
        .collect()
}

struct TestApp {
    /// `http://127.0.0.1:PORT`, where the application listens.
    address: String,
    client: Client<HttpConnector, Body>,
    pipeline: Arc<TestPipeline>,
    /// Dropped with the test: the application then shuts down.
    _stop: oneshot::Sender<()>,
}

struct Answer {
    status: StatusCode,
    headers: HeaderMap,
    body: Vec<u8>,
}

impl Answer {
    fn json(&self) -> Value {
        serde_json::from_slice(&self.body)
            .unwrap_or_else(|e| panic!("not JSON ({e}): {}", String::from_utf8_lossy(&self.body)))
    }
}

/// Starts the real application (`Application::build`) on port 0 with a fresh SQLite
/// store in its own directory, `workers` embedded workers running the test pipeline,
/// and the API limits `configure` sets over the defaults.
async fn spawn_app(configure: impl FnOnce(&mut ApiConfig), workers: usize) -> TestApp {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("api-{}", uuid::Uuid::new_v4().simple()));
    let mut settings = Settings {
        bind: "127.0.0.1:0".parse().unwrap(),
        data_dir: dir.clone(),
        ..Settings::default()
    };
    settings.api.viewer_dir = dir.join("viewer");
    settings.api.sync_wait = Duration::from_secs(20);
    settings.worker.concurrency = workers;
    settings.worker.heartbeat = Duration::from_millis(50);
    settings.worker.poll = Duration::from_millis(50);
    configure(&mut settings.api);
    let pipeline = Arc::new(TestPipeline::default());
    let app = Application::build_with_pipeline(settings, pipeline.clone())
        .await
        .unwrap();
    let address = format!("http://127.0.0.1:{}", app.port());
    let (stop, stopped) = oneshot::channel::<()>();
    tokio::spawn(app.run_until(async move {
        let _ = stopped.await;
    }));
    TestApp {
        address,
        client: Client::builder(TokioExecutor::new()).build_http(),
        pipeline,
        _stop: stop,
    }
}

impl TestApp {
    /// Sends `request` (its URI a path) to the application over HTTP.
    async fn send(&self, request: Request<Body>) -> Answer {
        let (mut parts, body) = request.into_parts();
        parts.uri = format!("{}{}", self.address, parts.uri).parse().unwrap();
        let response = self
            .client
            .request(Request::from_parts(parts, body))
            .await
            .unwrap();
        let status = response.status();
        let headers = response.headers().clone();
        let body = response
            .into_body()
            .collect()
            .await
            .unwrap()
            .to_bytes()
            .to_vec();
        Answer {
            status,
            headers,
            body,
        }
    }

    async fn get(&self, uri: &str) -> Answer {
        self.send(Request::get(uri).body(Body::empty()).unwrap())
            .await
    }

    async fn execute(&self, body: Value, prefer_async: bool) -> Answer {
        let mut request = Request::post("/processes/dmt-contour/execution")
            .header(header::HOST, "wellmesh.test")
            .header(header::CONTENT_TYPE, "application/json");
        if prefer_async {
            request = request.header("Prefer", "respond-async");
        }
        self.send(request.body(Body::from(body.to_string())).unwrap())
            .await
    }

    async fn wait_for_status(&self, job_id: &str, wanted: &str) -> Value {
        for _ in 0..400 {
            let status = self.get(&format!("/jobs/{job_id}")).await.json();
            if status["status"] == wanted {
                return status;
            }
            tokio::time::sleep(Duration::from_millis(25)).await;
        }
        panic!("job {job_id} never became {wanted}");
    }
}

fn samples_csv(rows: usize) -> String {
    let mut csv = String::from("well,x,y,z,value\n");
    for i in 0..rows {
        csv.push_str(&format!("w{},{},{},{},{}\n", i % 5, i % 5, i / 5, i, i % 2));
    }
    csv
}

fn small_request() -> Value {
    json!({"inputs": {"samples_csv": samples_csv(10), "thresholds": [0.5], "method": "ibc"}})
}

#[tokio::test]
async fn the_landing_page_links_the_api_conformance_and_processes() {
    let app = spawn_app(|_| {}, 0).await;

    let landing = app
        .send(
            Request::get("/")
                .header(header::HOST, "127.0.0.1:8080")
                .body(Body::empty())
                .unwrap(),
        )
        .await;

    assert_eq!(landing.status, StatusCode::OK);
    let links = landing.json()["links"].as_array().unwrap().clone();
    let rel = |r: &str| links.iter().find(|l| l["rel"] == r).cloned();
    let desc = rel("service-desc").unwrap();
    assert_eq!(desc["type"], "application/vnd.oai.openapi+json;version=3.0");
    assert!(rel("http://www.opengis.net/def/rel/ogc/1.0/conformance").is_some());
    assert!(rel("http://www.opengis.net/def/rel/ogc/1.0/processes").is_some());
    let href = desc["href"].as_str().unwrap();
    assert_eq!(href, "http://127.0.0.1:8080/api");
    let document = app
        .get(href.trim_start_matches("http://127.0.0.1:8080"))
        .await;
    assert_eq!(document.status, StatusCode::OK);
    assert!(document.json()["paths"]["/processes/{process_id}/execution"].is_object());
    let conformance = app.get("/conformance").await.json();
    assert!(
        conformance["conformsTo"]
            .as_array()
            .unwrap()
            .contains(&json!(
                "http://www.opengis.net/spec/ogcapi-processes-1/1.0/conf/core"
            ))
    );
}

#[tokio::test]
async fn the_process_description_lists_every_input_and_output() {
    let app = spawn_app(|_| {}, 0).await;

    let list = app.get("/processes").await.json();
    let description = app.get("/processes/dmt-contour").await.json();
    let missing = app.get("/processes/nope").await;

    assert_eq!(list["processes"][0]["id"], "dmt-contour");
    for input in [
        "wells",
        "samples_csv",
        "collars_csv",
        "surveys_csv",
        "intervals_csv",
        "variable",
        "thresholds",
        "method",
        "unknown",
        "anisotropy",
        "min_volume",
    ] {
        assert!(
            description["inputs"][input].is_object(),
            "input {input} missing"
        );
    }
    for output in ["summary", "glb", "tileset", "geojson", "obj", "vtu"] {
        assert!(
            description["outputs"][output].is_object(),
            "output {output} missing"
        );
    }
    assert_eq!(missing.status, StatusCode::NOT_FOUND);
    assert_eq!(
        missing.json()["type"],
        "http://www.opengis.net/def/exceptions/ogcapi-processes-1/1.0/no-such-process"
    );
}

#[tokio::test]
async fn a_small_job_runs_synchronously_and_returns_its_results() {
    let app = spawn_app(|_| {}, 1).await;

    let answer = app.execute(small_request(), false).await;

    assert_eq!(
        answer.status,
        StatusCode::OK,
        "{}",
        String::from_utf8_lossy(&answer.body)
    );
    let results = answer.json();
    assert_eq!(
        results["summary"],
        json!({"thresholds": [0.5], "points": 10})
    );
    let glb = &results["glb"];
    assert_eq!(glb["type"], "model/gltf-binary");
    let href = glb["href"].as_str().unwrap();
    assert!(
        href.starts_with("/jobs/") && href.ends_with("/results/glb"),
        "{href}"
    );
    let bytes = app.get(href).await;
    assert_eq!(bytes.status, StatusCode::OK);
    assert_eq!(bytes.headers[header::CONTENT_TYPE], "model/gltf-binary");
    assert_eq!(bytes.body, b"glTF\x02\0\0\0");
    assert_eq!(bytes.headers[header::ACCEPT_RANGES], "bytes");
    let part = app
        .send(
            Request::get(href)
                .header(header::RANGE, "bytes=4-")
                .body(Body::empty())
                .unwrap(),
        )
        .await;
    assert_eq!(part.status, StatusCode::PARTIAL_CONTENT);
    assert_eq!(part.headers[header::CONTENT_RANGE], "bytes 4-7/8");
    assert_eq!(part.body, b"\x02\0\0\0");
}

#[tokio::test]
async fn a_large_output_is_streamed_whole_and_by_ranges_across_its_parts() {
    let app = spawn_app(|_| {}, 1).await;
    let mut request = small_request();
    request["inputs"]["variable"] = json!("big");
    let answer = app.execute(request, false).await;
    assert_eq!(answer.status, StatusCode::OK);
    let href = answer.json()["glb"]["href"].as_str().unwrap().to_string();
    let glb = big_glb();
    let total = glb.len();

    let whole = app.get(&href).await;
    assert_eq!(whole.status, StatusCode::OK);
    assert_eq!(
        whole.headers[header::CONTENT_LENGTH],
        total.to_string().as_str()
    );
    assert_eq!(whole.headers[header::CONTENT_TYPE], "model/gltf-binary");
    assert!(
        whole.body == glb,
        "the streamed GLB differs from the stored one"
    );

    let part = OUTPUT_PART_BYTES;
    for (range, first, last) in [
        // across the first part boundary, and across two boundaries
        (
            format!("bytes={}-{}", part - 10, part + 9),
            part - 10,
            part + 9,
        ),
        (format!("bytes=100-{}", 2 * part + 5), 100, 2 * part + 5),
        // inside the short last part, open-ended, and a suffix
        (format!("bytes={}-", 3 * part + 1), 3 * part + 1, total - 1),
        ("bytes=-5000".to_string(), total - 5000, total - 1),
        // past the end: cut at the last byte
        (
            format!("bytes={}-{}", total - 3, total + 100),
            total - 3,
            total - 1,
        ),
    ] {
        let answer = app
            .send(
                Request::get(&href)
                    .header(header::RANGE, &range)
                    .body(Body::empty())
                    .unwrap(),
            )
            .await;
        assert_eq!(answer.status, StatusCode::PARTIAL_CONTENT, "{range}");
        assert_eq!(
            answer.headers[header::CONTENT_RANGE],
            format!("bytes {first}-{last}/{total}").as_str(),
            "{range}"
        );
        assert_eq!(
            answer.headers[header::CONTENT_LENGTH],
            (last + 1 - first).to_string().as_str()
        );
        assert!(answer.body == glb[first..=last], "{range}: wrong bytes");
    }
    let beyond = app
        .send(
            Request::get(&href)
                .header(header::RANGE, format!("bytes={total}-"))
                .body(Body::empty())
                .unwrap(),
        )
        .await;
    assert_eq!(beyond.status, StatusCode::RANGE_NOT_SATISFIABLE);
    assert_eq!(
        beyond.headers[header::CONTENT_RANGE],
        format!("bytes */{total}").as_str()
    );
}

#[tokio::test]
async fn respond_async_answers_201_with_location_and_the_job_completes() {
    let app = spawn_app(|_| {}, 1).await;

    let answer = app.execute(small_request(), true).await;

    assert_eq!(answer.status, StatusCode::CREATED);
    let location = answer.headers[header::LOCATION]
        .to_str()
        .unwrap()
        .to_string();
    let status = answer.json();
    assert_eq!(
        location,
        format!(
            "http://wellmesh.test/jobs/{}",
            status["jobID"].as_str().unwrap()
        )
    );
    let location = location
        .trim_start_matches("http://wellmesh.test")
        .to_string();
    assert_eq!(status["processID"], "dmt-contour");
    assert_eq!(status["type"], "process");
    assert!(["accepted", "running", "successful"].contains(&status["status"].as_str().unwrap()));
    let job_id = status["jobID"].as_str().unwrap().to_string();
    let done = app.wait_for_status(&job_id, "successful").await;
    assert_eq!(done["progress"], 100);
    assert!(done["finished"].is_string());
    let results = app.get(&format!("{location}/results")).await;
    assert_eq!(results.status, StatusCode::OK);
    assert_eq!(results.json()["summary"]["points"], 10);
    let listed = app.get("/jobs?limit=5").await.json();
    assert_eq!(listed["jobs"][0]["jobID"], job_id.as_str());
}

#[tokio::test]
async fn results_are_not_ready_while_a_job_runs_and_dismissal_cancels_it() {
    let app = spawn_app(|_| {}, 1).await;
    app.pipeline.hold.store(true, Ordering::SeqCst);
    let job_id = app.execute(small_request(), true).await.json()["jobID"]
        .as_str()
        .unwrap()
        .to_string();
    app.wait_for_status(&job_id, "running").await;
    let mut running = json!({});
    for _ in 0..200 {
        running = app.get(&format!("/jobs/{job_id}")).await.json();
        if running["message"]
            .as_str()
            .unwrap()
            .contains("tetrahedralize")
        {
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }

    let results = app.get(&format!("/jobs/{job_id}/results")).await;
    let output = app.get(&format!("/jobs/{job_id}/results/glb")).await;
    let dismissed = app
        .send(
            Request::delete(format!("/jobs/{job_id}"))
                .body(Body::empty())
                .unwrap(),
        )
        .await;

    assert!(
        running["message"]
            .as_str()
            .unwrap()
            .contains("tetrahedralize"),
        "{running}"
    );
    assert_eq!(running["status"], "running");
    assert_eq!(running["progress"], 42);
    assert_eq!(results.status, StatusCode::NOT_FOUND);
    assert_eq!(
        results.json()["type"],
        "http://www.opengis.net/def/exceptions/ogcapi-processes-1/1.0/result-not-ready"
    );
    assert_eq!(output.status, StatusCode::NOT_FOUND);
    assert_eq!(dismissed.status, StatusCode::OK);
    assert_eq!(dismissed.json()["status"], "dismissed");
    for _ in 0..200 {
        if app.pipeline.saw_cancel.load(Ordering::SeqCst) {
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    assert!(
        app.pipeline.saw_cancel.load(Ordering::SeqCst),
        "the computation was not cancelled"
    );
    assert_eq!(
        app.get(&format!("/jobs/{job_id}")).await.status,
        StatusCode::NOT_FOUND
    );
}

#[tokio::test]
async fn a_failed_input_answers_422_with_the_reason() {
    let app = spawn_app(|_| {}, 1).await;
    let mut request = small_request();
    request["inputs"]["variable"] = json!("bad");

    let answer = app.execute(request, false).await;

    assert_eq!(answer.status, StatusCode::UNPROCESSABLE_ENTITY);
    let problem = answer.json();
    assert!(
        problem["detail"]
            .as_str()
            .unwrap()
            .contains("no such column"),
        "{problem}"
    );
    assert_eq!(problem["field"], "intervals_csv");
}

#[tokio::test]
async fn an_internal_failure_answers_500_naming_the_job_and_no_internals() {
    let app = spawn_app(|_| {}, 1).await;
    for variable in ["internal", "panic"] {
        let mut request = small_request();
        request["inputs"]["variable"] = json!(variable);

        let answer = app.execute(request, false).await;

        assert_eq!(answer.status, StatusCode::INTERNAL_SERVER_ERROR);
        let newest = app.get("/jobs?limit=1").await.json();
        let job_id = newest["jobs"][0]["jobID"].as_str().unwrap().to_string();
        let problem = answer.json();
        let detail = problem["detail"].as_str().unwrap();
        assert!(detail.contains(&job_id), "{problem}");
        assert!(detail.contains("internal error"), "{problem}");
        let status = app.get(&format!("/jobs/{job_id}")).await.json();
        let listed = String::from_utf8(app.get("/jobs").await.body).unwrap();
        for text in [detail, status["message"].as_str().unwrap(), listed.as_str()] {
            assert!(!text.contains("/srv/secret"), "internals leaked: {text}");
        }
        assert_eq!(status["status"], "failed");
    }
}

#[tokio::test]
async fn invalid_inputs_answer_422_naming_the_field() {
    let app = spawn_app(|_| {}, 0).await;
    let cases = [
        (
            json!({"inputs": {"samples_csv": "a", "thresholds": []}}),
            "thresholds",
        ),
        (
            json!({"inputs": {"samples_csv": "a", "thresholds": [1], "method": "best"}}),
            "method",
        ),
        (
            json!({"inputs": {"samples_csv": "a", "thresholds": [1], "anisotropy": [1, -1, 1]}}),
            "anisotropy",
        ),
        (
            json!({"inputs": {"samples_csv": "a", "thresholds": [1], "tresholds": 2}}),
            "tresholds",
        ),
        (
            json!({"inputs": {"samples_csv": "a", "thresholds": "high"}}),
            "thresholds",
        ),
        (json!({"inputs": {"thresholds": [1]}}), "inputs"),
        (json!({"outputs": {}}), "inputs"),
    ];
    for (body, field) in cases {
        let answer = app.execute(body.clone(), false).await;
        assert_eq!(answer.status, StatusCode::UNPROCESSABLE_ENTITY, "{body}");
        assert_eq!(
            answer.headers[header::CONTENT_TYPE],
            "application/problem+json"
        );
        assert_eq!(answer.json()["field"], field, "{body}");
    }
    // The reasons speak of JSON values, not of the service's Rust types.
    let reasons = [
        (
            json!({"inputs": {"samples_csv": "a", "thresholds": "NaN"}}),
            "thresholds: expected a number or an array of numbers, got \"NaN\"",
        ),
        (
            json!({"inputs": {"samples_csv": "a", "thresholds": {"low": 1}}}),
            "thresholds: expected a number or an array of numbers, got {\"low\":1}",
        ),
        (
            json!({"inputs": {"samples_csv": "a", "thresholds": [1], "relax": 2.5}}),
            "relax: invalid type: floating point `2.5`, expected a whole number",
        ),
        (
            json!({"inputs": {"samples_csv": "a", "thresholds": [1], "min_volume": "big"}}),
            "min_volume: invalid type: string \"big\", expected a number",
        ),
        (
            json!({"inputs": null}),
            "inputs: invalid type: null, expected an object of inputs",
        ),
    ];
    for (body, detail) in reasons {
        let answer = app.execute(body.clone(), false).await;
        assert_eq!(answer.status, StatusCode::UNPROCESSABLE_ENTITY, "{body}");
        assert_eq!(answer.json()["detail"], detail, "{body}");
    }
    let not_json = app
        .send(
            Request::post("/processes/dmt-contour/execution")
                .header(header::CONTENT_TYPE, "application/json")
                .body(Body::from("{\"inputs\": "))
                .unwrap(),
        )
        .await;
    assert_eq!(not_json.status, StatusCode::BAD_REQUEST);
    assert!(not_json.json()["detail"].as_str().unwrap().contains("JSON"));
}

#[tokio::test]
async fn too_many_points_answer_422_naming_the_field() {
    let app = spawn_app(|c| c.max_points = 100, 0).await;

    let answer = app
        .execute(
            json!({"inputs": {"samples_csv": samples_csv(101), "thresholds": 1}}),
            true,
        )
        .await;

    assert_eq!(answer.status, StatusCode::UNPROCESSABLE_ENTITY);
    let problem = answer.json();
    assert_eq!(problem["field"], "samples_csv");
    assert!(problem["detail"].as_str().unwrap().contains("101"));
}

#[tokio::test]
async fn an_oversized_body_answers_413_with_a_json_problem() {
    let app = spawn_app(|c| c.max_body_bytes = 1000, 0).await;

    let answer = app
        .execute(
            json!({"inputs": {"samples_csv": samples_csv(200), "thresholds": 1}}),
            true,
        )
        .await;

    assert_eq!(answer.status, StatusCode::PAYLOAD_TOO_LARGE);
    assert_eq!(answer.json()["field"], "body");
}

#[tokio::test]
async fn a_full_queue_answers_429_with_retry_after() {
    let app = spawn_app(|c| c.max_queued = Some(2), 0).await;
    for _ in 0..2 {
        assert_eq!(
            app.execute(small_request(), true).await.status,
            StatusCode::CREATED
        );
    }

    let refused = app.execute(small_request(), true).await;

    assert_eq!(refused.status, StatusCode::TOO_MANY_REQUESTS);
    assert_eq!(refused.headers[header::RETRY_AFTER], "10");
    assert_eq!(refused.json()["status"], 429);
}

#[tokio::test]
async fn api_keys_guard_jobs_and_executions_when_configured() {
    let app = spawn_app(|c| c.api_keys = vec![ApiKey::new("s3cret")], 0).await;

    let anonymous = app.get("/jobs").await;
    let wrong = app
        .send(
            Request::get("/jobs")
                .header(header::AUTHORIZATION, "Bearer s3cre")
                .body(Body::empty())
                .unwrap(),
        )
        .await;
    let right = app
        .send(
            Request::get("/jobs")
                .header(header::AUTHORIZATION, "Bearer s3cret")
                .body(Body::empty())
                .unwrap(),
        )
        .await;
    let landing = app.get("/processes").await;

    assert_eq!(anonymous.status, StatusCode::UNAUTHORIZED);
    assert_eq!(anonymous.headers[header::WWW_AUTHENTICATE], "Bearer");
    assert_eq!(wrong.status, StatusCode::UNAUTHORIZED);
    assert_eq!(right.status, StatusCode::OK);
    assert_eq!(landing.status, StatusCode::OK);
}

#[tokio::test]
async fn a_multipart_csv_upload_runs_a_job() {
    let app = spawn_app(|_| {}, 1).await;
    let boundary = "XyZ123";
    let csv = samples_csv(7);
    let body = format!(
        "--{boundary}\r\nContent-Disposition: form-data; name=\"samples_csv\"; filename=\"samples.csv\"\r\nContent-Type: text/csv\r\n\r\n{csv}\r\n\
         --{boundary}\r\nContent-Disposition: form-data; name=\"thresholds\"\r\n\r\n0.5, 0.8\r\n\
         --{boundary}\r\nContent-Disposition: form-data; name=\"method\"\r\n\r\ncurvature\r\n--{boundary}--\r\n"
    );

    let answer = app
        .send(
            Request::post("/processes/dmt-contour/execution")
                .header(
                    header::CONTENT_TYPE,
                    format!("multipart/form-data; boundary={boundary}"),
                )
                .body(Body::from(body))
                .unwrap(),
        )
        .await;

    assert_eq!(
        answer.status,
        StatusCode::OK,
        "{}",
        String::from_utf8_lossy(&answer.body)
    );
    assert_eq!(
        answer.json()["summary"],
        json!({"thresholds": [0.5, 0.8], "points": 7})
    );
}

#[tokio::test]
async fn unknown_jobs_and_routes_answer_json_404s() {
    let app = spawn_app(|_| {}, 0).await;

    let unknown = app.get(&format!("/jobs/{}", uuid::Uuid::new_v4())).await;
    let malformed = app.get("/jobs/not-a-uuid/results").await;
    let route = app.get("/nowhere").await;
    let bad_limit = app.get("/jobs?limit=0").await;
    let method = app
        .send(Request::put("/jobs").body(Body::empty()).unwrap())
        .await;

    for answer in [&unknown, &malformed] {
        assert_eq!(answer.status, StatusCode::NOT_FOUND);
        assert_eq!(
            answer.json()["type"],
            "http://www.opengis.net/def/exceptions/ogcapi-processes-1/1.0/no-such-job"
        );
    }
    assert_eq!(route.status, StatusCode::NOT_FOUND);
    assert_eq!(route.json()["status"], 404);
    assert_eq!(bad_limit.status, StatusCode::BAD_REQUEST);
    assert_eq!(method.status, StatusCode::METHOD_NOT_ALLOWED);
    assert_eq!(method.json()["status"], 405);
}

#[tokio::test]
async fn health_readiness_and_metrics_answer() {
    let app = spawn_app(|_| {}, 0).await;
    app.execute(small_request(), true).await;

    let health = app.get("/healthz").await;
    let ready = app.get("/readyz").await;
    let metrics = app.get("/metrics").await;

    assert_eq!(health.status, StatusCode::OK);
    assert_eq!(ready.status, StatusCode::OK);
    let text = String::from_utf8(metrics.body).unwrap();
    assert!(
        text.contains("wellmesh_jobs{state=\"accepted\"} 1"),
        "{text}"
    );
    assert!(text.contains("wellmesh_queue_depth 1"), "{text}");
    assert!(
        text.contains("wellmesh_job_duration_seconds_count"),
        "{text}"
    );
}

#[tokio::test]
async fn json_is_gzipped_and_cors_preflights_are_allowed() {
    let app = spawn_app(|_| {}, 0).await;

    let gzipped = app
        .send(
            Request::get("/processes/dmt-contour")
                .header(header::ACCEPT_ENCODING, "gzip")
                .body(Body::empty())
                .unwrap(),
        )
        .await;
    let preflight = app
        .send(
            Request::options("/processes/dmt-contour/execution")
                .header(header::ORIGIN, "http://viewer.example")
                .header(header::ACCESS_CONTROL_REQUEST_METHOD, "POST")
                .header(
                    header::ACCESS_CONTROL_REQUEST_HEADERS,
                    "content-type,prefer",
                )
                .body(Body::empty())
                .unwrap(),
        )
        .await;

    assert_eq!(gzipped.headers[header::CONTENT_ENCODING], "gzip");
    assert_eq!(&gzipped.body[..2], &[0x1f, 0x8b]);
    assert!(preflight.status.is_success());
    assert_eq!(preflight.headers[header::ACCESS_CONTROL_ALLOW_ORIGIN], "*");
}

#[tokio::test]
async fn the_viewer_is_served_from_its_directory_and_never_outside_it() {
    let app = spawn_app(|_| {}, 0).await;
    let missing = app.get("/viewer").await;
    assert_eq!(missing.status, StatusCode::SERVICE_UNAVAILABLE);
    assert!(String::from_utf8_lossy(&missing.body).contains("npm ci --prefix viewer"));

    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("viewer-{}", uuid::Uuid::new_v4().simple()));
    let viewer = dir.join("viewer");
    std::fs::create_dir_all(viewer.join("node_modules/three/build")).unwrap();
    std::fs::write(viewer.join("index.html"), "<!doctype html><title>v</title>").unwrap();
    std::fs::write(
        viewer.join("node_modules/three/build/three.module.js"),
        "export {};",
    )
    .unwrap();
    std::fs::write(dir.join("secret.txt"), "TOP-SECRET-CONTENT").unwrap();
    let app = spawn_app(|c| c.viewer_dir = viewer.clone(), 0).await;

    let index = app.get("/viewer?job=abc").await;
    let module = app
        .get("/viewer/node_modules/three/build/three.module.js")
        .await;
    let escape = app.get("/viewer/../secret.txt").await;
    let encoded = app.get("/viewer/%2e%2e/secret.txt").await;

    assert_eq!(index.status, StatusCode::OK);
    assert!(String::from_utf8_lossy(&index.body).contains("<title>v</title>"));
    assert_eq!(module.status, StatusCode::OK);
    assert!(
        module.headers[header::CONTENT_TYPE]
            .to_str()
            .unwrap()
            .starts_with("text/javascript")
    );
    assert_ne!(escape.status, StatusCode::OK);
    assert_ne!(encoded.status, StatusCode::OK);
    assert!(!String::from_utf8_lossy(&encoded.body).contains("TOP-SECRET"));
    assert!(!String::from_utf8_lossy(&escape.body).contains("TOP-SECRET"));
}

fn with_key(request: axum::http::request::Builder, key: &str) -> axum::http::request::Builder {
    request.header(header::AUTHORIZATION, format!("Bearer {key}"))
}

#[tokio::test]
async fn a_key_sees_only_its_own_jobs_and_an_admin_sees_all() {
    let app = spawn_app(
        |c| c.api_keys = vec![ApiKey::new("k1"), ApiKey::new("k2"), ApiKey::admin("root")],
        0,
    )
    .await;
    let submitted = app
        .send(
            with_key(Request::post("/processes/dmt-contour/execution"), "k1")
                .header(header::CONTENT_TYPE, "application/json")
                .header("Prefer", "respond-async")
                .body(Body::from(small_request().to_string()))
                .unwrap(),
        )
        .await;
    assert_eq!(submitted.status, StatusCode::CREATED);
    let job_id = submitted.json()["jobID"].as_str().unwrap().to_string();
    let as_key = |key: &'static str, method: &'static str, path: String| {
        let app = &app;
        async move {
            app.send(
                with_key(Request::builder().method(method).uri(path), key)
                    .body(Body::empty())
                    .unwrap(),
            )
            .await
        }
    };

    let other_list = as_key("k2", "GET", "/jobs".into()).await.json();
    let other_status = as_key("k2", "GET", format!("/jobs/{job_id}")).await;
    let other_results = as_key("k2", "GET", format!("/jobs/{job_id}/results")).await;
    let other_delete = as_key("k2", "DELETE", format!("/jobs/{job_id}")).await;
    let own_list = as_key("k1", "GET", "/jobs".into()).await.json();
    let admin_list = as_key("root", "GET", "/jobs".into()).await.json();
    let own_status = as_key("k1", "GET", format!("/jobs/{job_id}")).await;

    assert_eq!(other_list["jobs"], json!([]));
    assert_eq!(other_status.status, StatusCode::NOT_FOUND);
    assert_eq!(other_results.status, StatusCode::NOT_FOUND);
    assert_eq!(other_delete.status, StatusCode::NOT_FOUND);
    assert_eq!(own_status.status, StatusCode::OK);
    assert_eq!(own_list["jobs"][0]["jobID"], job_id.as_str());
    assert_eq!(admin_list["jobs"][0]["jobID"], job_id.as_str());
    let admin_delete = as_key("root", "DELETE", format!("/jobs/{job_id}")).await;
    assert_eq!(admin_delete.status, StatusCode::OK);
}

/// A request claiming, through forwarded headers, to come from evil.example.
fn forged(request: axum::http::request::Builder) -> axum::http::request::Builder {
    request
        .header(header::HOST, "wellmesh.test")
        .header("X-Forwarded-Host", "evil.example")
        .header("X-Forwarded-Proto", "https")
}

async fn submit_forged(app: &TestApp) -> Answer {
    app.send(
        forged(Request::post("/processes/dmt-contour/execution"))
            .header(header::CONTENT_TYPE, "application/json")
            .header("Prefer", "respond-async")
            .body(Body::from(small_request().to_string()))
            .unwrap(),
    )
    .await
}

#[tokio::test]
async fn forwarded_headers_from_an_untrusted_peer_change_no_link() {
    let app = spawn_app(|_| {}, 0).await;
    let pinned = spawn_app(
        |c| c.public_url = Some("https://mesh.example/api/".into()),
        0,
    )
    .await;
    let trusting = spawn_app(
        |c| c.trusted_proxies = vec!["127.0.0.1".parse().unwrap()],
        0,
    )
    .await;
    let untrusted = submit_forged(&app).await;
    let landing = app
        .send(forged(Request::get("/")).body(Body::empty()).unwrap())
        .await;
    let public = submit_forged(&pinned).await;
    let proxied = submit_forged(&trusting).await;

    let location = |answer: &Answer| {
        answer.headers[header::LOCATION]
            .to_str()
            .unwrap()
            .to_string()
    };
    assert!(location(&untrusted).starts_with("http://wellmesh.test/jobs/"));
    assert!(!String::from_utf8_lossy(&landing.body).contains("evil.example"));
    assert!(location(&public).starts_with("https://mesh.example/api/jobs/"));
    assert!(location(&proxied).starts_with("https://evil.example/jobs/"));
}

#[tokio::test]
async fn a_huge_refused_input_is_never_echoed_back() {
    let app = spawn_app(|_| {}, 0).await;
    let huge = "m".repeat(5 * 1024 * 1024);

    let answer = app
        .execute(
            json!({"inputs": {"samples_csv": "a", "thresholds": [1], "method": huge}}),
            true,
        )
        .await;

    assert_eq!(answer.status, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(
        answer.body.len() < 2048,
        "{} bytes answered",
        answer.body.len()
    );
    assert_eq!(answer.json()["field"], "method");
}

#[tokio::test]
async fn the_job_list_pages_with_next_links_and_filters_by_status() {
    let app = spawn_app(|_| {}, 0).await;
    let mut ids = Vec::new();
    for _ in 0..3 {
        let job = app.execute(small_request(), true).await.json();
        ids.push(job["jobID"].as_str().unwrap().to_string());
        tokio::time::sleep(Duration::from_millis(3)).await;
    }
    app.send(
        Request::delete(format!("/jobs/{}", ids[2]))
            .body(Body::empty())
            .unwrap(),
    )
    .await;

    let first = app.get("/jobs?limit=1").await.json();
    let next = first["links"]
        .as_array()
        .unwrap()
        .iter()
        .find(|l| l["rel"] == "next")
        .unwrap()["href"]
        .as_str()
        .unwrap()
        .to_string();
    let second = app.get(&next).await.json();
    let failed = app.get("/jobs?status=failed").await.json();
    let other = app.get("/jobs?processID=other").await.json();

    assert_eq!(first["jobs"].as_array().unwrap().len(), 1);
    assert_eq!(first["jobs"][0]["jobID"], ids[1].as_str());
    assert_eq!(second["jobs"][0]["jobID"], ids[0].as_str());
    assert_eq!(failed["jobs"], json!([]));
    assert_eq!(other["jobs"], json!([]));
}

#[tokio::test]
async fn metrics_show_the_storage_per_job() {
    let app = spawn_app(|_| {}, 0).await;
    app.execute(small_request(), true).await;

    let text = String::from_utf8(app.get("/metrics").await.body).unwrap();

    assert!(text.contains("wellmesh_store_jobs 1"), "{text}");
    assert!(
        text.contains("wellmesh_store_bytes{part=\"inputs\"}"),
        "{text}"
    );
    assert!(
        text.contains("wellmesh_store_job_bytes{stat=\"max\"}"),
        "{text}"
    );
    assert!(text.contains("wellmesh_store_file_bytes"), "{text}");
}

#[test]
fn the_committed_openapi_document_is_the_generated_one() {
    let committed =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/openapi/openapi.json"))
            .expect("openapi/openapi.json is committed");
    let generated = api::openapi_json();
    assert!(
        committed == generated,
        "openapi/openapi.json is stale: regenerate it with `cargo run -- openapi > openapi/openapi.json`"
    );
}
