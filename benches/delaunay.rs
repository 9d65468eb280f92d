//! Delaunay tetrahedralization throughput on uniform points and on a well lattice at UTM
//! coordinates (the shapes of `docs/benchmarks.md`, at sizes a bench run can repeat).

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::DVec3;
use wellmesh::progress::NoProgress;
use wellmesh::tet::delaunay;

/// Seeded uniform points in the unit cube (xorshift64*).
fn uniform(n: usize) -> Vec<DVec3> {
    let mut s = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move || {
        s ^= s >> 12;
        s ^= s << 25;
        s ^= s >> 27;
        (s.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n).map(|_| DVec3::new(next(), next(), next())).collect()
}

/// `wells x wells` vertical wells 50 m apart at UTM coordinates, collars jittered by up to
/// 3 m, `samples` samples 1 m apart (like `gen_points.py utm-wells`).
fn utm_wells(wells: usize, samples: usize) -> Vec<DVec3> {
    let mut pts = Vec::with_capacity(wells * wells * samples);
    for i in 0..wells {
        for j in 0..wells {
            let k = (i * wells + j) as f64;
            let jitter = DVec3::new(
                (k * 0.618_034).fract() * 3.0,
                (k * 0.414_214).fract() * 3.0,
                0.0,
            );
            let collar = DVec3::new(
                500_000.0 + i as f64 * 50.0,
                6_500_000.0 + j as f64 * 50.0,
                300.0,
            );
            for s in 0..samples {
                pts.push(collar + jitter - DVec3::new(0.0, 0.0, s as f64));
            }
        }
    }
    pts
}

fn bench_delaunay(c: &mut Criterion) {
    let mut group = c.benchmark_group("delaunay");
    group.sample_size(10);
    for (name, pts) in [
        ("uniform_10k", uniform(10_000)),
        ("uniform_100k", uniform(100_000)),
        ("utm_wells_20x20x100", utm_wells(20, 100)),
    ] {
        group.throughput(Throughput::Elements(pts.len() as u64));
        group.bench_with_input(BenchmarkId::from_parameter(name), &pts, |b, pts| {
            b.iter(|| delaunay(black_box(pts), &NoProgress).expect("tetrahedralization"))
        });
    }
    group.finish();
}

criterion_group!(benches, bench_delaunay);
criterion_main!(benches);
