//! The exporters on real pipeline output: two nested grade shells contoured from vertical
//! wells at UTM coordinates, written as GLB and read back with the `gltf` crate.
//!
//! The GLB is kept as `target/tmp/export/pipeline.glb` (with its summary) for the Khronos
//! validator and the viewer's browser test.

use std::collections::HashMap;

use glam::DVec3;
use serde_json::Value;
use wellmesh::contour::{
    self, ContourRequest, ContourResult, Interpolant, Thresholds, UnknownMode,
};
use wellmesh::export::{OutputOptions, all_outputs};
use wellmesh::progress::NoProgress;
use wellmesh::wells::{ReadReport, SampleSet, Well};

const CENTRE: DVec3 = DVec3::new(512_345.0, 7_012_345.0, 300.0);

/// Grade: two overlapping ellipsoidal lenses, 1 at their centres, 0 at their rims.
fn grade(p: DVec3) -> f64 {
    let big = ((p - CENTRE) / DVec3::new(80.0, 60.0, 50.0)).length();
    let small =
        ((p - CENTRE - DVec3::new(30.0, 10.0, 5.0)) / DVec3::new(30.0, 25.0, 20.0)).length();
    (1.0 - big).max(0.0) + (1.0 - small).max(0.0)
}

/// 12 x 12 vertical wells 20 m apart (jittered by a fixed sequence), sampled every 5 m.
fn contoured() -> ContourResult {
    let (n, spacing) = (12, 20.0);
    let half = (n as f64 - 1.0) * spacing / 2.0;
    let (top, bottom) = (CENTRE.z + 120.0, CENTRE.z - 120.0);
    let mut state = 7u64;
    let mut jitter = move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 6.0
    };
    let mut world = Vec::new();
    let mut well_of = Vec::new();
    let mut collars = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let x = CENTRE.x - half + i as f64 * spacing + jitter();
            let y = CENTRE.y - half + j as f64 * spacing + jitter();
            collars.push(DVec3::new(x, y, top));
            let mut z = top;
            while z >= bottom {
                world.push(DVec3::new(x, y, z));
                well_of.push(collars.len() as u32 - 1);
                z -= 5.0;
            }
        }
    }
    let origin = DVec3::new(CENTRE.x, CENTRE.y, (top + bottom) / 2.0);
    let samples = SampleSet {
        origin,
        crs: Some("EPSG:32633".into()),
        unit: "m".into(),
        wells: collars
            .iter()
            .enumerate()
            .map(|(k, &c)| Well {
                id: format!("DH{k:03}"),
                collar: c - origin,
                trace: vec![c - origin, DVec3::new(c.x, c.y, bottom) - origin],
            })
            .collect(),
        points: world.iter().map(|&p| p - origin).collect(),
        values: world.iter().map(|&p| Some(grade(p))).collect(),
        well_of,
        report: ReadReport {
            rows_read: world.len(),
            ..ReadReport::default()
        },
    };
    let request = ContourRequest {
        unknown: UnknownMode::Drop,
        interpolant: Interpolant::Linear,
        ..ContourRequest::samples(samples, Thresholds::new(vec![0.2, 0.6]).unwrap())
    };
    contour::run(&request, &NoProgress).expect("the pipeline contours the lenses")
}

#[test]
fn pipeline_bodies_read_back_from_the_glb_closed_with_the_summarys_measures() {
    let result = contoured();
    let outputs = all_outputs(&result, &OutputOptions::default()).unwrap();
    let glb = &outputs.iter().find(|o| o.id == "glb").unwrap().bytes;
    let summary = &outputs.iter().find(|o| o.id == "summary").unwrap().bytes;
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("export");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("pipeline.glb"), glb).unwrap();
    std::fs::write(dir.join("pipeline.summary.json"), summary).unwrap();

    let summary: Value = serde_json::from_slice(summary).unwrap();
    let expected: Vec<&Value> = summary["shells"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|s| s["bodies"].as_array().unwrap())
        .collect();
    assert!(expected.len() >= 2, "both shells have a body");

    let (document, buffers, _) = gltf::import_slice(glb).unwrap();
    let bodies: Vec<_> = document
        .meshes()
        .filter(|m| {
            m.primitives()
                .all(|p| p.mode() == gltf::mesh::Mode::Triangles)
        })
        .collect();
    assert_eq!(bodies.len(), expected.len());
    for (mesh, body) in bodies.iter().zip(expected) {
        let primitive = mesh.primitives().next().unwrap();
        let reader = primitive.reader(|b| Some(&buffers[b.index()]));
        let positions: Vec<DVec3> = reader
            .read_positions()
            .unwrap()
            .map(|[e, u, s]| DVec3::new(e as f64, -s as f64, u as f64))
            .collect();
        let indices: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
        let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
        let (mut volume, mut area) = (0.0, 0.0);
        for t in indices.chunks(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| positions[i as usize]);
            volume += a.dot(b.cross(c)) / 6.0;
            area += (b - a).cross(c - a).length() / 2.0;
            for k in 0..3 {
                *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
            }
        }
        if body["closed"] == true {
            assert!(
                directed
                    .iter()
                    .all(|(&(a, b), &n)| n == 1 && directed.get(&(b, a)) == Some(&1)),
                "{}: a closed body is a consistently wound 2-manifold",
                mesh.name().unwrap()
            );
        }
        let (v, s) = (
            body["volume"].as_f64().unwrap(),
            body["area"].as_f64().unwrap(),
        );
        assert!(volume > 0.0);
        assert!((volume - v).abs() < 1e-5 * v, "volume {volume} vs {v}");
        assert!((area - s).abs() < 1e-5 * s, "area {area} vs {s}");
    }
}
