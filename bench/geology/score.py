"""Scores a modelled ore body against a layout's known truth.

Usage:
  python bench/geology/score.py LAYOUT_DIR MODEL.(glb|obj|ply|stl) [--json OUT.json]

A GLB is read as wellmesh writes it (Y-up, positions relative to the scene's
extras.origin); other meshes are taken in input coordinates and split into bodies by
connected components. Figures (see README.md for the protocol):

  iou            |truth & model| / |truth | model|: exact booleans (manifold3d) of the
                 model's bodies with a tessellation of the true ellipsoids (icosphere level 6,
                 81,920 triangles a lens, scaled to the exact volume) when every body is a
                 closed oriented manifold; otherwise (iou_method 'monte-carlo') the
                 intersection is the exact true volume times the share of points drawn
                 uniformly inside the true lenses that fall inside the model (ray parity),
                 with its standard error. The Monte-Carlo figure is always reported too
                 (iou_mc, iou_mc_se) as a check.
  volume_error_pct  100 (V_model - V_true) / V_true
  bodies, closed_bodies, lens_bodies (bodies overlapping each true lens), stray_bodies
                 (bodies overlapping no lens)
  area, area_true, area_ratio
  slivers_pct    share of triangles whose smallest angle is under 10 degrees
  max_dist_to_sample, p99_dist_to_sample   distance from surface points (vertices and
                 triangle centroids) to the nearest known sample
  iou_at_holes   the same ratio counted over the known assays' positions only: inside the
                 truth vs inside the model, at the holes themselves
  iou_at_holes_assays, assay_window   what the assays alone say there: each hole's running
                 mean over WINDOW assays (1, 3, 5 or 7, the best) at or above the threshold,
                 against the truth. With noisy 1.5 m assays this is the ceiling a smoother
                 of the assays reaches on the holes; a model close to it between the holes
                 loses little to interpolation (README, *What limits the figures*)
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from drillholes import read_tables
from meshes import (Body, RayParity, is_closed, min_angles_deg, read_surface, signed_volume,
                    triangle_areas)
from truth import Truth

SLIVER_DEG = 10.0
MC_POINTS = 400_000
TRUTH_LEVEL = 6


def layout_samples(layout: Path, truth: Truth):
    """Desurveyed samples of a layout's tables (wellmesh's positions)."""
    return read_tables(layout / "collars.csv", layout / "surveys.csv", layout / "assays.csv",
                       truth.variable)


def uniform_in_lenses(truth: Truth, n: int, rng) -> tuple[np.ndarray, np.ndarray]:
    """n points uniform in the union of the (disjoint) true lenses, and each one's lens."""
    vols = np.array([l.volume for l in truth.lenses])
    counts = rng.multinomial(n, vols / vols.sum())
    pts, which = [], []
    for i, (lens, k) in enumerate(zip(truth.lenses, counts)):
        d = rng.standard_normal((k, 3))
        d /= np.linalg.norm(d, axis=1)[:, None]
        u = d * rng.random(k)[:, None] ** (1.0 / 3.0) * np.asarray(lens.semi_axes)
        pts.append(u @ lens.rotation + np.asarray(lens.centre))
        which.append(np.full(k, i))
    return np.vstack(pts), np.concatenate(which)


def _manifold(vertices: np.ndarray, faces: np.ndarray):
    import manifold3d as m3

    mesh = m3.Mesh64(vert_properties=np.ascontiguousarray(vertices, np.float64),
                     tri_verts=np.ascontiguousarray(faces, np.uint64))
    m = m3.Manifold(mesh)
    return m, str(m.status())


_TRUTH_MANIFOLDS: dict = {}


def truth_manifolds(truth: Truth, origin: np.ndarray):
    """The true lenses as manifold3d solids relative to `origin` (kept for the next call
    on the same layout)."""
    key = (truth.layout, truth.seed, tuple(origin))
    if key not in _TRUTH_MANIFOLDS:
        lenses = []
        for v, f in truth.lens_meshes(TRUTH_LEVEL, origin):
            m, status = _manifold(v, f)
            if "NoError" not in status:
                raise RuntimeError(f"truth mesh is not a manifold: {status}")
            lenses.append(m)
        _TRUTH_MANIFOLDS.clear()
        _TRUTH_MANIFOLDS[key] = lenses
    return _TRUTH_MANIFOLDS[key]


def exact_overlaps(truth: Truth, bodies: list[Body], origin: np.ndarray):
    """Exact volumes by manifold3d: (union volume, intersection with the truth, per body
    per lens intersection volumes), or None with the reason when a body is not a valid
    manifold."""
    import manifold3d as m3

    ms = []
    for i, b in enumerate(bodies):
        m, status = _manifold(b.vertices - origin, b.faces)
        if "NoError" not in status:
            return None, f"body {i + 1}: {status}"
        ms.append(m)
    lenses = truth_manifolds(truth, origin)
    boxes = [l.bounds() for l in truth.lenses]
    union = m3.Manifold.batch_boolean(ms, m3.OpType.Add) if ms else m3.Manifold()
    true_union = m3.Manifold.batch_boolean(lenses, m3.OpType.Add)
    inter = (union ^ true_union).volume() if ms else 0.0
    per = np.zeros((len(ms), len(lenses)))
    for i, (b, m) in enumerate(zip(bodies, ms)):
        lo, hi = b.vertices.min(axis=0), b.vertices.max(axis=0)
        for k, (l, (llo, lhi)) in enumerate(zip(lenses, boxes)):
            if np.all(lo <= lhi) and np.all(llo <= hi):
                per[i, k] = (m ^ l).volume()
    return (union.volume(), inter, per), None


ASSAY_WINDOWS = (1, 3, 5, 7)


def assays_at_holes(truth: Truth, assays) -> tuple[float, int]:
    """The best IoU with the truth, over the known assays' positions, of a running mean of
    each hole's assays (window of ASSAY_WINDOWS samples, edges padded with the end value)
    at or above the threshold; and that window."""
    known = assays.known
    true_in = truth.contains(assays.positions) & known
    best = (0.0, 1)
    for w in ASSAY_WINDOWS:
        ore = np.zeros(len(known), bool)
        for h in np.unique(assays.hole):
            idx = np.nonzero((assays.hole == h) & known)[0]
            v = assays.values[idx]
            if w > 1:
                v = np.convolve(np.pad(v, w // 2, mode="edge"), np.ones(w) / w, mode="valid")
            ore[idx] = v >= truth.threshold
        union = (true_in | ore).sum()
        iou = float((true_in & ore).sum() / union) if union else 0.0
        best = max(best, (iou, w))
    return best


def score(truth: Truth, bodies: list[Body], samples: np.ndarray | None,
          mc_points: int = MC_POINTS, seed: int = 12345, assays=None) -> dict:
    """All figures for `bodies` (input coordinates) against `truth`; `samples` (N, 3) are
    the known sample positions for the distance figure; `assays` (drillholes.Samples), when
    given, adds the figures at the holes."""
    bodies = [b for b in bodies if len(b.faces)]
    lo, hi = truth.bounds()
    origin = np.round((lo + hi) / 2.0)
    out: dict = {"volume_true": truth.volume, "area_true": truth.area,
                 "lenses": len(truth.lenses)}
    closed = [is_closed(b.faces) for b in bodies]
    volumes = [signed_volume(b.vertices - origin, b.faces) for b in bodies]
    out["bodies"] = len(bodies)
    out["closed_bodies"] = int(sum(closed))
    out["triangles"] = int(sum(len(b.faces) for b in bodies))
    area = float(sum(triangle_areas(b.vertices - origin, b.faces).sum() for b in bodies))
    out["area"] = area
    out["area_ratio"] = area / truth.area
    if out["triangles"]:
        angles = np.concatenate([min_angles_deg(b.vertices - origin, b.faces) for b in bodies])
        out["slivers_pct"] = 100.0 * float(np.mean(angles < SLIVER_DEG))
    else:
        out["slivers_pct"] = None

    # Monte-Carlo: points uniform in the true lenses, tested against every body at once.
    rng = np.random.default_rng(seed)
    pts, which = uniform_in_lenses(truth, mc_points, rng)
    if bodies:
        verts = np.vstack([b.vertices for b in bodies])
        offs = np.cumsum([0] + [len(b.vertices) for b in bodies])
        faces = np.vstack([b.faces + o for b, o in zip(bodies, offs)])
        labels = np.concatenate([np.full(len(b.faces), i) for i, b in enumerate(bodies)])
        rp = RayParity(verts - origin, faces, labels, origin=np.zeros(3))
        inside = rp.inside(pts - origin)
    else:
        inside = np.zeros((len(pts), 0), bool)
    hit = inside.any(axis=1)
    p = float(hit.mean())
    inter_mc = truth.volume * p
    inter_se = truth.volume * math.sqrt(max(p * (1 - p), 1e-300) / len(pts))
    if all(closed):
        model_vol = float(sum(volumes))
        model_se = 0.0
    else:
        model_vol, model_se = _mc_volume(bodies, rng, mc_points, origin)
    union_mc = truth.volume + model_vol - inter_mc
    iou_mc = inter_mc / union_mc if union_mc > 0 else 0.0
    # dIoU = (V_T + V_M) / U^2 dI - I / U^2 dV_M (independent errors)
    iou_mc_se = math.hypot((truth.volume + model_vol) / union_mc ** 2 * inter_se,
                           inter_mc / union_mc ** 2 * model_se) if union_mc > 0 else 0.0
    out["iou_mc"], out["iou_mc_se"] = iou_mc, iou_mc_se

    exact, why = (None, "a body is not closed") if not all(closed) else exact_overlaps(
        truth, bodies, origin)
    if exact is not None:
        model_vol, inter, per = exact
        out["iou"] = inter / (truth.volume + model_vol - inter)
        out["iou_method"] = "manifold"
        overlap = per > 1e-9 * truth.volume
    else:
        out["iou"], out["iou_method"], out["iou_se"] = iou_mc, "monte-carlo", iou_mc_se
        out["manifold_refused"] = why
        overlap = np.zeros((len(bodies), len(truth.lenses)), bool)
        for k in range(len(truth.lenses)):
            overlap[:, k] = inside[which == k].any(axis=0)
    out["volume"] = model_vol
    out["volume_error_pct"] = 100.0 * (model_vol - truth.volume) / truth.volume
    out["lens_bodies"] = overlap.sum(axis=0).astype(int).tolist()
    out["stray_bodies"] = int((~overlap.any(axis=1)).sum()) if len(bodies) else 0

    if samples is not None and bodies:
        tree = cKDTree(samples - origin)
        probe = [np.vstack([b.vertices - origin, (b.vertices - origin)[b.faces].mean(axis=1)])
                 for b in bodies]
        d, _ = tree.query(np.vstack(probe))
        out["max_dist_to_sample"] = float(d.max())
        out["p99_dist_to_sample"] = float(np.percentile(d, 99))
    if assays is not None:
        at = assays.positions[assays.known]
        true_in = truth.contains(at)
        model_in = (rp.inside(at - origin).any(axis=1) if bodies
                    else np.zeros(len(at), bool))
        union = (true_in | model_in).sum()
        out["iou_at_holes"] = float((true_in & model_in).sum() / union) if union else 0.0
        out["iou_at_holes_assays"], out["assay_window"] = assays_at_holes(truth, assays)
    return out


def _mc_volume(bodies: list[Body], rng, n: int, origin: np.ndarray) -> tuple[float, float]:
    """Volume inside an open model by ray parity over its bounding box, with the standard
    error."""
    verts = np.vstack([b.vertices for b in bodies]) - origin
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    offs = np.cumsum([0] + [len(b.vertices) for b in bodies])
    faces = np.vstack([b.faces + o for b, o in zip(bodies, offs)])
    rp = RayParity(verts, faces, origin=np.zeros(3))
    pts = lo + rng.random((n, 3)) * (hi - lo)
    share = float(rp.inside(pts)[:, 0].mean())
    box = float(np.prod(hi - lo))
    return box * share, box * math.sqrt(max(share * (1 - share), 1e-300) / n)


def check_desurvey(samples: np.ndarray, glb_samples: np.ndarray) -> dict:
    """How far the GLB's sample points lie from our desurveyed positions (both ways)."""
    a = cKDTree(samples).query(glb_samples)[0]
    b = cKDTree(glb_samples).query(samples)[0]
    return {"glb_points": len(glb_samples), "our_points": len(samples),
            "max_glb_to_ours_m": float(a.max()), "max_ours_to_glb_m": float(b.max())}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("layout", type=Path)
    ap.add_argument("model", type=Path)
    ap.add_argument("--json", type=Path)
    ap.add_argument("--mc-points", type=int, default=MC_POINTS)
    args = ap.parse_args(argv)
    truth = Truth.load(args.layout)
    surface = read_surface(args.model)
    s = layout_samples(args.layout, truth)
    result = score(truth, surface.bodies, s.positions[s.known], args.mc_points, assays=s)
    if surface.samples is not None:
        result["desurvey_check"] = check_desurvey(s.positions, surface.samples)
    text = json.dumps(result, indent=1)
    if args.json:
        args.json.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
