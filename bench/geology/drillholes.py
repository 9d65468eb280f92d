"""Drill-hole tables as wellmesh reads them: collar/survey/interval CSVs, desurveyed by
minimum curvature, with one sample at each interval's midpoint and a don't-know sample in
every gap.

Invariant: `read_tables` places every sample where `wellmesh contour` places it (the same
rules as `src/wells/drillhole.rs` and `src/wells/desurvey.rs`: interval sorting, duplicate
and overlap resolution, dip-sign detection, stations past the end of the hole dropped,
straight extension above the first and below the last station), so the peers and the
held-out checks use exactly wellmesh's sample positions. `check_desurvey` in score.py
verifies this against the sample points a GLB carries.
"""

from __future__ import annotations

import csv
import io
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

TINY_ANGLE = 1e-9
NEAR_PI = math.pi - 1e-6

UNKNOWN_TOKENS = {
    "", "na", "n/a", "nan", "?", "null", "none", "-", "--", "ns", "nr", "lnr", "is", "nodata",
}

ALIASES = {
    "hole": ["holeid", "hole", "bhid", "dhid", "drillholeid", "drillhole", "holename", "well",
             "wellid", "wellname", "name", "id"],
    "x": ["x", "easting", "east", "xcollar", "xmga", "xutm", "utmx", "e", "xcoord", "eutm"],
    "y": ["y", "northing", "north", "ycollar", "ymga", "yutm", "utmy", "n", "ycoord", "nutm"],
    "z": ["z", "elevation", "elev", "rl", "zcollar", "zmga", "zutm", "collarrl", "altitude",
          "height"],
    "length": ["depth", "length", "maxdepth", "totaldepth", "eoh", "td"],
    "survey_depth": ["depth", "at", "md", "surveydepth", "distance", "depthm", "surveyat"],
    "azimuth": ["azimuth", "az", "azi", "brg", "bearing", "azim"],
    "dip": ["dip", "surveydip"],
    "from": ["from", "depthfrom", "fromdepth", "fromm", "mfrom", "start", "top", "depthtop"],
    "to": ["to", "depthto", "todepth", "tom", "mto", "end", "bottom", "depthbottom"],
}


def _norm(name: str) -> str:
    return re.sub(r"[^a-z0-9]", "", name.lower())


class TableError(ValueError):
    """A table that cannot be read; the message names the file, line or column."""


@dataclass
class Table:
    file: str
    headers: list[str]
    rows: list[tuple[int, list[str]]]  # (1-based file line, fields)

    @classmethod
    def read(cls, path: str | Path) -> "Table":
        text = Path(path).read_bytes().decode("utf-8", errors="replace").lstrip("\ufeff")
        first = text.splitlines()[0] if text else ""
        delimiter = max([",", ";", "\t"], key=first.count)
        reader = csv.reader(io.StringIO(text), delimiter=delimiter)
        rows = list(reader)
        if not rows:
            raise TableError(f"{path}: empty file")
        out = []
        for i, r in enumerate(rows[1:], start=2):
            if all(not f.strip() for f in r):
                continue
            out.append((i, r))
        return cls(str(path), rows[0], out)

    def column(self, kind: str, required: bool = True, exclude: tuple[int, ...] = ()) -> int | None:
        normed = [_norm(h) for h in self.headers]
        for alias in ALIASES[kind]:
            for i, h in enumerate(normed):
                if h == alias and i not in exclude:
                    return i
        if required:
            raise TableError(f"{self.file}: no {kind} column among {self.headers}")
        return None

    def named(self, name: str) -> int:
        want = _norm(name)
        for i, h in enumerate(self.headers):
            if _norm(h) == want:
                return i
        raise TableError(f"{self.file}: no column '{name}' among {self.headers}")

    @staticmethod
    def field(row: list[str], i: int) -> str:
        return row[i].strip() if i < len(row) else ""

    def number(self, line: int, row: list[str], i: int) -> float | None:
        text = self.field(row, i)
        if text == "":
            return None
        try:
            value = float(text)
        except ValueError:
            raise TableError(f"{self.file} line {line} column {self.headers[i]}: '{text}' is not a number")
        if not math.isfinite(value):
            raise TableError(f"{self.file} line {line} column {self.headers[i]}: '{text}' is not finite")
        return value


def read_value(text: str, negative_is_below: bool = True) -> float | None:
    """A grade as wellmesh reads it from an interval table: don't-know tokens are None,
    '<x' and negative numbers are below detection (half the limit), '>x' is x."""
    t = text.strip()
    if t.lower() in UNKNOWN_TOKENS:
        return None
    if t.startswith("<"):
        return float(t[1:]) * 0.5
    if t.startswith(">"):
        return float(t[1:])
    v = float(t)
    if not math.isfinite(v):
        return None
    if v < 0 and negative_is_below:
        return -v * 0.5
    return v


def direction(azimuth_deg, dip_down_deg):
    """Unit direction(s): x east, y north, z up; dip_down positive below horizontal."""
    az = np.radians(azimuth_deg)
    dip = np.radians(dip_down_deg)
    return np.stack([np.sin(az) * np.cos(dip), np.cos(az) * np.cos(dip), -np.sin(dip)], axis=-1)


def _dogleg(t1, t2):
    return 2.0 * np.arcsin(np.clip(np.linalg.norm(t2 - t1, axis=-1) * 0.5, 0.0, 1.0))


class Trajectory:
    """A hole desurveyed by minimum curvature: `position(depths)` relative to the collar."""

    def __init__(self, depths, azimuths, dips_down):
        depths = np.asarray(depths, float)
        if len(depths) == 0:
            self.depths = np.array([0.0])
            self.dirs = np.array([[0.0, 0.0, -1.0]])
            self.pos = np.zeros((1, 3))
            return
        dirs = direction(np.asarray(azimuths, float), np.asarray(dips_down, float))
        if depths[0] > 0.0:
            depths = np.concatenate([[0.0], depths])
            dirs = np.vstack([dirs[:1], dirs])
        pos = np.zeros((len(depths), 3))
        pos[0] = dirs[0] * depths[0] if depths[0] < 0.0 else 0.0
        for i in range(1, len(depths)):
            t1, t2 = dirs[i - 1], dirs[i]
            length = depths[i] - depths[i - 1]
            beta = float(_dogleg(t1, t2))
            if beta > NEAR_PI:
                step = (t1 + t2) * (length * 0.5)
            else:
                ratio = 1.0 if beta < TINY_ANGLE else math.tan(beta * 0.5) / (beta * 0.5)
                step = (t1 + t2) * (length * 0.5 * ratio)
            pos[i] = pos[i - 1] + step
        self.depths, self.dirs, self.pos = depths, dirs, pos

    def position(self, depth):
        """Positions (N, 3) at measured depths (N,), relative to the collar."""
        depth = np.atleast_1d(np.asarray(depth, float))
        d, dirs, pos = self.depths, self.dirs, self.pos
        out = np.empty((len(depth), 3))
        above = depth <= d[0]
        below = depth >= d[-1]
        out[above] = pos[0] + dirs[0] * (depth[above] - d[0])[:, None]
        out[below] = pos[-1] + dirs[-1] * (depth[below] - d[-1])[:, None]
        mid = ~(above | below)
        if mid.any():
            dm = depth[mid]
            i = np.searchsorted(d, dm, side="right") - 1
            t1, t2 = dirs[i], dirs[i + 1]
            length = dm - d[i]
            total = d[i + 1] - d[i]
            beta = _dogleg(t1, t2)
            f = length / total
            step = np.empty((len(dm), 3))
            straight = beta < TINY_ANGLE
            step[straight] = (t1[straight] + t2[straight]) * (length[straight] * 0.5)[:, None]
            rev = beta > NEAR_PI
            if rev.any():
                half = total[rev] * 0.5
                step[rev] = (t1[rev] * np.minimum(length[rev], half)[:, None]
                             + t2[rev] * np.maximum(length[rev] - half, 0.0)[:, None])
            arc = ~(straight | rev)
            if arc.any():
                b, fa = beta[arc], f[arc]
                tf = (t1[arc] * np.sin((1 - fa) * b)[:, None] + t2[arc] * np.sin(fa * b)[:, None]) \
                    / np.sin(b)[:, None]
                n = np.linalg.norm(tf, axis=1)
                ok = np.isfinite(n) & (n > 0)
                tf[ok] /= n[ok][:, None]
                tf[~ok] = t1[arc][~ok]
                fb = fa * b
                ratio = np.where(fb < TINY_ANGLE, 1.0, np.tan(fb * 0.5) / np.maximum(fb * 0.5, 1e-300))
                step[arc] = (t1[arc] + tf) * (length[arc] * 0.5 * ratio)[:, None]
            out[mid] = pos[i] + step
        return out


@dataclass
class Samples:
    """Desurveyed samples in input coordinates: positions (N, 3), values (N,) with NaN for
    don't know, the index of each sample's hole in `hole_ids`, and its measured depth."""

    hole_ids: list[str]
    hole: np.ndarray
    positions: np.ndarray
    values: np.ndarray
    depths: np.ndarray
    traces: list[np.ndarray] = field(default_factory=list)

    @property
    def known(self) -> np.ndarray:
        return ~np.isnan(self.values)


def read_tables(collars: str | Path, surveys: str | Path | None, intervals: str | Path,
                variable: str, dip_down_negative: bool | None = None) -> Samples:
    """Reads drill-hole tables as `wellmesh contour --collars --surveys --intervals
    --variable` does (midpoint samples, no compositing)."""
    ct = Table.read(collars)
    ch, cx, cy = ct.column("hole"), ct.column("x"), ct.column("y")
    cz = ct.column("z", required=False)
    cl = ct.column("length", required=False)
    order: list[str] = []
    collar: dict[str, tuple[np.ndarray, float | None]] = {}
    for line, row in ct.rows:
        hid = ct.field(row, ch)
        x, y = ct.number(line, row, cx), ct.number(line, row, cy)
        z = ct.number(line, row, cz) if cz is not None else 0.0
        if x is None or y is None or z is None:
            continue  # wellmesh drops collars with an empty coordinate
        if hid in collar:
            continue
        length = ct.number(line, row, cl) if cl is not None else None
        collar[hid] = (np.array([x, y, z]), length)
        order.append(hid)

    it = Table.read(intervals)
    ih, fr, to = it.column("hole"), it.column("from"), it.column("to")
    iv = it.named(variable)
    per_hole: dict[str, list[tuple[float, float, int, float | None]]] = {h: [] for h in order}
    for line, row in it.rows:
        hid = it.field(row, ih)
        if hid not in per_hole:
            continue
        f, t = it.number(line, row, fr), it.number(line, row, to)
        try:
            value = read_value(it.field(row, iv))
        except ValueError:
            raise TableError(f"{it.file} line {line} column {it.headers[iv]}: not a number")
        if f is None or t is None or not f < t:
            continue
        per_hole[hid].append((f, t, line, value))

    stations: dict[str, list[tuple[float, int, float, float]]] = {h: [] for h in order}
    if surveys is not None:
        st = Table.read(surveys)
        sh, sd = st.column("hole"), st.column("survey_depth")
        sa, sp = st.column("azimuth"), st.column("dip")
        for line, row in st.rows:
            hid = st.field(row, sh)
            if hid not in stations:
                continue
            d, a, p = st.number(line, row, sd), st.number(line, row, sa), st.number(line, row, sp)
            if d is None or a is None or p is None:
                continue
            stations[hid].append((d, line, a, p))
    if dip_down_negative is None:
        dips = [s[3] for v in stations.values() for s in v]
        neg = sum(1 for d in dips if d < 0)
        pos = sum(1 for d in dips if d > 0)
        dip_down_negative = neg >= pos

    ids, hole_idx, positions, values, depths, traces = [], [], [], [], [], []
    for hid in order:
        ivs = sorted(per_hole[hid], key=lambda r: (r[0], r[1], r[2]))
        kept: list[list] = []
        for f, t, line, v in ivs:
            if kept:
                lf, lt = kept[-1][0], kept[-1][1]
                if f == lf and t == lt:
                    continue
                if f < lt:
                    if t <= lt:
                        continue
                    f = lt
            kept.append([f, t, v])
        if not kept:
            continue
        samples: list[tuple[float, float | None]] = []
        for k, (f, t, v) in enumerate(kept):
            if k > 0 and f > kept[k - 1][1]:
                samples.append(((kept[k - 1][1] + f) * 0.5, None))
            samples.append(((f + t) * 0.5, v))
        deepest = max(r[1] for r in kept)
        length = collar[hid][1]
        hole_length = max(length if length is not None else deepest, deepest)
        sts = sorted(stations[hid], key=lambda s: (s[0], s[1]))
        dedup = []
        for s in sts:
            if dedup and dedup[-1][0] == s[0]:
                continue
            dedup.append(s)
        for k, s in enumerate(dedup):
            if s[0] >= hole_length:
                dedup = dedup[: k + 1]
                break
        traj = Trajectory(
            [s[0] for s in dedup],
            [s[2] % 360.0 for s in dedup],
            [(-s[3] if dip_down_negative else s[3]) for s in dedup],
        )
        d = np.array([s[0] for s in samples])
        p = collar[hid][0] + traj.position(d)
        n = len(ids)
        ids.append(hid)
        hole_idx.append(np.full(len(d), n))
        positions.append(p)
        values.append(np.array([np.nan if s[1] is None else s[1] for s in samples]))
        depths.append(d)
        bottom = d.max()
        sd_ = [x for x in traj.depths if 0.0 < x < bottom]
        traces.append(collar[hid][0] + traj.position(np.array([0.0] + sd_ + [bottom])))
    if not ids:
        raise TableError(f"{intervals}: no samples")
    return Samples(ids, np.concatenate(hole_idx), np.vstack(positions), np.concatenate(values),
                   np.concatenate(depths), traces)


def write_tables(directory: Path, collars, surveys, assays, variable: str) -> None:
    """Writes collar (hole_id,x,y,z), survey (hole_id,depth,azimuth,dip; dips negative down)
    and assay (hole_id,from,to,<variable>) tables; values None are written empty."""
    directory.mkdir(parents=True, exist_ok=True)
    with open(directory / "collars.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["hole_id", "x", "y", "z"])
        for hid, x, y, z in collars:
            w.writerow([hid, f"{x:.3f}", f"{y:.3f}", f"{z:.3f}"])
    with open(directory / "surveys.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["hole_id", "depth", "azimuth", "dip"])
        for hid, d, a, p in surveys:
            w.writerow([hid, f"{d:.2f}", f"{a:.3f}", f"{p:.3f}"])
    with open(directory / "assays.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["hole_id", "from", "to", variable])
        for hid, a, b, v in assays:
            if v is None:
                text = ""
            elif isinstance(v, (int, np.integer)):
                text = str(int(v))
            else:
                text = f"{v:.4g}"
            w.writerow([hid, f"{a:.2f}", f"{b:.2f}", text])


def subset_tables(src: dict[str, Path], dst: Path, keep_holes: set[str]) -> dict[str, Path]:
    """Copies collar/survey/interval tables keeping only rows of `keep_holes` (by the hole
    column), header and all other columns untouched. Returns the new paths."""
    dst.mkdir(parents=True, exist_ok=True)
    out = {}
    for kind, path in src.items():
        if path is None:
            out[kind] = None
            continue
        t = Table.read(path)
        h = t.column("hole")
        target = dst / Path(path).name
        with open(target, "w", newline="") as f:
            w = csv.writer(f, delimiter=",")
            w.writerow(t.headers)
            for _, row in t.rows:
                if Table.field(row, h) in keep_holes:
                    w.writerow(row)
        out[kind] = target
    return out
