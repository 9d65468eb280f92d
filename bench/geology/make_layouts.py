"""Synthetic drill-hole layouts with a known truth, written as wellmesh's drill-hole tables.

Usage:
  python bench/geology/make_layouts.py --out DIR [--seeds 1 2 3 4 5] [--layouts lens,two_lens,...]
                                       [--noise-free]
  python bench/geology/make_layouts.py inside DIR/lens/seed1 X Y Z [X Y Z ...]

Each layout/seed directory holds collars.csv (hole_id,x,y,z), surveys.csv
(hole_id,depth,azimuth,dip; dips negative down), assays.csv (hole_id,from,to,<variable>)
and truth.json (truth.py: the lenses, the exact volume and area, the noise). Layouts:

  lens            one dipping lens, ~33k assays (sections 50 m apart, holes 40 m apart)
  two_lens        two parallel lenses one above the other, ~33k assays
  lens_flag       lens's holes and noise, value 1 where the noisy grade >= 5 else 0
  two_lens_flag   the same for two_lens
  two_dips        two lenses side by side along strike, the second turned 40-90 degrees in
                  dip direction and 20-35 in dip (a field whose orientation varies), ~33k assays
  big             one lens 1.5 times larger drilled 25 m x 20 m: ~300k assays

With --noise-free the assays are the true grades at their midpoints (the same holes, lenses
and flags' threshold, no noise): what the assays' noise costs a model is its score on the
noisy layout against its score on this one.

Invariant: a layout is a pure function of (layout, seed): the same bytes on every run.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from drillholes import Trajectory, direction, write_tables
from truth import Lens, Truth, frame

GRADE_THRESHOLD = 5.0
ASSAY_LENGTH = 1.5
SURVEY_STEP = 30.0
# Origin of the coordinates: UTM-like easting and northing, so f32 rounding matters.
EASTING, NORTHING, SURFACE = 512_000.0, 7_021_000.0, 1_200.0

LAYOUTS = {
    # name: (lenses, section spacing, hole spacing, size factor, assays wanted, flag)
    "lens": dict(lenses=1, section=50.0, spacing=40.0, scale=1.0, assays=33_000, flag=False),
    "two_lens": dict(lenses=2, section=50.0, spacing=40.0, scale=1.0, assays=33_000, flag=False),
    "lens_flag": dict(base="lens", flag=True),
    "two_lens_flag": dict(base="two_lens", flag=True),
    "two_dips": dict(lenses=2, section=50.0, spacing=40.0, scale=1.0, assays=33_000, flag=False,
                     side=True),
    "big": dict(lenses=1, section=25.0, spacing=20.0, scale=1.5, assays=300_000, flag=False),
}
MAIN_LAYOUTS = ["lens", "two_lens", "lens_flag", "two_lens_flag"]
LAYOUT_INDEX = {"lens": 1, "two_lens": 2, "big": 3, "two_dips": 4}


def topography(x, y):
    """Collar elevation: a gentle rolling surface around SURFACE."""
    return SURFACE + 15.0 * np.sin((x - EASTING) / 310.0) + 10.0 * np.cos((y - NORTHING) / 260.0)


def make_lenses(rng, count: int, scale: float, side: bool = False) -> tuple[list[Lens], float]:
    """The lenses (first one random in orientation and size) and the background grade. With
    `side`, the second lens lies beside the first along its strike, turned."""
    background = float(rng.uniform(0.5, 1.0))
    dip = float(rng.uniform(25.0, 75.0))
    dip_direction = float(rng.uniform(0.0, 360.0))
    pitch = float(rng.uniform(-60.0, 60.0))
    a = float(rng.uniform(125.0, 250.0)) * scale
    b = float(rng.uniform(75.0, min(175.0, a / scale))) * scale
    c = float(rng.uniform(6.0, 20.0)) * scale ** 0.5
    axes = [[a, b, c]]
    if count == 2:
        k = rng.uniform(0.6, 0.9)
        axes.append([a * k, b * rng.uniform(0.6, 0.9), c * rng.uniform(0.7, 1.0)])
    r = frame(dip, dip_direction, pitch)
    centre = np.array([EASTING + rng.uniform(-300, 300), NORTHING + rng.uniform(-300, 300), 0.0])
    lenses = []
    offset = np.zeros(3)
    orientations = [(dip, dip_direction, pitch)] * len(axes)
    if side and count == 2:
        turn = float(rng.uniform(40.0, 90.0)) * float(rng.choice([-1.0, 1.0]))
        steeper = float(rng.uniform(20.0, 35.0)) * (1.0 if dip < 50.0 else -1.0)
        orientations[1] = (dip + steeper, (dip_direction + turn) % 360.0,
                           float(rng.uniform(-60.0, 60.0)))
    for i, (la, lb, lc) in enumerate(axes):
        if i == 1 and side:
            # Beside the first lens along its strike (horizontal), farther than both major
            # semi-axes: the bodies are disjoint whatever their orientations.
            dd = math.radians(dip_direction)
            strike_h = np.array([-math.cos(dd), math.sin(dd), 0.0])
            offset = (axes[0][0] + la + rng.uniform(30.0, 60.0)) * strike_h
        elif i == 1:
            gap = rng.uniform(25.0, 60.0)
            # Below the first lens (e3 points up or down; go down in elevation) and shifted
            # along strike: slabs |w - w_i| <= c_i do not overlap, so the bodies are disjoint.
            across = (axes[0][2] + lc + gap) * (-np.sign(r[2, 2]) or -1.0)
            offset = across * r[2] + rng.uniform(-0.4, 0.4) * axes[0][0] * r[0]
        core = float(rng.uniform(8.0, 15.0))
        q = (GRADE_THRESHOLD - background) / (core - background)
        halo = 1.0 / math.sqrt(1.0 - math.sqrt(q))
        l_dip, l_dd, l_pitch = orientations[i]
        lenses.append(Lens(centre=(centre + offset).tolist(), dip=l_dip, dip_direction=l_dd,
                           pitch=l_pitch, semi_axes=[la, lb, lc], core_grade=core,
                           halo_radius=halo))
    # Bury the lenses: the highest point of any lens 80-200 m below the surface.
    top = max(l.bounds()[1][2] for l in lenses)
    ground = float(topography(np.array(centre[0]), np.array(centre[1])))
    shift = ground - rng.uniform(80.0, 200.0) - top
    for l in lenses:
        l.centre[2] += shift
    return lenses, background


def plan_holes(rng, lenses: list[Lens], section: float, spacing: float, side: bool = False):
    """Candidate section holes: collars every `spacing` along section lines `section` apart
    across strike, drilled against the dip at -50..-70. Returns, per candidate, (collar xy,
    azimuth, dip, length to 40-120 m past the lenses it pierces, reach): reach is the
    smallest ellipsoidal radius, in its lens's mid-plane, at which the hole's straight line
    pierces a lens plane. `build` keeps the candidates within a reach."""
    main = lenses[0]
    dd = math.radians(main.dip_direction)
    strike_h = np.array([-math.cos(dd), math.sin(dd)])
    dip_h = np.array([math.sin(dd), math.cos(dd)])
    centre = np.mean([l.centre for l in lenses], axis=0)
    a_max = max(l.semi_axes[0] for l in lenses) + 150.0
    if side:  # lenses beside each other: sections over both
        a_max += max(abs(float((np.asarray(l.centre[:2]) - centre[:2]) @ strike_h)) for l in lenses)
    n_sec = math.ceil(2 * a_max / section)
    phase = rng.uniform(0, spacing)
    holes = []
    for k in range(-n_sec, n_sec + 1):
        s_off = k * section
        for m in range(-60, 61):
            xy = centre[:2] + s_off * strike_h + (m * spacing + phase) * dip_h
            xy = xy + rng.uniform(-3.0, 3.0, 2)
            az = (main.dip_direction + 180.0 + rng.uniform(-3.0, 3.0)) % 360.0
            dip = float(rng.uniform(50.0, 70.0))
            past = float(rng.uniform(40.0, 120.0))
            z = float(topography(xy[0], xy[1]))
            u = direction(az, dip)
            collar = np.array([xy[0], xy[1], z])
            reach, length = math.inf, 0.0
            for lens in lenses:
                n = lens.rotation[2]
                un = float(u @ n)
                if abs(un) < 1e-6:
                    continue
                t = float((np.asarray(lens.centre) - collar) @ n) / un
                if t <= 0:
                    continue
                q = (collar + t * u - np.asarray(lens.centre)) @ lens.rotation.T
                r_plane = math.hypot(q[0] / lens.semi_axes[0], q[1] / lens.semi_axes[1])
                reach = min(reach, r_plane)
                length = max(length, t + lens.semi_axes[2] / abs(un) + past)
            if math.isfinite(reach):
                holes.append((xy, az, dip, length, reach))
    return holes


def far_holes(rng, lenses: list[Lens], count: int):
    """Exploration holes 300-800 m beyond the lenses' centre, mostly in waste."""
    centre = np.mean([l.centre for l in lenses], axis=0)
    out = []
    for _ in range(count):
        bearing = rng.uniform(0, 2 * math.pi)
        dist = max(l.semi_axes[0] for l in lenses) + rng.uniform(300.0, 800.0)
        xy = centre[:2] + dist * np.array([math.sin(bearing), math.cos(bearing)])
        out.append((xy, float(rng.uniform(0, 360)), float(rng.uniform(60.0, 90.0)),
                    float(rng.uniform(250.0, 450.0))))
    return out


def drill(rng, truth: Truth, holes, prefix: str):
    """Surveys, intervals and noiseless grades of the planned holes: surveys every 30 m with a
    slow drift (the dip flattens by 0-2 degrees and the azimuth turns by up to 1.5 degrees per
    100 m); 1.5 m assays from below a short overburden, about 0.3% of them lost (gaps)."""
    collars, surveys, intervals, positions = [], [], [], []
    for i, (xy, az, dip, length) in enumerate(holes):
        hid = f"{prefix}{i + 1:04d}"
        z = float(topography(xy[0], xy[1]))
        collars.append((hid, float(xy[0]), float(xy[1]), z))
        flatten = rng.uniform(0.0, 2.0) / 100.0
        turn = rng.uniform(-1.5, 1.5) / 100.0
        depths = np.arange(0.0, length + 1e-9, SURVEY_STEP)
        azs = (az + turn * depths) % 360.0
        dips = np.maximum(dip - flatten * depths, 5.0)
        for d, a, p in zip(depths, azs, dips):
            surveys.append((hid, float(d), float(a), -float(p)))
        start = round(float(rng.uniform(0.0, 6.0)), 1)
        count = int((length - start) // ASSAY_LENGTH)
        froms = start + ASSAY_LENGTH * np.arange(count)
        keep = rng.random(count) > 0.003
        froms = froms[keep]
        traj = Trajectory(np.round(depths, 2), np.round(azs, 3), np.round(dips, 3))
        mids = froms + ASSAY_LENGTH / 2
        p = np.array([xy[0], xy[1], z]) + traj.position(mids)
        for f in froms:
            intervals.append((hid, round(float(f), 2), round(float(f) + ASSAY_LENGTH, 2)))
        positions.append(p)
    return collars, surveys, intervals, np.vstack(positions)


def build(layout: str, seed: int, noise_free: bool = False):
    """(truth, collars, surveys, intervals, assayed grades) of a grade layout: the true
    grades times noise, or with `noise_free` the true grades (same holes and lenses)."""
    spec = LAYOUTS[layout]
    rng = np.random.default_rng([seed, LAYOUT_INDEX[layout]])
    lenses, background = make_lenses(rng, spec["lenses"], spec["scale"], spec.get("side", False))
    truth = Truth(layout=layout, seed=seed, variable="zn", threshold=GRADE_THRESHOLD,
                  grade_threshold=GRADE_THRESHOLD, background=background, noise_sigma_ln=0.0,
                  nugget_share=float(rng.uniform(0.2, 0.3)), lenses=lenses)
    plan_rng = np.random.default_rng([seed, LAYOUT_INDEX[layout], 1])
    # Step out from the lenses (reach from 1.1 lens radii up) until the layout has the
    # assays wanted.
    candidates = plan_holes(np.random.default_rng([seed, LAYOUT_INDEX[layout], 2]), lenses,
                            spec["section"], spec["spacing"], spec.get("side", False))
    by_reach = sorted(range(len(candidates)), key=lambda i: candidates[i][4])
    metres, chosen = 0.0, []
    for i in by_reach:
        if candidates[i][4] > 1.1 and metres / ASSAY_LENGTH >= spec["assays"]:
            break
        chosen.append(i)
        metres += candidates[i][3]
    holes = [candidates[i][:4] for i in sorted(chosen)]
    holes += far_holes(plan_rng, lenses, 5)
    collars, surveys, intervals, positions = drill(np.random.default_rng([seed, 7]), truth, holes,
                                                   "DH")
    true = truth.grade(positions)
    # Multiplicative lognormal noise with mean 1; its variance share of the assays is
    # k E[T^2] / (Var T + k E[T^2]) with k = exp(sigma^2) - 1: solved for the share wanted.
    s = truth.nugget_share
    k = s * true.var() / ((1.0 - s) * (true ** 2).mean())
    sigma = math.sqrt(math.log1p(k))
    truth.noise_sigma_ln = sigma
    z = np.random.default_rng([seed, LAYOUT_INDEX[layout], 3]).standard_normal(len(true))
    noisy = true * np.exp(sigma * z - 0.5 * sigma * sigma)
    if noise_free:
        truth.noise_sigma_ln, truth.nugget_share = 0.0, 0.0
        return truth, collars, surveys, intervals, true
    return truth, collars, surveys, intervals, noisy


def write_layout(out: Path, layout: str, seed: int, noise_free: bool = False) -> dict:
    spec = LAYOUTS[layout]
    base = spec.get("base", layout)
    truth, collars, surveys, intervals, assayed = build(base, seed, noise_free)
    directory = out / layout / f"seed{seed}"
    if spec["flag"]:
        truth.layout, truth.flag, truth.variable, truth.threshold = layout, True, "zn_ge5", 0.5
        values = [int(v >= GRADE_THRESHOLD) for v in assayed]
    else:
        values = [float(v) for v in assayed]
    assays = [(h, a, b, v) for (h, a, b), v in zip(intervals, values)]
    write_tables(directory, collars, surveys, assays, truth.variable)
    truth.save(directory / "truth.json")
    ore = float(np.mean(np.asarray(assayed) >= GRADE_THRESHOLD))
    return dict(layout=layout, seed=seed, holes=len(collars), assays=len(assays),
                ore_share=ore, sigma=truth.noise_sigma_ln, volume=truth.volume, dir=str(directory))


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "inside":
        if len(argv) < 5 or (len(argv) - 2) % 3:
            print("usage: make_layouts.py inside LAYOUT_DIR X Y Z [X Y Z ...]", file=sys.stderr)
            return 2
        truth = Truth.load(argv[1])
        pts = np.array([float(v) for v in argv[2:]]).reshape(-1, 3)
        for p, inside, g in zip(pts, truth.contains(pts), truth.grade(pts)):
            print(f"{p[0]:.3f} {p[1]:.3f} {p[2]:.3f} {'inside' if inside else 'outside'} "
                  f"true_grade {g:.4f}")
        return 0
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--layouts", default=",".join(MAIN_LAYOUTS),
                    help=f"comma-separated among {', '.join(LAYOUTS)} (default: the main ones)")
    ap.add_argument("--noise-free", action="store_true",
                    help="assays are the true grades (no noise): the same layouts otherwise")
    args = ap.parse_args(argv)
    names = [n for n in args.layouts.split(",") if n]
    for n in names:
        if n not in LAYOUTS:
            ap.error(f"unknown layout '{n}' (known: {', '.join(LAYOUTS)})")
    for n in names:
        for seed in args.seeds:
            info = write_layout(args.out, n, seed, args.noise_free)
            print(f"{info['layout']:>14} seed {seed}: {info['holes']} holes, {info['assays']} assays, "
                  f"{100 * info['ore_share']:.1f}% >= 5, noise sigma_ln {info['sigma']:.3f}, "
                  f"true volume {info['volume']:.0f} m3 -> {info['dir']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
