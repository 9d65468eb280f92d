#!/usr/bin/env python3
"""Peak RSS of `wellmesh serve` in the reliability suite's uploads case, and in its halves.

    bench/service_memory.py BINARY [--interpolant kriging|linear] [--load both|downloads|uploads]
                                   [--worker separate|embedded]

Replays `tests/e2e/reliability.py`'s uploads case with that file's own server and request
helpers: `serve --max-large-uploads 3`, one synchronous job on sample_wells/copper_grade.csv
with thresholds 0.25, 0.5 and 1.0 (the GLB the clients download; kriging unless
--interpolant linear), then 8 concurrent uploads of a 34 MB samples CSV and 16 concurrent
downloads of that GLB (--load both), or only one of the two. With --worker separate (the
case's layout) the server is an API node (`--workers 0`) and a `wellmesh worker` process on
its SQLite file computes the GLB and is stopped before the load; with --worker embedded the
server runs `--workers 1`, whose worker starts computing an uploaded 1.4M-sample job during
the load. Prints the GLB's size, VmHWM and VmRSS of the server after the job, the peak VmRSS
sampled every 20 ms from /proc/PID/status while the load runs, VmHWM after it, and the
uploads' answers.
"""

import argparse
import concurrent.futures
import json
import os
import sys
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("binary")
parser.add_argument("--interpolant", choices=["kriging", "linear"], default="kriging")
parser.add_argument("--load", choices=["both", "downloads", "uploads"], default="both")
parser.add_argument("--worker", choices=["separate", "embedded"], default="separate")
args = parser.parse_args()
sys.path.insert(0, os.path.join(HERE, "..", "tests", "e2e"))
sys.argv = [sys.argv[0], args.binary]  # reliability.py reads the binary from argv
import reliability  # noqa: E402


def status_mb(pid, key):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith(key):
                return int(line.split()[1]) / 1024
    return 0.0


def main():
    embedded = args.worker == "embedded"
    server = reliability.Server("--workers", "1" if embedded else "0", "--max-large-uploads", "3")
    worker = None
    if not embedded:
        worker = reliability.start_worker(server)
    try:
        inputs = {"samples_csv": reliability.SAMPLES, "thresholds": [0.25, 0.5, 1.0]}
        if args.interpolant == "linear":
            inputs["interpolant"] = "linear"
        status, _, body = reliability.execute(server, inputs, prefer_async=False)
        assert status == 200, body[:300]
        href = json.loads(body)["glb"]["href"]
        glb = reliability.request("GET", server.base + href)[2]
        if worker is not None:
            reliability.stop_worker(worker)
        pid = server.process.pid
        after_job = (status_mb(pid, "VmHWM:"), status_mb(pid, "VmRSS:"))
        big = ("well,x,y,z,value\n" + "".join(
            f"w{i % 97},{i % 1000}.5,{i // 1000}.25,{i % 37}.75,{i % 2}\n" for i in range(1_400_000)
        ))[: 34 * 1024 * 1024]
        payload = json.dumps({"inputs": {"samples_csv": big, "thresholds": [0.5]}}).encode()
        peak = [0.0]
        stop = threading.Event()

        def sample():
            while not stop.is_set():
                peak[0] = max(peak[0], status_mb(pid, "VmRSS:"))
                time.sleep(0.02)

        codes = []

        def upload(_):
            status, _, _ = reliability.request(
                "POST", server.base + "/processes/dmt-contour/execution", payload,
                {"Content-Type": "application/json", "Prefer": "respond-async"}, timeout=120)
            codes.append(status)

        def download(_):
            status, _, body = reliability.request("GET", server.base + href, timeout=60)
            assert status == 200 and body == glb

        sampler = threading.Thread(target=sample)
        sampler.start()
        started = time.time()
        with concurrent.futures.ThreadPoolExecutor(24) as pool:
            work = []
            if args.load in ("both", "uploads"):
                work += [pool.submit(upload, i) for i in range(8)]
            if args.load in ("both", "downloads"):
                work += [pool.submit(download, i) for i in range(16)]
            for done in work:
                done.result()
        took = time.time() - started
        stop.set()
        sampler.join()
        print(f"{args.interpolant} GLB {len(glb) / 1e6:.1f} MB, load {args.load}, {args.worker} "
              f"worker: after the job "
              f"VmHWM {after_job[0]:.0f} MB, VmRSS {after_job[1]:.0f} MB; load {took:.1f} s, peak "
              f"VmRSS sampled {peak[0]:.0f} MB, VmHWM {status_mb(pid, 'VmHWM:'):.0f} MB; "
              f"uploads answered {sorted(codes)}")
    finally:
        if worker is not None and worker.poll() is None:
            worker.kill()
            worker.wait()
        server.stop()


if __name__ == "__main__":
    main()
