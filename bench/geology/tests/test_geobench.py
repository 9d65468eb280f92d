"""Tests of the geology benchmark's own parts: desurvey, truth, layouts, mesh reading and
scoring. Run: python -m pytest bench/geology/tests (needs requirements.txt)."""

from __future__ import annotations

import json
import math
import shutil
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import make_layouts  # noqa: E402
from drillholes import Samples, Trajectory, read_tables  # noqa: E402
from meshes import Body, RayParity, is_closed, read_glb, signed_volume, split_bodies  # noqa: E402
from score import assays_at_holes, score, uniform_in_lenses  # noqa: E402
from truth import Lens, Truth, ellipsoid_area, frame, icosphere, mesh_volume  # noqa: E402

REPO = HERE.parent.parent.parent


def small_truth(count=1) -> Truth:
    lenses = [Lens(centre=[512000.0, 7021000.0, 900.0], dip=40.0, dip_direction=130.0,
                   pitch=25.0, semi_axes=[150.0, 90.0, 12.0], core_grade=12.0,
                   halo_radius=1.6)]
    if count == 2:
        lenses.append(Lens(centre=(np.array(lenses[0].centre) - 60.0 * frame(40, 130, 25)[2])
                           .tolist(), dip=40.0, dip_direction=130.0, pitch=25.0,
                           semi_axes=[100.0, 60.0, 8.0], core_grade=10.0, halo_radius=1.5))
    return Truth(layout="test", seed=0, variable="zn", threshold=5.0, grade_threshold=5.0,
                 background=0.7, noise_sigma_ln=0.3, nugget_share=0.25, lenses=lenses)


# -- desurvey ---------------------------------------------------------------------------

def test_straight_inclined_hole_is_a_line():
    t = Trajectory([0.0, 50.0, 100.0], [45.0, 45.0, 45.0], [60.0, 60.0, 60.0])
    p = t.position(np.array([10.0, 75.0, 150.0]))
    d = np.array([math.sin(math.radians(45)) * 0.5, math.cos(math.radians(45)) * 0.5,
                  -math.sin(math.radians(60))])
    assert np.allclose(p, np.outer([10.0, 75.0, 150.0], d), atol=1e-9)


def test_minimum_curvature_reproduces_a_circular_arc():
    # A vertical arc of radius 300 m building from straight down towards north.
    r = 300.0
    depths = np.arange(0.0, 301.0, 30.0)
    theta = depths / r  # angle turned from vertical
    t = Trajectory(depths, np.zeros_like(depths), 90.0 - np.degrees(theta))
    q = np.array([17.0, 95.5, 211.25])
    p = t.position(q)
    exact = np.column_stack([np.zeros(3), r * (1 - np.cos(q / r)), -r * np.sin(q / r)])
    assert np.allclose(p, exact, atol=1e-8)


def test_samples_at_interval_midpoints_with_gap_unknown(tmp_path):
    (tmp_path / "c.csv").write_text("hole_id,x,y,z\nA,500000,7000000,1000\n")
    (tmp_path / "s.csv").write_text("hole_id,depth,azimuth,dip\nA,0,0,-90\n")
    (tmp_path / "a.csv").write_text("hole_id,from,to,zn\nA,0,2,1.5\nA,4,6,<0.2\nA,4,6,9\n")
    s = read_tables(tmp_path / "c.csv", tmp_path / "s.csv", tmp_path / "a.csv", "zn")
    assert np.allclose(s.positions[:, 2], [999.0, 997.0, 995.0])
    assert s.values[0] == 1.5 and math.isnan(s.values[1]) and s.values[2] == pytest.approx(0.1)


# -- truth --------------------------------------------------------------------------------

def test_frame_is_orthonormal_and_follows_strike_and_dip():
    r = frame(30.0, 90.0, 0.0)  # dips 30 degrees to the east: strike is north
    assert np.allclose(r @ r.T, np.eye(3), atol=1e-12)
    assert np.allclose(r[0], [0.0, 1.0, 0.0], atol=1e-12)  # major axis along strike
    assert np.allclose(r[1], [math.cos(math.radians(30)), 0.0, -math.sin(math.radians(30))])


def test_grade_reaches_the_threshold_exactly_on_the_ellipsoid():
    t = small_truth()
    lens = t.lenses[0]
    q = (5.0 - t.background) / (lens.core_grade - t.background)
    lens.halo_radius = 1.0 / math.sqrt(1.0 - math.sqrt(q))
    rng = np.random.default_rng(1)
    d = rng.standard_normal((200, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    on = (d * lens.semi_axes) @ lens.rotation + lens.centre
    assert np.allclose(t.grade(on), 5.0, atol=1e-9)
    assert np.all(t.grade((d * 0.99 * np.asarray(lens.semi_axes)) @ lens.rotation + lens.centre) > 5)
    assert np.all(t.contains(on * 0 + lens.centre))


def test_ellipsoid_area_matches_a_fine_tessellation():
    v, f = icosphere(6)
    for axes in ([150.0, 90.0, 12.0], [40.0, 40.0, 40.0], [300.0, 20.0, 5.0]):
        w = v * axes
        a, b, c = (w[f[:, k]] for k in range(3))
        tess = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum()
        assert ellipsoid_area(*axes) == pytest.approx(tess, rel=2e-3)


def test_lens_meshes_are_closed_outward_with_exact_volume():
    t = small_truth(2)
    for (v, f), lens in zip(t.lens_meshes(4), t.lenses):
        assert is_closed(f)
        assert mesh_volume(v, f) == pytest.approx(lens.volume, rel=1e-9)
    assert t.volume == pytest.approx(sum(4 / 3 * math.pi * np.prod(l.semi_axes) for l in t.lenses))


def test_truth_round_trips_through_json(tmp_path):
    t = small_truth(2)
    t.save(tmp_path / "truth.json")
    u = Truth.load(tmp_path)
    pts = np.random.default_rng(0).uniform(-200, 200, (1000, 3)) + t.lenses[0].centre
    assert np.array_equal(t.contains(pts), u.contains(pts))
    assert json.loads((tmp_path / "truth.json").read_text())["volume_m3"] == pytest.approx(t.volume)


# -- layouts ------------------------------------------------------------------------------

def test_layouts_are_reproducible_and_read_back(tmp_path):
    a = make_layouts.write_layout(tmp_path / "a", "lens", 3)
    b = make_layouts.write_layout(tmp_path / "b", "lens", 3)
    for name in ("collars.csv", "surveys.csv", "assays.csv", "truth.json"):
        assert (Path(a["dir"]) / name).read_bytes() == (Path(b["dir"]) / name).read_bytes()
    assert 28_000 < a["assays"] < 40_000
    d = Path(a["dir"])
    t = Truth.load(d)
    s = read_tables(d / "collars.csv", d / "surveys.csv", d / "assays.csv", t.variable)
    k = s.known
    assert k.sum() == a["assays"]
    # The assays are the true grade at the desurveyed midpoints times lognormal noise.
    ratio = s.values[k] / t.grade(s.positions[k])
    assert abs(np.log(ratio).std() - t.noise_sigma_ln) < 0.01
    assert t.contains(s.positions[k]).sum() > 50
    flag = make_layouts.write_layout(tmp_path / "a", "lens_flag", 3)
    f = Truth.load(flag["dir"])
    fs = read_tables(Path(flag["dir"]) / "collars.csv", Path(flag["dir"]) / "surveys.csv",
                     Path(flag["dir"]) / "assays.csv", f.variable)
    assert f.flag and f.threshold == 0.5
    assert np.array_equal(fs.values[fs.known] == 1, np.round(s.values[k], 4) >= 5.0)


def test_noise_free_layouts_hold_the_true_grades_of_the_same_holes(tmp_path):
    a = make_layouts.write_layout(tmp_path / "noisy", "lens", 2)
    b = make_layouts.write_layout(tmp_path / "clean", "lens", 2, noise_free=True)
    for name in ("collars.csv", "surveys.csv"):
        assert (Path(a["dir"]) / name).read_bytes() == (Path(b["dir"]) / name).read_bytes()
    d = Path(b["dir"])
    t = Truth.load(d)
    assert t.noise_sigma_ln == 0.0 and t.nugget_share == 0.0
    assert t.lenses == Truth.load(Path(a["dir"])).lenses
    s = read_tables(d / "collars.csv", d / "surveys.csv", d / "assays.csv", t.variable)
    k = s.known
    assert k.sum() == a["assays"] == b["assays"]
    # Written with four significant digits.
    assert np.abs(s.values[k] / t.grade(s.positions[k]) - 1.0).max() < 1e-3


def test_two_lenses_are_disjoint():
    truth, *_ = make_layouts.build("two_lens", 2)
    rng = np.random.default_rng(0)
    pts, which = uniform_in_lenses(truth, 20000, rng)
    r = [l.radius(pts) for l in truth.lenses]
    assert not np.any((r[0] <= 1) & (r[1] <= 1))


def test_two_dips_lie_side_by_side_at_different_attitudes():
    for seed in (1, 3):
        truth, _, _, _, noisy = make_layouts.build("two_dips", seed)
        rng = np.random.default_rng(0)
        pts, _ = uniform_in_lenses(truth, 20000, rng)
        r = [l.radius(pts) for l in truth.lenses]
        assert not np.any((r[0] <= 1) & (r[1] <= 1))
        normals = [l.rotation[2] for l in truth.lenses]
        angle = np.degrees(np.arccos(abs(float(normals[0] @ normals[1]))))
        assert angle > 20.0, angle
        assert np.mean(np.asarray(noisy) >= 5.0) > 0.005  # the lenses are drilled


# -- meshes and scoring -------------------------------------------------------------------

def ellipsoid_body(truth: Truth, scale: float, level: int = 5, shift=(0.0, 0.0, 0.0)) -> Body:
    lens = truth.lenses[0]
    v, f = icosphere(level)
    verts = (v * np.asarray(lens.semi_axes) * scale) @ lens.rotation + lens.centre + shift
    return Body(verts, f)


def test_ray_parity_matches_the_closed_form_inside_test():
    t = small_truth()
    b = ellipsoid_body(t, 1.0, level=6)
    rng = np.random.default_rng(3)
    lo, hi = t.bounds()
    pts = lo + rng.random((20000, 3)) * (hi - lo)
    inside = RayParity(b.vertices, b.faces).inside(pts)[:, 0]
    r = t.lenses[0].radius(pts)
    far = np.abs(r - 1.0) > 0.01  # away from the tessellation's chords
    assert np.array_equal(inside[far], r[far] <= 1.0)


def test_scaled_truth_scores_the_nested_volume_ratio():
    t = small_truth()
    body = ellipsoid_body(t, 0.9, level=6)
    out = score(t, [body], None, mc_points=100_000)
    assert out["iou_method"] == "manifold"
    assert out["iou"] == pytest.approx(0.9 ** 3, abs=0.003)
    assert abs(out["iou_mc"] - out["iou"]) < 4 * out["iou_mc_se"] + 0.002
    assert out["volume_error_pct"] == pytest.approx(100 * (0.9 ** 3 - 1), abs=0.4)
    assert out["lens_bodies"] == [1] and out["stray_bodies"] == 0 and out["bodies"] == 1


def test_figures_at_the_holes(tmp_path):
    """Noise-free assays say exactly where the truth is at the holes (the ceiling is 1 with
    no smoothing); the true ellipsoid as the model scores 1 there too, a shrunk one less;
    noisy assays score below 1, better smoothed than raw."""
    lay = make_layouts.write_layout(tmp_path, "lens", 2)
    d = Path(lay["dir"])
    t = Truth.load(d)
    s = read_tables(d / "collars.csv", d / "surveys.csv", d / "assays.csv", t.variable)
    noisy, window = assays_at_holes(t, s)
    assert 0.5 < noisy < 0.95 and window > 1
    exact = Samples(s.hole_ids, s.hole, s.positions, np.where(s.known, t.grade(s.positions),
                                                                np.nan), s.depths)
    assert assays_at_holes(t, exact) == (1.0, 1)
    full = score(t, [ellipsoid_body(t, 1.0, level=6)], None, mc_points=10_000, assays=exact)
    assert full["iou_at_holes"] > 0.98
    shrunk = score(t, [ellipsoid_body(t, 0.8, level=6)], None, mc_points=10_000, assays=exact)
    assert shrunk["iou_at_holes"] < full["iou_at_holes"] - 0.1


def test_open_model_falls_back_to_monte_carlo_and_stray_bodies_count():
    t = small_truth(2)
    inside = ellipsoid_body(t, 1.0, level=5)
    stray = ellipsoid_body(t, 0.1, level=2, shift=(2000.0, 0.0, 0.0))
    open_faces = inside.faces[1:]  # one triangle missing
    out = score(t, [Body(inside.vertices, open_faces), stray], None, mc_points=50_000)
    assert out["iou_method"] == "monte-carlo" and out["iou_se"] > 0
    assert out["lens_bodies"] == [1, 0] and out["stray_bodies"] == 1
    v1 = t.lenses[0].volume
    assert out["iou"] == pytest.approx(v1 / t.volume, rel=0.05)


def test_split_bodies_turns_inward_soups_and_finds_cavities():
    v, f = icosphere(2)
    outer = (v * 10.0, f)
    cavity = (v * 3.0, f[:, ::-1])
    far = (v * 2.0 + 50.0, f)
    verts = np.vstack([outer[0], cavity[0], far[0]])
    faces = np.vstack([outer[1], cavity[1] + len(v), far[1] + 2 * len(v)])
    bodies = split_bodies(verts, faces)
    assert len(bodies) == 2
    vols = sorted(signed_volume(b.vertices, b.faces) for b in bodies)
    assert vols[1] == pytest.approx(mesh_volume(v * 10, f) - mesh_volume(v * 3, f))
    flipped = split_bodies(verts, faces[:, ::-1])  # all inward: turned over as a whole
    assert sorted(signed_volume(b.vertices, b.faces) for b in flipped) == pytest.approx(vols)


def write_glb(path: Path, positions_local: np.ndarray, faces: np.ndarray, origin):
    """A minimal GLB the way wellmesh writes one: Y-up (east, up, -north), extras.origin."""
    gl = np.column_stack([positions_local[:, 0], positions_local[:, 2], -positions_local[:, 1]])
    pos = gl.astype("<f4").tobytes()
    idx = faces.astype("<u4").tobytes()
    doc = {"asset": {"version": "2.0"}, "scene": 0,
           "scenes": [{"nodes": [0], "extras": {"origin": list(origin)}}],
           "nodes": [{"name": "shell 1 threshold 5 body 1", "mesh": 0}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "mode": 4}]}],
           "buffers": [{"byteLength": len(pos) + len(idx)}],
           "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(pos)},
                           {"buffer": 0, "byteOffset": len(pos), "byteLength": len(idx)}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": len(gl), "type": "VEC3"},
                         {"bufferView": 1, "componentType": 5125, "count": faces.size,
                          "type": "SCALAR"}]}
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    binary = pos + idx
    binary += b"\0" * (-len(binary) % 4)
    total = 12 + 8 + len(js) + 8 + len(binary)
    path.write_bytes(struct.pack("<4sII", b"glTF", 2, total) + struct.pack("<II", len(js), 0x4E4F534A)
                     + js + struct.pack("<II", len(binary), 0x004E4942) + binary)


def test_glb_axes_and_origin_are_undone(tmp_path):
    t = small_truth()
    body = ellipsoid_body(t, 1.0, level=4)
    origin = np.array([511990.0, 7021010.0, 880.0])
    write_glb(tmp_path / "m.glb", body.vertices - origin, body.faces, origin)
    s = read_glb(tmp_path / "m.glb")
    assert len(s.bodies) == 1
    assert np.abs(s.bodies[0].vertices - body.vertices).max() < 1e-3  # f32 relative positions
    assert signed_volume(s.bodies[0].vertices, s.bodies[0].faces) > 0  # winding kept


@pytest.mark.skipif(not (REPO / "target" / "release" / "wellmesh").exists(),
                    reason="needs target/release/wellmesh")
def test_wellmesh_samples_sit_where_we_desurvey_them(tmp_path):
    info = make_layouts.write_layout(tmp_path, "lens", 2)
    d = Path(info["dir"])
    glb = tmp_path / "w.glb"
    subprocess.run([str(REPO / "target" / "release" / "wellmesh"), "contour", "--collars",
                    str(d / "collars.csv"), "--surveys", str(d / "surveys.csv"), "--intervals",
                    str(d / "assays.csv"), "--variable", "zn", "--threshold", "5", "-o", str(glb)],
                   check=True, capture_output=True)
    s = read_tables(d / "collars.csv", d / "surveys.csv", d / "assays.csv", "zn")
    g = read_glb(glb)
    from score import check_desurvey

    c = check_desurvey(s.positions, g.samples)
    assert c["glb_points"] == c["our_points"]
    assert c["max_glb_to_ours_m"] < 1e-3  # the GLB's f32 rounding, nothing more
    assert all(is_closed(b.faces) for b in g.bodies)


def test_ferreus_normalises_trend_ratios_by_their_geometric_mean():
    """peers.py passes ranges to ferreus_rbf as their geometric mean (base range) and ratios
    to it, because ferreus_rbf divides the ratios by their geometric mean: ratios 2,2,2 act as
    1,1,1 and 8,1,1 as 4,0.5,0.5. If a new ferreus_rbf stops doing so, this fails."""
    from ferreus_rbf import GlobalTrend, RBFInterpolator
    from ferreus_rbf.interpolant_config import (Drift, InterpolantSettings, RBFKernelType,
                                                SpheroidalOrder)

    rng = np.random.default_rng(0)
    far = rng.normal(size=(40, 3))
    far = far / np.linalg.norm(far, axis=1)[:, None] * 5000.0
    x = np.vstack([[0.0, 0.0, 0.0], far])
    v = np.concatenate([[1.0], np.zeros(40)])
    d = np.array([[10.0, 0.0, 0.0], [0.0, 10.0, 0.0], [0.0, 0.0, 10.0]])

    def field(ratios):
        s = InterpolantSettings(RBFKernelType.Spheroidal, spheroidal_order=SpheroidalOrder.Three,
                                drift=Drift.Constant, base_range=20.0, total_sill=1.0)
        gt = None if ratios is None else GlobalTrend.three(0.0, 90.0, 0.0, *ratios)
        return RBFInterpolator(x, v, s, global_trend=gt).evaluate(d)

    assert np.allclose(field((2.0, 2.0, 2.0)), field(None), atol=1e-6)
    # 8,1,1 has geometric mean 2: the same as 4,0.5,0.5.
    assert np.allclose(field((8.0, 1.0, 1.0)), field((4.0, 0.5, 0.5)), atol=1e-6)


# -- drivers ------------------------------------------------------------------------------

def test_folds_partition_the_holes():
    import tom_zone_holdout as tz

    holes = [f"H{i:03d}" for i in range(206)]
    folds = [tz.fold_holes(holes, k) for k in range(5)]
    assert set().union(*folds) == set(holes)
    assert sum(len(f) for f in folds) == len(holes)
    assert {len(f) for f in folds} == {41, 42}
    assert "H000" in folds[0] and "H005" in folds[0] and "H004" in folds[4]


def test_balanced_accuracy_of_held_out_assays():
    import tom_zone_holdout as tz

    values = np.array([6.0, 7.0, 5.0, 1.0, 2.0, 4.9, 0.1, 3.0])
    inside = np.array([True, False, True, False, True, False, False, False])
    s = tz.scores(inside, values)
    assert s["ore_inside"] == pytest.approx(2 / 3)
    assert s["waste_outside"] == pytest.approx(4 / 5)
    assert s["balanced"] == pytest.approx((2 / 3 + 4 / 5) / 2)
    # 3 of 8 inside against 3 of ore: the shell holds as many assays as there are of ore.
    assert s["inside_per_ore"] == pytest.approx(1.0)
    # Drawn lower: one more ore assay kept, one more waste taken in; balanced accuracy rises
    # while the shell overstates the ore by two thirds.
    grown = inside | (values >= 4.9)
    assert tz.scores(grown, values)["inside_per_ore"] == pytest.approx(5 / 3)
    assert tz.scores(grown, values)["balanced"] > s["balanced"]


@pytest.mark.skipif(not Path("/usr/bin/time").exists(), reason="needs GNU time")
def test_peak_memory_is_the_child_s_not_the_parent_s(tmp_path):
    import bench

    ballast = np.ones(40_000_000)  # 320 MB held by this process while the child runs
    small = bench.measured([sys.executable, "-c", "pass"], tmp_path / "small.log")
    big = bench.measured([sys.executable, "-c", "b = bytearray(300_000_000); b[::4096] = b'x' * len(b[::4096])"],
                         tmp_path / "big.log")
    assert ballast.sum() > 0
    assert small["exit"] == 0 and not small["peak_is_upper_bound"]
    assert small["peak_mb"] < 100
    assert 280 < big["peak_mb"] < 450


@pytest.mark.skipif(not (REPO / "target" / "release" / "wellmesh").exists(),
                    reason="needs target/release/wellmesh")
def test_tom_zone_samples_sit_where_wellmesh_puts_them(tmp_path):
    """Real tables (up-holes, gaps, unsurveyed holes): every sample point of wellmesh's GLB
    is one of ours, within the GLB's f32 rounding."""
    import tom_zone_holdout as tz
    from score import check_desurvey

    p = tz.tables()
    glb = tmp_path / "tom.glb"
    subprocess.run([str(REPO / "target" / "release" / "wellmesh"), "contour", "--collars",
                    str(p["collars"]), "--surveys", str(p["surveys"]), "--intervals",
                    str(p["intervals"]), "--variable", "Zn_pct", "--threshold", "5", "-o",
                    str(glb)], check=True, capture_output=True)
    s = read_tables(p["collars"], p["surveys"], p["intervals"], "Zn_pct")
    c = check_desurvey(s.positions, read_glb(glb).samples)
    assert c["glb_points"] == c["our_points"] == 6686
    assert c["max_glb_to_ours_m"] < 1e-3 and c["max_ours_to_glb_m"] < 1e-3
    assert len(tz.holes_with_assays()) == 206


def test_pictures_reduce_the_palette_and_keep_the_size(tmp_path):
    from PIL import Image

    import pictures

    path = tmp_path / "many.png"
    ramp = np.arange(64 * 64 * 3, dtype=np.uint32).reshape(64, 64, 3) * 37 % 256
    Image.fromarray(ramp.astype(np.uint8), "RGB").save(path)
    pictures.reduce_palette(path, 16)
    with Image.open(path) as im:
        assert im.mode == "P" and im.size == (64, 64)
        assert len(im.getcolors()) <= 16


def test_vein_model_intercepts_bridge_at_most_two_waste_samples():
    from vein_model import intercepts

    v = np.array([0, 6, 7, 1, 1, 8, 0, 0, 0, 9, 2, 5], float)
    # 6 7 | two waste | 8 is one run; three waste end it; 9 and 5 bridge one waste.
    assert intercepts(v) == [(1, 5), (9, 11)]
    assert intercepts(np.zeros(5)) == []
    assert intercepts(np.array([5.0])) == [(0, 0)]
