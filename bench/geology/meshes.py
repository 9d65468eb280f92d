"""Reading surfaces (wellmesh's GLB, OBJ/PLY/STL) into bodies, and the mesh measures the
benchmark reports: closedness, area, slivers, signed volume, point-in-mesh by ray parity.

Invariant: every position returned is in the input's coordinates (easting, northing,
elevation), float64. A GLB is Y-up glTF: a position (X, Y, Z) relative to the scene's
`extras.origin` is the point origin + (X, -Z, Y) (docs/export.md); node transforms are
applied. Triangle primitives are bodies; POINTS (samples) and LINES (drill holes) are
returned apart and never scored.
"""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

COMPONENT = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32,
             5126: np.float32}
WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


@dataclass
class Body:
    """One closed (or not) triangle mesh: vertices (V, 3) input coordinates, faces (F, 3)."""

    vertices: np.ndarray
    faces: np.ndarray
    name: str = ""
    extras: dict = field(default_factory=dict)


@dataclass
class Surface:
    bodies: list[Body]
    origin: np.ndarray
    samples: np.ndarray | None = None  # (N, 3) sample points carried by a GLB
    extras: dict = field(default_factory=dict)
    segments: np.ndarray | None = None  # (S, 2, 3) drill-hole trace segments of a GLB


def _accessor(doc: dict, binary: bytes, index: int) -> np.ndarray:
    acc = doc["accessors"][index]
    view = doc["bufferViews"][acc["bufferView"]]
    dtype = np.dtype(COMPONENT[acc["componentType"]]).newbyteorder("<")
    width = WIDTH[acc["type"]]
    offset = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    stride = view.get("byteStride", 0)
    count = acc["count"]
    if stride and stride != dtype.itemsize * width:
        rows = [np.frombuffer(binary, dtype, width, offset + i * stride) for i in range(count)]
        return np.array(rows)
    data = np.frombuffer(binary, dtype, count * width, offset)
    return data.reshape(count, width) if width > 1 else data


def _quat_matrix(q):
    x, y, z, w = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def _node_matrix(node: dict) -> np.ndarray:
    if "matrix" in node:
        return np.array(node["matrix"], float).reshape(4, 4).T
    m = np.eye(4)
    s = np.diag(node.get("scale", [1.0, 1.0, 1.0]))
    r = _quat_matrix(node.get("rotation", [0.0, 0.0, 0.0, 1.0]))
    m[:3, :3] = r @ s
    m[:3, 3] = node.get("translation", [0.0, 0.0, 0.0])
    return m


def read_glb(path: str | Path) -> Surface:
    """Bodies (triangle primitives), sample points (POINTS primitives) and the origin of a
    wellmesh GLB, in input coordinates."""
    data = Path(path).read_bytes()
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    if magic != b"glTF" or version != 2:
        raise ValueError(f"{path}: not a glTF 2.0 binary")
    offset, doc, binary = 12, None, b""
    while offset < length:
        chunk_len, chunk_type = struct.unpack_from("<II", data, offset)
        chunk = data[offset + 8: offset + 8 + chunk_len]
        if chunk_type == 0x4E4F534A:
            doc = json.loads(chunk)
        elif chunk_type == 0x004E4942:
            binary = chunk
        offset += 8 + chunk_len
    if doc is None:
        raise ValueError(f"{path}: no JSON chunk")
    scene = doc["scenes"][doc.get("scene", 0)]
    extras = scene.get("extras", {})
    origin = np.array(extras.get("origin", [0.0, 0.0, 0.0]), float)

    def to_input(p):
        # glTF (X, Y, Z) = (east, up, -north): local (x, y, z) = (X, -Z, Y).
        return origin + np.stack([p[:, 0], -p[:, 2], p[:, 1]], axis=1)

    bodies, samples, segments = [], [], []
    stack = [(n, np.eye(4)) for n in scene.get("nodes", [])]
    while stack:
        index, parent = stack.pop()
        node = doc["nodes"][index]
        m = parent @ _node_matrix(node)
        for child in node.get("children", []):
            stack.append((child, m))
        if "mesh" not in node:
            continue
        mesh = doc["meshes"][node["mesh"]]
        for prim in mesh["primitives"]:
            mode = prim.get("mode", 4)
            pos = _accessor(doc, binary, prim["attributes"]["POSITION"]).astype(np.float64)
            pos = pos @ m[:3, :3].T + m[:3, 3]
            if mode == 4:
                if "indices" in prim:
                    idx = _accessor(doc, binary, prim["indices"]).astype(np.int64).reshape(-1, 3)
                else:
                    idx = np.arange(len(pos)).reshape(-1, 3)
                if np.linalg.det(m[:3, :3]) < 0:
                    idx = idx[:, ::-1]
                bodies.append(Body(to_input(pos), idx, node.get("name", mesh.get("name", "")),
                                   node.get("extras", mesh.get("extras", {}))))
            elif mode == 0:
                samples.append(to_input(pos))
            elif mode == 1:
                p = to_input(pos)
                if "indices" in prim:
                    idx = _accessor(doc, binary, prim["indices"]).astype(np.int64).reshape(-1, 2)
                else:
                    idx = np.arange(len(p) - len(p) % 2).reshape(-1, 2)
                segments.append(p[idx])
    bodies.sort(key=lambda b: (b.extras.get("shell", 0), b.extras.get("body", 0), b.name))
    return Surface(bodies, origin, np.vstack(samples) if samples else None, extras,
                   np.vstack(segments) if segments else None)


def read_surface(path: str | Path) -> Surface:
    """A GLB (wellmesh's axes and origin) or any mesh trimesh reads (OBJ, PLY, STL, ...) in
    input coordinates; the latter is split into bodies by connected components."""
    path = Path(path)
    if path.suffix.lower() == ".glb":
        return read_glb(path)
    import trimesh

    loaded = trimesh.load(path, force="mesh", process=False)
    vertices = np.asarray(loaded.vertices, float)
    faces = np.asarray(loaded.faces, np.int64)
    return Surface(split_bodies(vertices, faces), np.zeros(3))


def weld(vertices: np.ndarray, faces: np.ndarray, tol: float = 0.0):
    """Merges vertices with identical (or, with tol > 0, grid-snapped) coordinates."""
    key = vertices if tol <= 0 else np.round(vertices / tol)
    uniq, inverse = np.unique(key, axis=0, return_inverse=True)
    first = np.zeros(len(uniq), np.int64)
    first[inverse[::-1]] = np.arange(len(vertices))[::-1]
    return vertices[first], inverse.reshape(-1)[faces]


def components(faces: np.ndarray, n_vertices: int) -> np.ndarray:
    """Connected component label of each face (faces sharing a vertex are connected)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    f = len(faces)
    rows = np.repeat(np.arange(f), 3)
    g = coo_matrix((np.ones(3 * f), (rows, faces.reshape(-1) + f)), shape=(f + n_vertices,) * 2)
    _, labels = connected_components(g, directed=False)
    return labels[:f]


def split_bodies(vertices: np.ndarray, faces: np.ndarray, orient: bool = True) -> list[Body]:
    """Bodies of a triangle soup: welded, split into connected components; a component of
    negative signed volume (a cavity) joins the smallest positive component around it.
    With `orient`, a soup whose total signed volume is negative (faces wound inwards, as
    some isosurfacers write them) is turned over first."""
    if len(faces) == 0:
        return []
    vertices, faces = weld(vertices, faces)
    if orient and signed_volume(vertices, faces) < 0:
        faces = faces[:, ::-1]
    labels = components(faces, len(vertices))
    parts = []
    for lab in np.unique(labels):
        f = faces[labels == lab]
        parts.append((f, signed_volume(vertices, f)))
    outer = [p for p in parts if p[1] >= 0]
    bodies = [[p[0]] for p in outer]
    for f, vol in parts:
        if vol >= 0:
            continue
        # the smallest outer part whose box holds the cavity's box
        lo, hi = vertices[f].min(0), vertices[f].max(0)
        best, best_vol = None, np.inf
        for i, (of, ov) in enumerate(outer):
            olo, ohi = vertices[of].min(0), vertices[of].max(0)
            if np.all(olo <= lo) and np.all(ohi >= hi) and ov < best_vol:
                best, best_vol = i, ov
        if best is None:
            bodies.append([f])
        else:
            bodies[best].append(f)
    out = []
    for i, fs in enumerate(bodies):
        f = np.vstack(fs)
        used = np.unique(f)
        remap = np.full(len(vertices), -1)
        remap[used] = np.arange(len(used))
        out.append(Body(vertices[used], remap[f], f"component {i + 1}"))
    return out


def signed_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    if len(faces) == 0:
        return 0.0
    c = vertices[faces].mean(axis=(0, 1))
    a, b, d = (vertices[faces[:, k]] - c for k in range(3))
    return float(np.einsum("ij,ij->i", a, np.cross(b, d)).sum() / 6.0)


def triangle_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)


def min_angles_deg(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Smallest interior angle of each triangle, degrees (0 for degenerate ones)."""
    p = [vertices[faces[:, k]] for k in range(3)]
    angles = []
    for k in range(3):
        u = p[(k + 1) % 3] - p[k]
        v = p[(k + 2) % 3] - p[k]
        nu, nv = np.linalg.norm(u, axis=1), np.linalg.norm(v, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            cos = np.einsum("ij,ij->i", u, v) / (nu * nv)
        angles.append(np.degrees(np.arccos(np.clip(np.nan_to_num(cos, nan=1.0), -1, 1))))
    return np.min(angles, axis=0)


def is_closed(faces: np.ndarray) -> bool:
    """Closed and consistently oriented: every directed edge once, its reverse once."""
    if len(faces) == 0:
        return False
    e = np.vstack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    directed = e[:, 0] * (faces.max() + 1) + e[:, 1]
    reverse = e[:, 1] * (faces.max() + 1) + e[:, 0]
    uniq, counts = np.unique(directed, return_counts=True)
    if np.any(counts != 1):
        return False
    return bool(np.all(np.isin(reverse, uniq)))


class RayParity:
    """Point-in-mesh by the parity of a vertical ray's crossings, triangles bucketed on a
    2D grid. `inside(points)` gives, for several meshes at once (each face labelled by its
    mesh), which mesh holds each point: an (N, M) boolean array. Exact for closed meshes
    except on a measure-zero set (rays through an edge or vertex)."""

    @staticmethod
    def _coefficients(tri: np.ndarray, area2: np.ndarray) -> np.ndarray:
        """Per triangle, the three edge functions w_k = A x + B y + C (the barycentric
        weights times |twice the projected area|, non-negative inside) and the plane
        z = D x + E y + F, as 12 columns."""
        s = np.sign(area2)
        co = np.empty((len(tri), 12))
        for k in range(3):
            (x1, y1), (x2, y2) = tri[:, (k + 1) % 3, :2].T, tri[:, (k + 2) % 3, :2].T
            co[:, 3 * k] = (y1 - y2) * s
            co[:, 3 * k + 1] = (x2 - x1) * s
            co[:, 3 * k + 2] = (x1 * y2 - x2 * y1) * s
        a = np.abs(area2)
        for j in range(3):
            co[:, 9 + j] = sum(co[:, 3 * k + j] * tri[:, k, 2] for k in range(3)) / a
        return co

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, labels: np.ndarray | None = None,
                 origin: np.ndarray | None = None):
        self.origin = vertices.mean(axis=0) if origin is None else origin
        v = vertices - self.origin
        tri = v[faces]  # (F, 3, 3)
        area2 = ((tri[:, 1, 0] - tri[:, 0, 0]) * (tri[:, 2, 1] - tri[:, 0, 1])
                 - (tri[:, 2, 0] - tri[:, 0, 0]) * (tri[:, 1, 1] - tri[:, 0, 1]))
        keep = np.abs(area2) > 0
        self.tri = tri[keep]
        self.area2 = area2[keep]
        self.coef = self._coefficients(self.tri, self.area2)
        self.labels = (np.zeros(len(faces), np.int64) if labels is None else labels)[keep]
        self.count = 1 if labels is None else int(labels.max()) + 1 if len(labels) else 1
        lo = self.tri[:, :, :2].min(axis=1)
        hi = self.tri[:, :, :2].max(axis=1)
        self.lo_all = lo.min(axis=0) if len(lo) else np.zeros(2)
        hi_all = hi.max(axis=0) if len(hi) else np.ones(2)
        extent = np.maximum(hi_all - self.lo_all, 1e-9)
        mean_size = np.median(hi - lo, axis=0).max() if len(lo) else 1.0
        self.h = max(mean_size, float(np.sqrt(extent[0] * extent[1] / max(len(lo), 1))), 1e-6)
        self.shape = np.ceil(extent / self.h).astype(np.int64) + 1
        i0 = np.floor((lo - self.lo_all) / self.h).astype(np.int64)
        i1 = np.floor((hi - self.lo_all) / self.h).astype(np.int64)
        nx, ny = i1[:, 0] - i0[:, 0] + 1, i1[:, 1] - i0[:, 1] + 1
        n = nx * ny
        t = np.repeat(np.arange(len(n)), n)
        k = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)
        cx = i0[t, 0] + k % nx[t]
        cy = i0[t, 1] + k // nx[t]
        cell = cx * self.shape[1] + cy
        order = np.argsort(cell, kind="stable")
        self.cell_tris = t[order]
        self.starts = np.searchsorted(cell[order], np.arange(self.shape[0] * self.shape[1] + 1))

    def inside(self, points: np.ndarray) -> np.ndarray:
        q = np.asarray(points, float) - self.origin
        res = np.zeros((len(q), self.count), bool)
        c = np.floor((q[:, :2] - self.lo_all) / self.h).astype(np.int64)
        valid = np.all((c >= 0) & (c < self.shape), axis=1)
        qi = np.nonzero(valid)[0]
        cell = c[valid, 0] * self.shape[1] + c[valid, 1]
        order = np.argsort(cell, kind="stable")
        qi, cell = qi[order], cell[order]
        cuts = np.flatnonzero(np.diff(cell)) + 1
        for grp in np.split(np.arange(len(qi)), cuts):
            if len(grp) == 0:
                continue
            k = cell[grp[0]]
            tris = self.cell_tris[self.starts[k]:self.starts[k + 1]]
            if len(tris) == 0:
                continue
            idx = qi[grp]
            x, y, z = q[idx, 0:1], q[idx, 1:2], q[idx, 2:3]
            co = self.coef[tris]  # (t, 12): three edge functions and the plane, A x + B y + C
            hit = np.ones((len(idx), len(tris)), bool)
            for e in range(3):
                hit &= co[:, 3 * e] * x + co[:, 3 * e + 1] * y + co[:, 3 * e + 2] >= 0
            hit &= co[:, 9] * x + co[:, 10] * y + co[:, 11] > z
            if self.count == 1:
                res[idx, 0] = hit.sum(axis=1) % 2 == 1
            else:
                rows, cols = np.nonzero(hit)
                key = rows * self.count + self.labels[tris[cols]]
                odd = np.bincount(key, minlength=len(idx) * self.count) % 2 == 1
                res[idx] = odd.reshape(len(idx), self.count)
        return res
