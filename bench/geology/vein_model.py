"""A vein model of a one-lens layout, for comparison with wellmesh's kriging.

What a geologist does for a tabular body, in its simplest form: down each hole the longest
intercept at or above 5 (at most 2 waste samples bridged) gives a hanging-wall and a
footwall contact (midpoints to the neighbouring samples); in the frame of the model's plane
(wellmesh's own orientation, read from its summary) each ore hole gives the lens's centre
and thickness at the intercept, and each barren hole, where it crosses the centre plane
fitted to those, a thickness of `--barren` times the median one (negative, so the lens
closes between ore and barren holes). The centre and the thickness are interpolated over
the plane by thin-plate splines with `--smoothing`; the body is every point whose distance
across the plane from the centre is under half the thickness. IoU and volume against the
truth by Monte Carlo (1.5 million points in the truth's box widened by 60 m).

    python bench/geology/vein_model.py LAYOUT_DIR SUMMARY.json [--smoothing S] [--barren B]

For the layout `lens`: one intercept per hole is one lens (the two-lens layouts have two),
and grades are read against 5 (the flag layouts' values are 0 and 1).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from scipy.interpolate import RBFInterpolator

sys.path.insert(0, str(Path(__file__).resolve().parent))
from drillholes import read_tables  # noqa: E402
from truth import Truth, frame  # noqa: E402

THRESHOLD = 5.0
DILUTION = 2


def intercepts(values: np.ndarray, dilution: int = DILUTION) -> list[tuple[int, int]]:
    """Runs (first, last) of samples at or above the threshold down one hole, bridging at
    most `dilution` waste samples."""
    ore = values >= THRESHOLD
    runs, i, n = [], 0, len(values)
    while i < n:
        if not ore[i]:
            i += 1
            continue
        last = j = i
        while j + 1 < n:
            k = j + 1
            m = k
            while m < n and not ore[m] and m - k < dilution:
                m += 1
            if m < n and ore[m]:
                j = last = m
                continue
            break
        runs.append((i, last))
        i = last + 1
    return runs


def contacts(samples, rotation, origin):
    """Per ore hole (u, v, centre, thickness) in the plane's frame; per barren hole its
    sample positions in that frame."""
    q = (samples.positions - origin) @ rotation.T
    ore, barren = [], []
    for h in range(len(samples.hole_ids)):
        idx = np.where(samples.hole == h)[0]
        idx = idx[np.argsort(samples.depths[idx])]
        idx = idx[~np.isnan(samples.values[idx])]
        if len(idx) < 2:
            continue
        runs = intercepts(samples.values[idx])
        if not runs:
            barren.append(q[idx])
            continue
        a, b = max(runs, key=lambda r: r[1] - r[0])
        top = q[idx[a], 2] if a == 0 else 0.5 * (q[idx[a], 2] + q[idx[a - 1], 2])
        bottom = q[idx[b], 2] if b == len(idx) - 1 else 0.5 * (q[idx[b], 2] + q[idx[b + 1], 2])
        u, v = q[idx[a:b + 1], :2].mean(axis=0)
        ore.append((u, v, 0.5 * (top + bottom), abs(top - bottom)))
    return np.array(ore), barren


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("layout", type=Path)
    ap.add_argument("summary", type=Path, help="wellmesh's --summary of the same layout")
    ap.add_argument("--smoothing", type=float, default=3000.0)
    ap.add_argument("--barren", type=float, default=-1.0)
    args = ap.parse_args(argv)

    truth = Truth.load(args.layout / "truth.json")
    samples = read_tables(args.layout / "collars.csv", args.layout / "surveys.csv",
                          args.layout / "assays.csv", truth.variable)
    o = json.loads(args.summary.read_text())["model"]["orientation"]
    rotation = frame(o["dip"], o["dip_direction"], o["pitch"])
    origin = samples.positions.mean(axis=0)
    ore, barren = contacts(samples, rotation, origin)
    plane = np.linalg.lstsq(np.c_[ore[:, :2], np.ones(len(ore))], ore[:, 2], rcond=None)[0]
    thick = np.median(ore[:, 3])
    closing = []
    for q in barren:
        centre = q[:, :2] @ plane[:2] + plane[2]
        k = np.argmin(np.abs(q[:, 2] - centre))
        if abs(q[k, 2] - centre[k]) < 5.0:
            closing.append((q[k, 0], q[k, 1], centre[k], args.barren * thick))
    points = np.vstack([ore, np.array(closing).reshape(-1, 4)])
    centre = RBFInterpolator(ore[:, :2], ore[:, 2], kernel="thin_plate_spline",
                             smoothing=args.smoothing)
    thickness = RBFInterpolator(points[:, :2], points[:, 3], kernel="thin_plate_spline",
                                smoothing=args.smoothing)

    lo, hi = truth.bounds()
    lo, hi = lo - 60.0, hi + 60.0
    p = lo + np.random.default_rng(1).random((1_500_000, 3)) * (hi - lo)
    q = (p - origin) @ rotation.T
    t = thickness(q[:, :2])
    model = (t > 0) & (np.abs(q[:, 2] - centre(q[:, :2])) < t / 2)
    true = truth.contains(p)
    iou = (model & true).sum() / (model | true).sum()
    print(json.dumps({"layout": str(args.layout), "iou": round(float(iou), 4),
                      "volume_error_pct": round(100.0 * (model.sum() / true.sum() - 1.0), 2),
                      "ore_holes": len(ore), "closing_holes": len(closing),
                      "median_thickness_m": round(float(thick), 2)}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
