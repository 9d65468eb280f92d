"""Renders a wellmesh GLB (or OBJ/PLY/STL, or a peer's .npz) to a PNG from a fixed, stated
viewpoint, so that before/after pictures of the same data can be compared.

Usage:
  python bench/geology/pictures.py MODEL.glb OUT.png [--from-bearing 200] [--elevation 30]
      [--frame FRAME.glb] [--traces] [--title TEXT] [--size 1200x900] [--palette N]

The camera is orthographic, looking at the centre of the frame box from the compass
bearing --from-bearing (degrees clockwise from north: 200 = from the south-south-west) and
--elevation degrees above the horizontal; east, north and elevation keep one scale.
The frame box holds the bodies and the middle 98 % of the samples (1st-99th percentile on
each axis) of --frame (default: MODEL itself), grown by 5 %; draw the "after" picture with
--frame BEFORE.glb and both share one framing. Bodies are flat-shaded (two-sided Lambert,
a light from the camera's upper left), one colour per body, all triangles depth-sorted
together; --traces draws the drill holes in grey.
--palette N stores the PNG with N colours (Pillow's median cut, no dithering): about a
third of the bytes, for pictures kept in the repository's docs.
Matplotlib only (Agg; Pillow, which it installs, for --palette): no display, no GPU.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from meshes import Surface, read_surface, split_bodies


def load(path: Path) -> Surface:
    if path.suffix.lower() == ".npz":
        d = np.load(path)
        return Surface(split_bodies(d["vertices"], d["faces"]), np.zeros(3))
    return read_surface(path)


def frame_box(surface: Surface) -> tuple[np.ndarray, np.ndarray]:
    """The box of the bodies and of the samples' 1st-99th percentiles on each axis (a far
    exploration hole does not shrink the picture), grown by 5 % on each side."""
    parts = [b.vertices for b in surface.bodies]
    if surface.samples is not None and len(surface.samples):
        q = np.percentile(surface.samples, [1, 99], axis=0)
        parts.append(q)
    if not parts:
        raise ValueError("nothing to frame: no samples or bodies")
    pts = np.vstack(parts)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = 0.05 * (hi - lo)
    return lo - pad, hi + pad


def render(surface: Surface, out: Path, bearing: float, elevation: float, box,
           traces: bool, title: str | None, size: tuple[int, int]) -> dict:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

    lo, hi = box
    centre = (lo + hi) / 2.0
    fig = plt.figure(figsize=(size[0] / 100, size[1] / 100), dpi=100)
    ax = fig.add_subplot(projection="3d")
    ax.set_proj_type("ortho")
    # matplotlib's azimuth is counter-clockwise from +x (east); a compass bearing is
    # clockwise from north.
    ax.view_init(elev=elevation, azim=90.0 - bearing)
    b, e = math.radians(bearing), math.radians(elevation)
    to_camera = np.array([math.sin(b) * math.cos(e), math.cos(b) * math.cos(e), math.sin(e)])
    # Light from the camera's upper left.
    left = np.cross([0.0, 0.0, 1.0], to_camera)
    left /= np.linalg.norm(left) or 1.0
    light = 0.5 * to_camera + 0.8 * np.array([0.0, 0.0, 1.0]) + 0.7 * left
    light /= np.linalg.norm(light)
    cmap = matplotlib.colormaps["tab10"]
    triangles = 0
    all_tri, all_col = [], []
    for i, body in enumerate(surface.bodies):
        v = body.vertices - centre
        tri = v[body.faces]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        norm = np.linalg.norm(n, axis=1)
        ok = norm > 0
        n[ok] /= norm[ok][:, None]
        # Two-sided Lambert so open or inward-wound surfaces still read.
        shade = 0.25 + 0.75 * np.abs(n @ light)
        base = np.array(cmap(i % 10)[:3]) if len(surface.bodies) > 1 else np.array([0.85, 0.33, 0.1])
        all_tri.append(tri)
        all_col.append(np.clip(base[None, :] * shade[:, None], 0, 1))
        triangles += len(tri)
    if all_tri:
        ax.add_collection3d(Poly3DCollection(np.vstack(all_tri), facecolors=np.vstack(all_col),
                                             edgecolors="none", linewidths=0))
    if traces and surface.segments is not None:
        ax.add_collection3d(Line3DCollection(surface.segments - centre, colors=(0.45, 0.45, 0.45),
                                             linewidths=0.4, alpha=0.6))
    half = (hi - lo) / 2.0
    ax.set_xlim(-half[0], half[0])
    ax.set_ylim(-half[1], half[1])
    ax.set_zlim(-half[2], half[2])
    ax.set_box_aspect(np.maximum(hi - lo, 1e-6), zoom=1.15)
    fig.subplots_adjust(left=0.0, right=1.0, bottom=0.04, top=0.95)
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_zlabel("elevation (m)")
    ax.tick_params(labelsize=7)
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_pane_color((1.0, 1.0, 1.0, 0.0))
    ax.grid(False)
    caption = (f"{len(surface.bodies)} bodies, {triangles} triangles; view from bearing "
               f"{bearing:g} deg, elevation {elevation:g} deg; axes relative to "
               f"({centre[0]:.0f}, {centre[1]:.0f}, {centre[2]:.0f})")
    fig.suptitle(title or "", fontsize=12)
    fig.text(0.5, 0.02, caption, ha="center", fontsize=8)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return dict(bodies=len(surface.bodies), triangles=triangles, centre=centre.tolist())


def reduce_palette(path: Path, colours: int) -> None:
    """Rewrites the PNG at `path` with `colours` colours (median cut, no dithering)."""
    from PIL import Image

    with Image.open(path) as im:
        rgb = im.convert("RGB")
    rgb.quantize(colors=colours, method=Image.Quantize.MEDIANCUT,
                 dither=Image.Dither.NONE).save(path, optimize=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("model", type=Path)
    ap.add_argument("out", type=Path)
    ap.add_argument("--from-bearing", type=float, default=200.0)
    ap.add_argument("--elevation", type=float, default=30.0)
    ap.add_argument("--frame", type=Path, help="take the frame box from this model's holes")
    ap.add_argument("--traces", action="store_true")
    ap.add_argument("--title")
    ap.add_argument("--size", default="1200x900")
    ap.add_argument("--palette", type=int, help="store the PNG with this many colours (2-256)")
    args = ap.parse_args(argv)
    if args.palette is not None and not 2 <= args.palette <= 256:
        ap.error("--palette takes 2 to 256 colours")
    w, h = (int(t) for t in args.size.lower().split("x"))
    surface = load(args.model)
    box = frame_box(load(args.frame) if args.frame else surface)
    info = render(surface, args.out, args.from_bearing, args.elevation, box, args.traces,
                  args.title, (w, h))
    if args.palette:
        reduce_palette(args.out, args.palette)
    print(f"{args.out}: {info['bodies']} bodies, {info['triangles']} triangles")
    return 0


if __name__ == "__main__":
    sys.exit(main())
