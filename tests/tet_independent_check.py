"""Independent checks of `wellmesh tetrahedralize` output, with numpy and scipy.

`python3 tests/tet_independent_check.py BIN [DIR]` builds point sets in DIR (default
target/tmp/tet-check), runs `BIN tetrahedralize SET.xyz -o SET.vtu` on each and reads the
VTU back with its own parser. Needs `pip install numpy scipy`. Exits 1 on any failed check.

The sets are those of the Delaunay benchmarks (`docs/benchmarks.md`), smaller: uniform
points in the unit cube, and drill holes sampled every metre on an exact 50 m lattice and
at UTM coordinates with jittered collars (co-planar and co-spherical everywhere).

For each set, computed here in float64 from the file alone:
- the file holds every distinct input point exactly, and only those;
- every tetrahedron has four distinct vertices and a positive volume;
- every face is shared by at most two tetrahedra;
- the volumes sum to the volume of scipy's convex hull (relative 1e-9);
- a sample of tetrahedra has empty circumspheres (no input point inside by more than a
  relative 1e-9: the lattices' co-spherical points lie on the spheres).
On uniform points (general position) also: as many tetrahedra as scipy's Delaunay (Qhull),
and as many hull faces as scipy's convex hull.
"""

import base64
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
from scipy.spatial import ConvexHull, Delaunay, cKDTree

binary = sys.argv[1] if len(sys.argv) > 1 else "target/release/wellmesh"
folder = Path(sys.argv[2] if len(sys.argv) > 2 else "target/tmp/tet-check")
folder.mkdir(parents=True, exist_ok=True)
failures = []


def check(ok, message):
    print(("ok   " if ok else "FAIL ") + message)
    if not ok:
        failures.append(message)


def well_lattice(wells, samples, utm, rng):
    cx = np.repeat(np.arange(wells) * 50.0, wells)
    cy = np.tile(np.arange(wells) * 50.0, wells)
    if utm:
        cx = 500000.0 + cx + rng.normal(0, 3, wells * wells)
        cy = 6500000.0 + cy + rng.normal(0, 3, wells * wells)
    z = 300.0 - np.arange(samples) * 1.0
    return np.stack([np.repeat(cx, samples), np.repeat(cy, samples), np.tile(z, wells * wells)], 1)


def read_vtu(path):
    text = path.read_text()
    if 'header_type="UInt64"' not in text:
        raise ValueError("expected 64-bit size headers")

    def array(name):
        m = re.search(r'<DataArray type="(\w+)" Name="%s"[^>]*>([^<]*)<' % name, text)
        dtype = {"Float64": "<f8", "Int32": "<i4", "Int64": "<i8", "UInt8": "u1"}[m.group(1)]
        raw = base64.b64decode(m.group(2).strip())
        size = int(np.frombuffer(raw[:8], "<u8")[0])
        if size != len(raw) - 8:
            raise ValueError(f"{name}: header says {size} bytes, {len(raw) - 8} follow")
        return np.frombuffer(raw[8:], dtype)

    points = array("Points").reshape(-1, 3)
    tets = array("connectivity").reshape(-1, 4).astype(np.int64)
    offsets = array("offsets")
    types = array("types")
    return points, tets, offsets, types


def rows_sorted(a):
    return a[np.lexsort(a.T[::-1])]


def check_set(name, points, general_position):
    xyz = folder / f"{name}.xyz"
    vtu = folder / f"{name}.vtu"
    np.savetxt(xyz, points, fmt="%.17g")
    run = subprocess.run([binary, "tetrahedralize", str(xyz), "-o", str(vtu)],
                         capture_output=True, text=True)
    check(run.returncode == 0, f"{name}: wellmesh exits 0 ({run.stdout.strip()}{run.stderr.strip()})")
    if run.returncode != 0:
        return
    # `%.17g` text gives back every double exactly.
    distinct = np.unique(points, axis=0)
    pts, tets, offsets, types = read_vtu(vtu)
    check(len(pts) == len(distinct) and np.array_equal(rows_sorted(pts), rows_sorted(distinct)),
          f"{name}: the file holds the {len(distinct)} distinct input points exactly")
    check(np.array_equal(offsets, 4 * np.arange(1, len(tets) + 1)) and np.all(types == 10),
          f"{name}: {len(tets)} cells, all linear tetrahedra")
    check(tets.min() >= 0 and tets.max() < len(pts), f"{name}: vertex indices in range")
    s = np.sort(tets, axis=1)
    check(bool(np.all(s[:, :3] != s[:, 1:])), f"{name}: four distinct vertices per tetrahedron")

    # Volumes about the centre of the data (at UTM coordinates the differences are exact).
    p = pts - pts.mean(axis=0)
    a, b, c, d = (p[tets[:, i]] for i in range(4))
    vol = np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a)) / 6.0
    check(bool(np.all(vol > 0)), f"{name}: every volume positive (smallest {vol.min():.3e})")
    hull = ConvexHull(p)
    rel = abs(vol.sum() - hull.volume) / hull.volume
    check(rel < 1e-9, f"{name}: volumes sum to the hull's {hull.volume:.6e} (relative difference {rel:.1e})")

    faces = np.sort(np.concatenate([tets[:, [1, 2, 3]], tets[:, [0, 2, 3]],
                                    tets[:, [0, 1, 3]], tets[:, [0, 1, 2]]]), axis=1)
    _, uses = np.unique(faces, axis=0, return_counts=True)
    check(uses.max() <= 2, f"{name}: no face in more than two tetrahedra")

    rng = np.random.default_rng(7)
    sample = rng.choice(len(tets), size=min(5000, len(tets)), replace=False)
    tree = cKDTree(p)
    inside = 0
    for t in sample:
        q = p[tets[t]]
        m = q[1:] - q[0]
        centre = np.linalg.solve(m, 0.5 * np.einsum("ij,ij->i", m, m))
        radius = np.linalg.norm(centre)
        near = tree.query_ball_point(q[0] + centre, radius * (1 - 1e-9))
        inside += len(set(near) - set(tets[t].tolist())) > 0
    check(inside == 0, f"{name}: {len(sample)} sampled circumspheres empty ({inside} not)")

    if general_position:
        qhull = Delaunay(p)
        check(len(qhull.simplices) == len(tets),
              f"{name}: {len(tets)} tetrahedra, scipy's Delaunay {len(qhull.simplices)}")
        boundary = int(np.sum(uses == 1))
        check(boundary == len(hull.simplices),
              f"{name}: {boundary} hull faces, scipy's convex hull {len(hull.simplices)}")


rng = np.random.default_rng(12345)
check_set("uniform-100k", rng.random((100000, 3)), True)
check_set("well-lattice-40x40x40", well_lattice(40, 40, False, rng), False)
check_set("utm-well-lattice-40x40x40", well_lattice(40, 40, True, rng), False)

if failures:
    print(f"{len(failures)} check(s) failed")
    sys.exit(1)
print("all tetrahedralization checks passed")
