"""The peers wellmesh is measured against, each run on the same samples (wellmesh's
desurveyed midpoints of the layout's tables, known values only) in its own process.

Usage:
  python bench/geology/peers.py TOOL LAYOUT_DIR OUT.npz [--trend DIP,DIPDIR,PITCH] [options]

TOOL:
  ferreus_iso    ferreus_rbf's RBFInterpolator: spheroidal kernel (order 3), constant drift,
                 sill = the values' variance, nugget from the down-hole variogram, isotropic
                 base range (--range, default 100 m: twice the section spacing); its own
                 isosurfacer (regularised marching tetrahedra, --resolution 5 m) over the
                 samples' box, closed at the box (BoundaryClosure.CloseNegative).
  ferreus_trend  the same with a global trend: the lens's TRUE orientation (truth.json, first
                 lens) unless --trend is given, ranges --range-trend (default 200,150,15 m:
                 major, semi-major, minor). ferreus_rbf divides the trend's ratios by their
                 geometric mean (measured: ratios 2,2,2 give the isotropic base range), so
                 the base range is the ranges' geometric mean and the ratios are the ranges
                 over it.
  scipy          scipy.interpolate.RBFInterpolator (thin-plate spline, --neighbors 50
                 nearest samples, --smoothing 1.0) on a --grid 5 m lattice over the box of
                 the samples at or above the threshold padded by 60 m; lattice points farther
                 than 60 m from every sample are set to the lowest value (no data, no ore);
                 scikit-image's marching cubes on the lattice padded by one layer of that
                 lowest value, so every surface closes.

OUT.npz holds `vertices` (V, 3) float64 in input coordinates, `faces` (F, 3) and the
parameters used (`params`, a JSON string).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from drillholes import Samples, read_tables
from truth import Truth


def downhole_nugget(s: Samples) -> float:
    """Nugget from the down-hole variogram: gamma at one and two sample spacings
    (consecutive known samples of one hole), extrapolated linearly to lag 0, within
    [0, variance]."""
    known = s.known
    v, h, d = s.values, s.hole, s.depths
    spacing = np.median(np.diff(d)[(np.diff(h) == 0)])
    gam = []
    for lag in (1, 2):
        a, b = slice(0, -lag), slice(lag, None)
        ok = (h[a] == h[b]) & known[a] & known[b] & (np.abs(d[b] - d[a] - lag * spacing)
                                                     < 0.05 * spacing)
        gam.append(0.5 * np.mean((v[b][ok] - v[a][ok]) ** 2))
    var = float(np.var(v[known]))
    return float(np.clip(2 * gam[0] - gam[1], 0.0, var))


def run_ferreus(x: np.ndarray, v: np.ndarray, threshold: float, nugget: float, base_range: float,
                resolution: float, trend=None):
    from ferreus_rbf import GlobalTrend, RBFInterpolator
    from ferreus_rbf.interpolant_config import (Drift, FittingAccuracy, FittingAccuracyType,
                                                InterpolantSettings, RBFKernelType,
                                                SpheroidalOrder)
    from ferreus_rbf.isosurfacing import BoundaryClosure

    sill = float(np.var(v))
    settings = InterpolantSettings(
        RBFKernelType.Spheroidal, spheroidal_order=SpheroidalOrder.Three, drift=Drift.Constant,
        nugget=nugget, base_range=base_range, total_sill=sill,
        fitting_accuracy=FittingAccuracy(0.01 * float(np.std(v)), FittingAccuracyType.Absolute))
    gt = None if trend is None else GlobalTrend.three(*trend)
    rbf = RBFInterpolator(x, v, settings, global_trend=gt)
    extents = np.concatenate([x.min(axis=0), x.max(axis=0)])
    mesh = rbf.build_isosurface(extents, resolution, threshold,
                                boundary_closure=BoundaryClosure.CloseNegative)
    return (np.asarray(mesh.vertices, float), np.asarray(mesh.facets, np.int64),
            dict(kernel="spheroidal order 3", drift="constant", sill=sill, nugget=nugget,
                 base_range=base_range, resolution=resolution,
                 trend=None if trend is None else dict(zip(
                     ["dip", "dip_direction", "pitch", "major_ratio", "semi_major_ratio",
                      "minor_ratio"], trend))), rbf)


def run_scipy(x: np.ndarray, v: np.ndarray, threshold: float, neighbors: int, smoothing: float,
              grid: float, kernel: str = "linear", pad: float = 60.0):
    from scipy.interpolate import RBFInterpolator
    from scipy.spatial import cKDTree
    from skimage.measure import marching_cubes

    ore = x[v >= threshold]
    if len(ore) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64), dict(note="no sample at or above")
    lo = np.maximum(ore.min(axis=0) - pad, x.min(axis=0))
    hi = np.minimum(ore.max(axis=0) + pad, x.max(axis=0))
    axes = [np.arange(lo[k], hi[k] + grid, grid) for k in range(3)]
    gx, gy, gz = np.meshgrid(*axes, indexing="ij")
    nodes = np.column_stack([gx.ravel(), gy.ravel(), gz.ravel()])
    dist, _ = cKDTree(x).query(nodes, distance_upper_bound=pad)
    near = np.isfinite(dist)
    low = float(v.min())
    field = np.full(len(nodes), low)
    rbf = RBFInterpolator(x, v, neighbors=neighbors, smoothing=smoothing, kernel=kernel)
    field[near] = rbf(nodes[near])
    vol = np.pad(field.reshape(gx.shape), 1, constant_values=low)
    if not (vol.max() >= threshold > vol.min()):
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64), {}
    verts, faces, _, _ = marching_cubes(vol, level=threshold, spacing=(grid, grid, grid))
    verts = verts - grid + lo
    # marching_cubes winds faces so normals point towards lower values' side reversed by
    # its gradient convention; split_bodies turns a soup with negative volume over.
    return verts, faces.astype(np.int64), dict(kernel=kernel, neighbors=neighbors,
                                               smoothing=smoothing, grid=grid, pad=pad,
                                               lattice=list(gx.shape),
                                               evaluated=int(near.sum()))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("tool", choices=["ferreus_iso", "ferreus_trend", "scipy"])
    ap.add_argument("layout", type=Path)
    ap.add_argument("out", type=Path)
    ap.add_argument("--range", type=float, default=100.0)
    ap.add_argument("--range-trend", default="200,150,15")
    ap.add_argument("--trend", help="DIP,DIPDIR,PITCH (default: the truth's first lens)")
    ap.add_argument("--resolution", type=float, default=5.0)
    ap.add_argument("--neighbors", type=int, default=50)
    ap.add_argument("--smoothing", type=float, default=1.0)
    ap.add_argument("--grid", type=float, default=5.0)
    ap.add_argument("--kernel", default="linear")
    args = ap.parse_args(argv)

    t0 = time.perf_counter()
    truth = Truth.load(args.layout)
    s = read_tables(args.layout / "collars.csv", args.layout / "surveys.csv",
                    args.layout / "assays.csv", truth.variable)
    known = s.known
    origin = np.round(s.positions[known].mean(axis=0))
    x, v = s.positions[known] - origin, s.values[known]
    nugget = downhole_nugget(s)
    if args.tool.startswith("ferreus"):
        trend = None
        base = args.range
        if args.tool == "ferreus_trend":
            major, semi, minor = (float(t) for t in args.range_trend.split(","))
            if args.trend:
                dip, dd, pitch = (float(t) for t in args.trend.split(","))
            else:
                lens = truth.lenses[0]
                dip, dd, pitch = lens.dip, lens.dip_direction, lens.pitch
            base = (major * semi * minor) ** (1.0 / 3.0)
            trend = (dip, dd, pitch, major / base, semi / base, minor / base)
        verts, faces, params, _ = run_ferreus(x, v, truth.threshold, nugget, base,
                                              args.resolution, trend)
    else:
        verts, faces, params = run_scipy(x, v, truth.threshold, args.neighbors, args.smoothing,
                                         args.grid, args.kernel)
    params["samples"] = int(known.sum())
    params["seconds_in_process"] = time.perf_counter() - t0
    np.savez(args.out, vertices=verts + origin, faces=faces, params=json.dumps(params))
    return 0


if __name__ == "__main__":
    sys.exit(main())
