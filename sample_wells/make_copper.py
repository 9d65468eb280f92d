#!/usr/bin/env python3
"""Writes the synthetic sample wells of this folder from analytic ore bodies.

Python 3 standard library only; seeded, so the output is the same on every run:

    python3 sample_wells/make_copper.py            # writes next to this script

copper_wells.csv  13 vertical wells, 9-43 samples each, value 1 inside the ellipsoid
                  ELLIPSOID below and 0 outside (the shape of the DMT paper's copper data).
copper_grade.csv  247 vertical wells on a jittered 19 x 13 grid (20 m) at UTM coordinates,
                  one sample every 4 m, value = GRADE_PEAK * (1 - r^2) clipped at 0, where r is the
                  ellipsoidal radius of the same ellipsoid; the shell value >= t is the
                  ellipsoid scaled by sqrt(1 - t / GRADE_PEAK).

copper_collars.csv, copper_surveys.csv, copper_assays.csv
                  80 inclined drill holes (collar, survey, interval tables) through the
                  same grade field: each hole is an exact circular arc (radius 500-1500 m,
                  dips -60 +- 8 degrees, towards azimuth 120 +- 12), surveyed every 25 m,
                  assayed every 2 m; an interval's Cu is the grade field at its midpoint on
                  the arc, so minimum-curvature desurvey must put every midpoint where the
                  grade was taken.

The samples files use the samples CSV of the design (well,x,y,z,value); z is elevation (up).
"""
import math
import os
import random

SEED = 20261122
# Ellipsoid: centre (UTM zone 33N metres), semi-axes (m), rotation of the a axis from east
# towards north (degrees).
CENTRE = (512300.0, 7021850.0, 240.0)
SEMI_AXES = (150.0, 90.0, 45.0)
ROTATION_DEG = 30.0
GRADE_PEAK = 2.0


def ellipsoid_radius2(x, y, z):
    """Squared ellipsoidal radius of a point (1 on the surface)."""
    dx, dy, dz = x - CENTRE[0], y - CENTRE[1], z - CENTRE[2]
    c, s = math.cos(math.radians(ROTATION_DEG)), math.sin(math.radians(ROTATION_DEG))
    u = c * dx + s * dy
    v = -s * dx + c * dy
    a, b, h = SEMI_AXES
    return (u / a) ** 2 + (v / b) ** 2 + (dz / h) ** 2


def volume(scale=1.0):
    a, b, h = SEMI_AXES
    return 4.0 / 3.0 * math.pi * a * b * h * scale ** 3


def copper_wells(rng):
    """13 wells: 7 through the body (a hexagon and its centre), 6 around it."""
    rows = []
    collars = [(0.0, 0.0)]
    for k in range(6):
        t = math.radians(60 * k + 15)
        collars.append((95 * math.cos(t), 60 * math.sin(t)))
    for k in range(6):
        t = math.radians(60 * k + 45)
        collars.append((230 * math.cos(t), 150 * math.sin(t)))
    c, s = math.cos(math.radians(ROTATION_DEG)), math.sin(math.radians(ROTATION_DEG))
    for i, (u, v) in enumerate(collars):
        u += rng.uniform(-8, 8)
        v += rng.uniform(-8, 8)
        x = CENTRE[0] + c * u - s * v
        y = CENTRE[1] + s * u + c * v
        top = CENTRE[2] + 90 + rng.uniform(0, 20)
        bottom = CENTRE[2] - 90 - rng.uniform(0, 20)
        n = rng.randint(9, 43)
        step = (top - bottom) / (n - 1)
        for k in range(n):
            z = top - k * step
            if 0 < k < n - 1:
                z += rng.uniform(-0.3, 0.3) * step
            value = 1 if ellipsoid_radius2(x, y, z) <= 1.0 else 0
            rows.append((f"CU-{i + 1:02d}", x, y, z, value))
    return rows


def grade_wells(rng):
    rows = []
    nx, ny, spacing = 19, 13, 20.0
    c, s = math.cos(math.radians(ROTATION_DEG)), math.sin(math.radians(ROTATION_DEG))
    for j in range(ny):
        for i in range(nx):
            u = (i - (nx - 1) / 2) * spacing + rng.uniform(-4, 4)
            v = (j - (ny - 1) / 2) * spacing + rng.uniform(-4, 4)
            x = CENTRE[0] + c * u - s * v
            y = CENTRE[1] + s * u + c * v
            top = CENTRE[2] + 80 + rng.uniform(-5, 5)
            z = top
            while z > CENTRE[2] - 80:
                g = max(0.0, GRADE_PEAK * (1.0 - ellipsoid_radius2(x, y, z)))
                rows.append((f"G-{j + 1:02d}{i + 1:02d}", x, y, z, round(g, 4)))
                z -= 4.0
    return rows


def grade(x, y, z):
    return max(0.0, GRADE_PEAK * (1.0 - ellipsoid_radius2(x, y, z)))


def drill_holes(rng):
    """Collar, survey and assay rows of inclined holes that are exact circular arcs."""
    collars, surveys, assays = [], [], []
    nx, ny, spacing, length, step = 10, 8, 40.0, 300.0, 2.0
    c, s = math.cos(math.radians(ROTATION_DEG)), math.sin(math.radians(ROTATION_DEG))
    top = CENTRE[2] + 150.0
    for j in range(ny):
        for i in range(nx):
            az = 120.0 + rng.uniform(-12, 12)
            dip = 60.0 + rng.uniform(-8, 8)
            ar, dr = math.radians(az), math.radians(dip)
            t0 = (math.sin(ar) * math.cos(dr), math.cos(ar) * math.cos(dr), -math.sin(dr))
            h = (math.sin(ar), math.cos(ar), 0.0)
            ht = sum(a * b for a, b in zip(h, t0))
            nh = [a - ht * b for a, b in zip(h, t0)]
            norm = math.sqrt(sum(a * a for a in nh))
            nh = [a / norm for a in nh]
            side = (math.cos(ar), -math.sin(ar), 0.0)
            phi = rng.uniform(-1.2, 1.2)
            n = [math.cos(phi) * a + math.sin(phi) * b for a, b in zip(nh, side)]
            radius = rng.uniform(500, 1500)
            # Collar up-dip of the body so the hole crosses it about 150 m down.
            u = (i - (nx - 1) / 2) * spacing + rng.uniform(-8, 8)
            v = (j - (ny - 1) / 2) * spacing + rng.uniform(-8, 8)
            x0 = CENTRE[0] + c * u - s * v - t0[0] / -t0[2] * 150.0
            y0 = CENTRE[1] + s * u + c * v - t0[1] / -t0[2] * 150.0
            z0 = top + rng.uniform(-3, 3)
            hole = f"DH{j + 1:02d}{i + 1:02d}"

            def at(depth):
                a = depth / radius
                p = [x0, y0, z0]
                t = []
                for k in range(3):
                    p[k] += radius * math.sin(a) * t0[k] + radius * (1 - math.cos(a)) * n[k]
                    t.append(math.cos(a) * t0[k] + math.sin(a) * n[k])
                return p, t

            collars.append((hole, x0, y0, z0, length))
            d = 0.0
            while d <= length:
                _, t = at(d)
                azimuth = math.degrees(math.atan2(t[0], t[1])) % 360.0
                dip_down = math.degrees(math.asin(-t[2]))
                surveys.append((hole, d, azimuth, -dip_down))
                d += 25.0
            d = 0.0
            while d < length:
                p, _ = at(d + step / 2)
                assays.append((hole, d, d + step, round(grade(*p), 4)))
                d += step
    return collars, surveys, assays


def write_tables(here, rng):
    collars, surveys, assays = drill_holes(rng)
    with open(os.path.join(here, "copper_collars.csv"), "w", newline="\n") as f:
        f.write("hole_id,x,y,z,depth\n")
        for h, x, y, z, d in collars:
            f.write(f"{h},{x:.4f},{y:.4f},{z:.4f},{d}\n")
    with open(os.path.join(here, "copper_surveys.csv"), "w", newline="\n") as f:
        f.write("hole_id,depth,azimuth,dip\n")
        for h, d, a, p in surveys:
            f.write(f"{h},{d},{a:.9f},{p:.9f}\n")
    with open(os.path.join(here, "copper_assays.csv"), "w", newline="\n") as f:
        f.write("hole_id,from,to,cu\n")
        for h, a, b, g in assays:
            f.write(f"{h},{a},{b},{g}\n")


def write(path, rows):
    with open(path, "w", newline="\n") as f:
        f.write("well,x,y,z,value\n")
        for w, x, y, z, v in rows:
            f.write(f"{w},{x:.2f},{y:.2f},{z:.2f},{v}\n")


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    rng = random.Random(SEED)
    write(os.path.join(here, "copper_wells.csv"), copper_wells(rng))
    write(os.path.join(here, "copper_grade.csv"), grade_wells(rng))
    write_tables(here, rng)
    print(f"ellipsoid volume {volume():.1f} m3")
    for t in (0.5, 1.0):
        print(f"grade shell >= {t}: {volume(math.sqrt(1 - t / GRADE_PEAK)):.1f} m3")


if __name__ == "__main__":
    main()
