"""An independent reading of a wellmesh GLB: every body mesh is watertight and consistently
wound (trimesh), with the volume and area its summary JSON reports.

Usage: python3 tests/glb_check.py OUT.glb OUT.json   (needs `pip install trimesh numpy`)
Exits 1 on any failed check.
"""

import json
import sys

import trimesh

glb_path, summary_path = sys.argv[1], sys.argv[2]
summary = json.load(open(summary_path))
expected = [b for shell in summary["shells"] for b in shell["bodies"]]
scene = trimesh.load(glb_path, force="scene", process=False)
failures = []
bodies = []
for name, geometry in scene.geometry.items():
    if not isinstance(geometry, trimesh.Trimesh) or len(geometry.faces) == 0:
        continue  # drill-hole traces and samples
    mesh = trimesh.Trimesh(geometry.vertices, geometry.faces, process=True)
    bodies.append((name, mesh))

if len(bodies) != len(expected):
    failures.append(f"{len(bodies)} body meshes in the GLB, {len(expected)} in the summary")
volumes = sorted(abs(m.volume) for _, m in bodies)
for name, mesh in bodies:
    if not mesh.is_watertight:
        failures.append(f"{name}: not watertight")
    if not mesh.is_winding_consistent:
        failures.append(f"{name}: inconsistent winding")
    if mesh.volume <= 0:
        failures.append(f"{name}: volume {mesh.volume} is not positive (faces point inwards)")
for want in expected:
    # Match by volume: the closest body mesh.
    best = min(bodies, key=lambda nm: abs(nm[1].volume - want["volume"]), default=None)
    if best is None:
        break
    name, mesh = best
    dv = abs(mesh.volume - want["volume"]) / max(abs(want["volume"]), 1e-9)
    da = abs(mesh.area - want["area"]) / max(want["area"], 1e-9)
    if dv > 1e-6 or da > 1e-6:
        failures.append(f"{name}: volume {mesh.volume} / area {mesh.area} vs summary {want['volume']} / {want['area']}")
for f in failures:
    print("FAIL", f)
print(f"{glb_path}: {len(bodies)} bodies checked, {len(failures)} failures")
sys.exit(1 if failures else 0)
