//! The service's pipeline on real inputs: what an HTTP client gets in the stored outputs.

use wellmesh::process::{ContourPipeline, ProcessInputs};
use wellmesh::progress::NoProgress;

fn inputs(extra: serde_json::Value) -> ProcessInputs {
    let csv = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/sample_wells/copper_wells.csv"
    ))
    .unwrap();
    let mut body = serde_json::json!({"samples_csv": csv, "thresholds": [0.5]});
    body.as_object_mut()
        .unwrap()
        .extend(extra.as_object().unwrap().clone());
    serde_json::from_value(body).unwrap()
}

fn glb_node_names(extra: serde_json::Value) -> Vec<String> {
    let outputs = ContourPipeline
        .run_inputs(&inputs(extra), &NoProgress)
        .expect("pipeline");
    let glb = outputs
        .iter()
        .find(|o| o.id == "glb")
        .expect("a GLB output");
    let doc = gltf::Gltf::from_slice(&glb.bytes).expect("a readable GLB");
    doc.nodes()
        .filter_map(|n| n.name().map(str::to_string))
        .collect()
}

#[test]
fn drill_hole_traces_and_samples_are_optional_per_request() {
    let all = glb_node_names(serde_json::json!({}));
    assert!(all.iter().any(|n| n == "drill holes"), "{all:?}");
    assert!(all.iter().any(|n| n == "samples"), "{all:?}");

    let bare = glb_node_names(serde_json::json!({"well_traces": false, "well_samples": false}));
    assert!(
        !bare.iter().any(|n| n == "drill holes" || n == "samples"),
        "{bare:?}"
    );
    assert!(
        bare.iter().any(|n| n.contains("body")),
        "the bodies stay: {bare:?}"
    );
}
