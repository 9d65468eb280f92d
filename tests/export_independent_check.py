"""Independent libraries read the exporters' fixture outputs.

Run after `cargo test --test export_outputs` (which keeps its outputs in
target/tmp/export/): `python3 tests/export_independent_check.py [target/tmp/export]`.
Needs `pip install trimesh pyproj shapely numpy`. Exits 1 on any failed check.

- trimesh: every body of the GLB is watertight and consistently wound, with the
  summary's volume and area.
- pyproj: the tileset's root transform puts local points where PROJ puts the same UTM
  points in ECEF (within the documented Earth-curvature error, d^2/2R).
- shapely: the GeoJSON level plans are valid polygons with the stated areas.
"""

import json
import math
import sys

import numpy as np
import pyproj
import shapely.geometry
import trimesh

folder = sys.argv[1] if len(sys.argv) > 1 else "target/tmp/export"
failures = []


def check(ok, message):
    print(("ok   " if ok else "FAIL ") + message)
    if not ok:
        failures.append(message)


summary = json.load(open(f"{folder}/nested.summary.json"))
scene = trimesh.load(f"{folder}/nested.glb", process=False)
expected = [b for shell in summary["shells"] for b in shell["bodies"]]
names = sorted(n for n in scene.graph.nodes_geometry if " body " in n)
check(len(names) == len(expected), f"{len(names)} body nodes, {len(expected)} in the summary")
for name, body in zip(names, expected):
    mesh = scene.geometry[scene.graph[name][1]]
    check(mesh.is_watertight and mesh.is_winding_consistent, f"{name}: watertight and consistently wound")
    check(abs(mesh.volume - body["volume"]) <= 1e-5 * body["volume"],
          f"{name}: volume {mesh.volume:.3f} vs summary {body['volume']:.3f}")
    check(abs(mesh.area - body["area"]) <= 1e-5 * body["area"],
          f"{name}: area {mesh.area:.3f} vs summary {body['area']:.3f}")

tileset = json.load(open(f"{folder}/tileset.json"))
matrix = np.array(tileset["root"]["transform"]).reshape(4, 4).T
origin = summary["origin"]
to_geographic = pyproj.Transformer.from_crs(summary["crs"], "EPSG:4979", always_xy=True)
to_ecef = pyproj.Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True)
for dx, dy in [(0, 0), (1000, 0), (0, 1000), (700, -700)]:
    lon, lat = to_geographic.transform(origin[0] + dx, origin[1] + dy)[:2]
    expected_ecef = np.array(to_ecef.transform(lon, lat, origin[2]))
    placed = (matrix @ np.array([dx, dy, 0.0, 1.0]))[:3]
    error = float(np.linalg.norm(placed - expected_ecef))
    allowed = 0.01 + (dx * dx + dy * dy) / (2 * 6_371_000) * 1.1
    check(error <= allowed, f"tileset: local ({dx}, {dy}, 0) is {error:.4f} m from PROJ (allowed {allowed:.4f})")

for name, exact in [("sphere-equator", math.pi * 50 ** 2), ("hollow-equator", math.pi * (40 ** 2 - 20 ** 2))]:
    plans = json.load(open(f"{folder}/{name}.geojson"))
    check(plans["crs"]["properties"]["name"] == "urn:ogc:def:crs:EPSG::32633", f"{name}: CRS named")
    for feature in plans["features"]:
        polygon = shapely.geometry.shape(feature["geometry"])
        check(polygon.is_valid and polygon.exterior.is_ccw, f"{name}: valid polygon, exterior counter-clockwise")
        check(abs(polygon.area - feature["properties"]["area"]) <= 1e-6 * polygon.area,
              f"{name}: area {polygon.area:.3f} as stated")
        check(abs(polygon.area - exact) <= 0.01 * exact, f"{name}: area {polygon.area:.1f} vs exact {exact:.1f}")

print(f"{0 if failures else 1} passed, {1 if failures else 0} failed")
sys.exit(1 if failures else 0)
