"""Runs wellmesh and the peers on every layout and seed, scores each result against the
truth, and writes a markdown table and a JSON file of all figures.

Usage:
  python bench/geology/bench.py --layouts LAYOUTS_DIR --out RESULTS_DIR
      [--names lens,two_lens,lens_flag,two_lens_flag] [--seeds 1 2 3 4 5]
      [--tools wellmesh,ferreus_iso,ferreus_trend,scipy]
      [--wellmesh target/release/wellmesh] [--wellmesh-args "--interpolant linear"]
      [--label wellmesh-linear] [--peer-args "ferreus_trend=--range-trend 200,120,10"]
      [--merge]
  python bench/geology/bench.py --layouts LAYOUTS_DIR --out ALL --combine DIR1 DIR2 ...

Each run is its own child process; wall time, CPU time (user + system) and peak resident
memory are those of that process (GNU time), so the figures cover reading the tables,
desurveying, modelling, surfacing and writing the result, and nothing of the scoring.
wellmesh's command is

  WELLMESH contour --collars C --surveys S --intervals A --variable V --threshold T
      -o RUN.glb --summary RUN.json WELLMESH_ARGS...

with V and T from the layout's truth.json (zn and 5 for grades, zn_ge5 and 0.5 for flags).
With --merge, results already in RESULTS_DIR/results.json for other (layout, seed, tool)
keys are kept, so runs can be added tool by tool.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from meshes import read_glb, split_bodies
from score import check_desurvey, layout_samples, score
from truth import Truth

HERE = Path(__file__).resolve().parent
REPO = HERE.parent.parent
PEERS = ["ferreus_iso", "ferreus_trend", "scipy"]


def measured(cmd: list[str], log: Path) -> dict:
    """Runs cmd as a child process: exit code, wall seconds, CPU seconds, peak MB.

    GNU time (/usr/bin/time, Debian package `time`) starts the command and reports its peak
    resident set: a process forked from this (large) Python process would inherit its
    resident size as the high-water mark that wait4 reports. Without /usr/bin/time, wait4's
    figures are used and `peak_mb` is flagged as an upper bound."""
    timing = log.with_suffix(".time")
    gnu_time = Path("/usr/bin/time")
    wrapped = ([str(gnu_time), "-f", "%e %U %S %M", "-o", str(timing), *cmd]
               if gnu_time.exists() else cmd)
    with open(log, "w") as err:
        start = time.perf_counter()
        proc = subprocess.Popen(wrapped, stdout=err, stderr=subprocess.STDOUT)
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - start
    code = os.waitstatus_to_exitcode(status)
    rec = dict(exit=code, wall_s=wall, cpu_s=usage.ru_utime + usage.ru_stime,
               peak_mb=usage.ru_maxrss / 1024.0, peak_is_upper_bound=True)
    if gnu_time.exists() and timing.exists():
        fields = timing.read_text().split()[-4:]
        try:
            e, u, s, m = (float(f) for f in fields)
            rec.update(wall_s=e, cpu_s=u + s, peak_mb=m / 1024.0, peak_is_upper_bound=False)
        except ValueError:
            pass
    return rec


_SAMPLES: dict = {}


def run_one(layout: Path, tool: str, label: str, out: Path, wellmesh: str, wellmesh_args: list[str],
            peer_args: dict[str, list[str]], mc_points: int) -> dict:
    truth = Truth.load(layout)
    out.mkdir(parents=True, exist_ok=True)
    rec: dict = dict(layout=truth.layout, seed=truth.seed, tool=label)
    if tool == "wellmesh":
        glb, summary = out / f"{label}.glb", out / f"{label}.summary.json"
        cmd = [wellmesh, "contour", "--collars", str(layout / "collars.csv"), "--surveys",
               str(layout / "surveys.csv"), "--intervals", str(layout / "assays.csv"),
               "--variable", truth.variable, "--threshold", f"{truth.threshold:g}", "-o", str(glb),
               "--summary", str(summary), *wellmesh_args]
    else:
        result = out / f"{label}.npz"
        cmd = [sys.executable, str(HERE / "peers.py"), tool, str(layout), str(result),
               *peer_args.get(tool, [])]
    rec["command"] = shlex.join(cmd)
    rec.update(measured(cmd, out / f"{label}.log"))
    if rec["exit"] != 0:
        rec["error"] = (out / f"{label}.log").read_text()[-2000:]
        return rec
    if layout not in _SAMPLES:
        _SAMPLES.clear()
        _SAMPLES[layout] = layout_samples(layout, truth)
    samples = _SAMPLES[layout]
    if tool == "wellmesh":
        surface = read_glb(glb)
        bodies = surface.bodies
        s = json.loads(summary.read_text())
        rec["wellmesh_counts"] = s.get("counts")
        if surface.samples is not None:
            rec["desurvey_check"] = check_desurvey(samples.positions, surface.samples)
    else:
        data = np.load(result)
        bodies = split_bodies(data["vertices"], data["faces"])
        rec["params"] = json.loads(str(data["params"]))
    rec.update(score(truth, bodies, samples.positions[samples.known], mc_points,
                     assays=samples))
    return rec


def fmt(v, spec):
    return "-" if v is None else format(v, spec)


def markdown(records: list[dict]) -> str:
    cols = ("| layout | seed | tool | IoU | vol. err % | bodies (per lens, stray) | area ratio | "
            "slivers % | max dist m | wall s | CPU s | peak MB |")
    lines = [cols, "|" + "---|" * 12]
    key = lambda r: (r["layout"], r["tool"], r["seed"])
    for r in sorted(records, key=key):
        if r.get("exit", 0) != 0:
            lines.append(f"| {r['layout']} | {r['seed']} | {r['tool']} | failed (exit {r['exit']}) "
                         "| | | | | | | | |")
            continue
        bodies = f"{r['bodies']} ({'+'.join(map(str, r['lens_bodies']))}, {r['stray_bodies']})"
        iou = fmt(r["iou"], ".3f") + ("" if r["iou_method"] == "manifold" else "*")
        lines.append(
            f"| {r['layout']} | {r['seed']} | {r['tool']} | {iou} | {fmt(r['volume_error_pct'], '+.1f')} "
            f"| {bodies} | {fmt(r['area_ratio'], '.2f')} | {fmt(r['slivers_pct'], '.1f')} "
            f"| {fmt(r.get('max_dist_to_sample'), '.1f')} | {r['wall_s']:.1f} | {r['cpu_s']:.1f} "
            f"| {r['peak_mb']:.0f} |")
    lines.append("")
    lines.append("Medians over seeds:")
    lines.append("")
    lines.append("| layout | tool | runs | IoU | vol. err % | bodies | area ratio | slivers % | "
                 "max dist m | wall s | CPU s | peak MB |")
    lines.append("|" + "---|" * 12)
    groups: dict = {}
    for r in records:
        if r.get("exit", 0) == 0:
            groups.setdefault((r["layout"], r["tool"]), []).append(r)
    for (layout, tool), rs in sorted(groups.items()):
        med = lambda k: statistics.median([r[k] for r in rs if r.get(k) is not None] or [0])
        lines.append(
            f"| {layout} | {tool} | {len(rs)} | {med('iou'):.3f} | {med('volume_error_pct'):+.1f} "
            f"| {med('bodies'):g} | {med('area_ratio'):.2f} | {med('slivers_pct'):.1f} "
            f"| {med('max_dist_to_sample'):.1f} | {med('wall_s'):.1f} | {med('cpu_s'):.1f} "
            f"| {med('peak_mb'):.0f} |")
    lines.append("")
    lines.append("IoU by exact booleans (manifold3d) unless marked * (Monte-Carlo, a body not "
                 "closed; its standard error is in results.json). Bodies: count (bodies "
                 "overlapping each true lens, bodies overlapping none).")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--layouts", type=Path)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--names", default="lens,two_lens,lens_flag,two_lens_flag")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--tools", default="wellmesh," + ",".join(PEERS))
    ap.add_argument("--wellmesh", default=str(REPO / "target" / "release" / "wellmesh"))
    ap.add_argument("--wellmesh-args", default="", help="extra flags for wellmesh contour")
    ap.add_argument("--label", help="the wellmesh row's name (default: wellmesh, or wellmesh "
                                    "plus its extra flags)")
    ap.add_argument("--peer-args", action="append", default=[],
                    help='TOOL="flags" for peers.py, e.g. scipy="--grid 4"')
    ap.add_argument("--mc-points", type=int, default=400_000)
    ap.add_argument("--merge", action="store_true")
    ap.add_argument("--combine", type=Path, nargs="+", metavar="RESULTS_DIR",
                    help="only merge these directories' results.json into --out (later ones "
                         "win for the same layout, seed and tool) and write its table")
    args = ap.parse_args(argv)
    if args.combine:
        merged: dict = {}
        for d in args.combine:
            for r in json.loads((d / "results.json").read_text()):
                merged[(r["layout"], r["seed"], r["tool"])] = r
        args.out.mkdir(parents=True, exist_ok=True)
        records = list(merged.values())
        (args.out / "results.json").write_text(json.dumps(records, indent=1, default=float))
        (args.out / "results.md").write_text(markdown(records))
        print(markdown(records))
        return 0

    if args.layouts is None:
        ap.error("--layouts is required (except with --combine)")
    tools = [t for t in args.tools.split(",") if t]
    for t in tools:
        if t != "wellmesh" and t not in PEERS:
            ap.error(f"unknown tool {t}")
    wm_args = shlex.split(args.wellmesh_args)
    label = args.label or ("wellmesh" if not wm_args else "wellmesh " + " ".join(wm_args))
    peer_args = {}
    for p in args.peer_args:
        tool, _, flags = p.partition("=")
        peer_args[tool] = shlex.split(flags)
    args.out.mkdir(parents=True, exist_ok=True)
    results_path = args.out / "results.json"
    records = json.loads(results_path.read_text()) if args.merge and results_path.exists() else []
    for name in [n for n in args.names.split(",") if n]:
        for seed in args.seeds:
            layout = args.layouts / name / f"seed{seed}"
            if not (layout / "truth.json").exists():
                ap.error(f"{layout}: no layout there (run make_layouts.py first)")
            for tool in tools:
                lab = label if tool == "wellmesh" else tool
                rec = run_one(layout, tool, lab, args.out / name / f"seed{seed}", args.wellmesh,
                              wm_args, peer_args, args.mc_points)
                records = [r for r in records
                           if (r["layout"], r["seed"], r["tool"]) != (name, seed, lab)] + [rec]
                brief = ("failed" if rec.get("exit") else
                         f"IoU {rec['iou']:.3f} vol {rec['volume_error_pct']:+.1f}% "
                         f"bodies {rec['bodies']} wall {rec['wall_s']:.1f}s cpu {rec['cpu_s']:.1f}s "
                         f"peak {rec['peak_mb']:.0f}MB")
                print(f"{name} seed {seed} {lab}: {brief}", flush=True)
                results_path.write_text(json.dumps(records, indent=1, default=float))
                (args.out / "results.md").write_text(markdown(records))
    return 0


if __name__ == "__main__":
    sys.exit(main())
