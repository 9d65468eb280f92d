#!/usr/bin/env python3
"""Sync-job throughput of `wellmesh serve` on the sample wells (Python stdlib only).

    bench/service_throughput.py [BINARY] [--clients 8] [--seconds 30] [--interpolant linear]
                                [--thresholds 0.5] [--samples sample_wells/copper_wells.csv]
                                [--workers N] [--markdown]

Starts `wellmesh serve` on a free loopback port with a fresh data directory (SQLite, every
other flag at its default unless given), posts one warm-up job, then runs CLIENTS threads
for SECONDS, each posting synchronous executions of the README's walk-through request
(`{"inputs": {"samples_csv": <the file>, "thresholds": [...]}}`) back to back over one
keep-alive connection, and prints: jobs completed, jobs/s, latency p50/p90/p99/max,
errors (any answer but 200 with a results document), the server's CPU seconds per job
(utime + stime from /proc) and its peak RSS (VmHWM). Without --interpolant the request
leaves it out, so the service's default (kriging) applies.
"""

import argparse
import http.client
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CLOCK_TICKS = os.sysconf("SC_CLK_TCK")


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def cpu_seconds(pid):
    """utime + stime of a process, in seconds (fields 14 and 15 of /proc/PID/stat)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS


def peak_rss_mb(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    return 0.0


def percentile(sorted_values, q):
    if not sorted_values:
        return float("nan")
    index = min(len(sorted_values) - 1, max(0, round(q * (len(sorted_values) - 1))))
    return sorted_values[index]


class Client:
    """One keep-alive connection; reconnects after a failure."""

    def __init__(self, port):
        self.port = port
        self.connection = None

    def post(self, path, body):
        if self.connection is None:
            self.connection = http.client.HTTPConnection("127.0.0.1", self.port, timeout=120)
        try:
            self.connection.request("POST", path, body, {"Content-Type": "application/json"})
            answer = self.connection.getresponse()
            return answer.status, answer.read()
        except (OSError, http.client.HTTPException):
            self.connection.close()
            self.connection = None
            raise


def run(args):
    samples = open(args.samples).read()
    inputs = {"samples_csv": samples, "thresholds": args.thresholds}
    if args.interpolant:
        inputs["interpolant"] = args.interpolant
    body = json.dumps({"inputs": inputs}).encode()
    path = "/processes/dmt-contour/execution"

    port = free_port()
    data = tempfile.mkdtemp(prefix="wellmesh-throughput-")
    flags = ["serve", "--bind", f"127.0.0.1:{port}", "--data-dir", data]
    if args.workers is not None:
        flags += ["--workers", str(args.workers)]
    log = open(os.path.join(data, "serve.log"), "w")
    server = subprocess.Popen([args.binary, *flags], stdout=log, stderr=subprocess.STDOUT)
    try:
        deadline = time.time() + 20
        while True:
            try:
                connection = http.client.HTTPConnection("127.0.0.1", port, timeout=1)
                connection.request("GET", "/healthz")
                connection.getresponse().read()
                break
            except OSError:
                if time.time() > deadline:
                    raise RuntimeError("serve did not start")
                time.sleep(0.05)
        status, warm = Client(port).post(path, body)
        if status != 200:
            raise RuntimeError(f"warm-up job answered {status}: {warm[:300]!r}")
        connection = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
        connection.request("GET", json.loads(warm)["glb"]["href"])
        glb_bytes = len(connection.getresponse().read())
        connection.close()

        latencies = []
        errors = []
        lock = threading.Lock()
        start_cpu = cpu_seconds(server.pid)
        started = time.monotonic()
        stop_at = started + args.seconds

        def client_loop():
            client = Client(port)
            while time.monotonic() < stop_at:
                sent = time.monotonic()
                try:
                    status, answer = client.post(path, body)
                    ok = status == 200 and b'"glb"' in answer
                    reason = f"{status}: {answer[:200]!r}"
                except (OSError, http.client.HTTPException) as error:
                    ok, reason = False, repr(error)
                took = time.monotonic() - sent
                with lock:
                    if ok:
                        latencies.append(took)
                    else:
                        errors.append(reason)

        threads = [threading.Thread(target=client_loop) for _ in range(args.clients)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        elapsed = time.monotonic() - started
        cpu = cpu_seconds(server.pid) - start_cpu
        latencies.sort()
        jobs = len(latencies)
        figures = {
            "interpolant": args.interpolant or "kriging (default)",
            "clients": args.clients,
            "workers": args.workers if args.workers is not None else "default",
            "seconds": round(elapsed, 1),
            "jobs": jobs,
            "jobs_per_s": round(jobs / elapsed, 1),
            "p50_ms": round(1000 * percentile(latencies, 0.50), 1),
            "p90_ms": round(1000 * percentile(latencies, 0.90), 1),
            "p99_ms": round(1000 * percentile(latencies, 0.99), 1),
            "max_ms": round(1000 * (latencies[-1] if latencies else float("nan")), 1),
            "errors": len(errors),
            "server_cpu_s_per_job": round(cpu / jobs, 4) if jobs else None,
            "server_cpu_cores_busy": round(cpu / elapsed, 2),
            "peak_rss_mb": round(peak_rss_mb(server.pid)),
            "glb_bytes": glb_bytes,
        }
        if errors:
            figures["first_error"] = errors[0]
        return figures
    finally:
        server.terminate()
        try:
            server.wait(timeout=40)
        except subprocess.TimeoutExpired:
            server.kill()
            server.wait()
        shutil.rmtree(data, ignore_errors=True)  # 30 s of jobs store hundreds of MB


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("binary", nargs="?", default=os.path.join(ROOT, "target/release/wellmesh"))
    parser.add_argument("--clients", type=int, default=8)
    parser.add_argument("--seconds", type=float, default=30)
    parser.add_argument("--interpolant", choices=["kriging", "linear"])
    parser.add_argument("--thresholds", type=float, nargs="+", default=[0.5])
    parser.add_argument("--samples", default=os.path.join(ROOT, "sample_wells/copper_wells.csv"))
    parser.add_argument("--workers", type=int, help="serve --workers (default: serve's own)")
    parser.add_argument("--markdown", action="store_true", help="print one table row")
    args = parser.parse_args()
    figures = run(args)
    if args.markdown:
        print(f"| {figures['interpolant']} | {figures['workers']} | {figures['clients']} | "
              f"{figures['seconds']} | {figures['jobs']} | {figures['jobs_per_s']} | "
              f"{figures['p50_ms']} | {figures['p99_ms']} | {figures['errors']} | "
              f"{figures['server_cpu_s_per_job']} | {figures['peak_rss_mb']} |")
    else:
        print(json.dumps(figures, indent=2))
    sys.exit(1 if figures["errors"] else 0)


if __name__ == "__main__":
    main()
