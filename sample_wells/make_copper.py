#!/usr/bin/env python3
"""Writes the synthetic sample wells of this folder from analytic ore bodies.

Python 3 standard library only; seeded, so the output is the same on every run:

    python3 sample_wells/make_copper.py            # writes next to this script

copper_wells.csv  13 vertical wells, 9-43 samples each, value 1 inside the ellipsoid
                  ELLIPSOID below and 0 outside (the shape of the DMT paper's copper data).
copper_grade.csv  42 vertical wells on a jittered 7 x 6 grid at UTM coordinates, one sample
                  every 4 m, value = GRADE_PEAK * (1 - r^2) clipped at 0, where r is the
                  ellipsoidal radius of the same ellipsoid; the shell value >= t is the
                  ellipsoid scaled by sqrt(1 - t / GRADE_PEAK).

Both files use the samples CSV of the design (well,x,y,z,value); z is elevation (up).
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
    nx, ny, spacing = 7, 6, 55.0
    c, s = math.cos(math.radians(ROTATION_DEG)), math.sin(math.radians(ROTATION_DEG))
    for j in range(ny):
        for i in range(nx):
            u = (i - (nx - 1) / 2) * spacing + rng.uniform(-10, 10)
            v = (j - (ny - 1) / 2) * spacing + rng.uniform(-10, 10)
            x = CENTRE[0] + c * u - s * v
            y = CENTRE[1] + s * u + c * v
            top = CENTRE[2] + 80 + rng.uniform(-5, 5)
            z = top
            while z > CENTRE[2] - 80:
                g = max(0.0, GRADE_PEAK * (1.0 - ellipsoid_radius2(x, y, z)))
                rows.append((f"G-{j + 1}{i + 1}", x, y, z, round(g, 4)))
                z -= 4.0
    return rows


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
    print(f"ellipsoid volume {volume():.1f} m3")
    for t in (0.5, 1.0):
        print(f"grade shell >= {t}: {volume(math.sqrt(1 - t / GRADE_PEAK)):.1f} m3")


if __name__ == "__main__":
    main()
