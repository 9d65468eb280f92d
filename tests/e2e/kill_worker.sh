#!/usr/bin/env bash
# End-to-end: a process running a job is killed with SIGKILL mid-job; the job still
# completes on another process, exactly once, and no job is lost.
#
#   tests/e2e/kill_worker.sh [sqlite|postgres|all]   (default: all)
#
# sqlite:   `wellmesh serve` (embedded SQLite) is killed mid-job and restarted on the
#           same data directory; the job completes after the restart.
# postgres: one API node (`serve --workers 0`) and two `wellmesh worker`s share
#           PostgreSQL ($WELLMESH_TEST_DATABASE_URL); the worker holding the job is
#           killed; the other one completes it.
# Needs curl, python3 and (for postgres) psql. WELLMESH_BIN overrides the binary.
set -euo pipefail

MODE="${1:-all}"
ROOT="$(cd "$(dirname "$0")/../.." && pwd)"
BIN="${WELLMESH_BIN:-$ROOT/target/release/wellmesh}"
[ -x "$BIN" ] || BIN="$ROOT/target/debug/wellmesh"
[ -x "$BIN" ] || { echo "build wellmesh first (cargo build --release)"; exit 1; }
WORK="$(mktemp -d)"
PIDS=()
cleanup() {
    for pid in "${PIDS[@]:-}"; do
        [ -n "$pid" ] && kill -9 "$pid" 2>/dev/null || true
    done
    rm -rf "$WORK"
}
trap cleanup EXIT

fail() { echo "FAIL: $*" >&2; for f in "$WORK"/*.log; do echo "--- $f"; tail -20 "$f"; done >&2; exit 1; }

free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }

# A lattice of vertical wells, big enough that contouring takes a few seconds.
make_request() {
    python3 - "$1" <<'PY'
import json, math, sys
n = int(sys.argv[1])
rows = ["well,x,y,z,value"]
for i in range(n):
    for j in range(n):
        for k in range(40):
            x, y, z = 500000 + 10 * i + 0.37 * j, 7000000 + 10 * j + 0.29 * i, 300 - 2.5 * k
            r = math.sqrt((i - n / 2) ** 2 + (j - n / 2) ** 2 + ((k - 20) * 0.6) ** 2)
            rows.append(f"h{i}_{j},{x:.3f},{y:.3f},{z:.3f},{1 if r < n / 3 else 0}")
print(json.dumps({"inputs": {"samples_csv": "\n".join(rows) + "\n", "thresholds": [0.5]}}))
PY
}

wait_http() {
    for _ in $(seq 1 200); do
        curl -fsS "$1/healthz" >/dev/null 2>&1 && return 0
        sleep 0.1
    done
    fail "server at $1 did not start"
}

status_of() { curl -fsS "$1/jobs/$2" | python3 -c 'import json,sys; print(json.load(sys.stdin)["status"])'; }

submit() {
    curl -fsS -D "$WORK/headers" -H 'Content-Type: application/json' -H 'Prefer: respond-async' \
        --data-binary @"$2" "$1/processes/dmt-contour/execution" \
        | python3 -c 'import json,sys; print(json.load(sys.stdin)["jobID"])'
}

wait_status() { # base job wanted seconds
    for _ in $(seq 1 $(( $4 * 10 ))); do
        s="$(status_of "$1" "$2")"
        [ "$s" = "$3" ] && return 0
        case "$s" in failed|dismissed) fail "job $2 is $s: $(curl -fsS "$1/jobs/$2")";; esac
        sleep 0.1
    done
    fail "job $2 never became $3 (is $(status_of "$1" "$2"))"
}

check_results() { # base job
    curl -fsS "$1/jobs/$2/results" > "$WORK/results.json" || fail "no results for $2"
    python3 - "$WORK/results.json" <<'PY' || fail "results of $2 are incomplete"
import json, sys
doc = json.load(open(sys.argv[1]))
assert "summary" in doc and doc["summary"]["shells"], doc
PY
}

LEASE=(--lease-secs 2 --heartbeat-ms 200)

run_sqlite() {
    echo "== sqlite: kill serve mid-job, restart, job completes"
    local port base data pid job other
    port="$(free_port)"; base="http://127.0.0.1:$port"; data="$WORK/data"
    make_request 60 > "$WORK/big.json"
    "$BIN" serve --bind "127.0.0.1:$port" --data-dir "$data" "${LEASE[@]}" >"$WORK/serve1.log" 2>&1 &
    pid=$!; PIDS+=("$pid")
    wait_http "$base"
    job="$(submit "$base" "$WORK/big.json")"
    other="$(submit "$base" "$WORK/big.json")"
    wait_status "$base" "$job" running 60
    kill -9 "$pid"; wait "$pid" 2>/dev/null || true
    echo "killed serve (pid $pid) while job $job was running"
    "$BIN" serve --bind "127.0.0.1:$port" --data-dir "$data" "${LEASE[@]}" >"$WORK/serve2.log" 2>&1 &
    pid=$!; PIDS+=("$pid")
    wait_http "$base"
    wait_status "$base" "$job" successful 600
    wait_status "$base" "$other" successful 600
    check_results "$base" "$job"
    check_results "$base" "$other"
    curl -fsS "$base/jobs/$job/results/summary" >/dev/null || fail "summary output missing"
    kill -TERM "$pid"; wait "$pid" 2>/dev/null || true
    echo "ok: job $job completed after the restart"
}

run_postgres() {
    local url="${WELLMESH_TEST_DATABASE_URL:-${DATABASE_URL:-}}"
    [ -n "$url" ] || { echo "== postgres: skipped (set WELLMESH_TEST_DATABASE_URL)"; return 0; }
    echo "== postgres: two workers, the one holding the job is killed"
    local schema="e2e_$(date +%s)_$$" port base api w1 w2 job other holder
    psql "$url" -qc "CREATE SCHEMA $schema" >/dev/null
    local db="$url"; case "$url" in *\?*) db="$url&options=-csearch_path%3D$schema";; *) db="$url?options=-csearch_path%3D$schema";; esac
    port="$(free_port)"; base="http://127.0.0.1:$port"
    make_request 60 > "$WORK/big.json"
    "$BIN" serve --bind "127.0.0.1:$port" --database-url "$db" --workers 0 >"$WORK/api.log" 2>&1 &
    api=$!; PIDS+=("$api")
    wait_http "$base"
    HOSTNAME=w1 "$BIN" worker --database-url "$db" "${LEASE[@]}" >"$WORK/w1.log" 2>&1 &
    w1=$!; PIDS+=("$w1")
    job="$(submit "$base" "$WORK/big.json")"
    wait_status "$base" "$job" running 60
    HOSTNAME=w2 "$BIN" worker --database-url "$db" "${LEASE[@]}" >"$WORK/w2.log" 2>&1 &
    w2=$!; PIDS+=("$w2")
    other="$(submit "$base" "$WORK/big.json")"
    holder="$(psql "$db" -Atc "SELECT lease_owner FROM jobs WHERE id = '$job'")"
    case "$holder" in w1-*) ;; *) fail "job $job held by $holder, expected w1";; esac
    kill -9 "$w1"; wait "$w1" 2>/dev/null || true
    echo "killed worker w1 (pid $w1) while it held job $job"
    wait_status "$base" "$job" successful 600
    wait_status "$base" "$other" successful 600
    check_results "$base" "$job"
    check_results "$base" "$other"
    local attempts outputs
    attempts="$(psql "$db" -Atc "SELECT attempt FROM jobs WHERE id = '$job'")"
    outputs="$(psql "$db" -Atc "SELECT count(*) FROM job_outputs WHERE job_id = '$job' AND output_id = 'summary'")"
    [ "$attempts" = 2 ] || fail "job $job ran $attempts times, expected 2 (killed once, completed once)"
    [ "$outputs" = 1 ] || fail "job $job has $outputs summaries"
    grep -q "job successful" "$WORK/w2.log" || fail "w2 did not complete the job"
    kill -TERM "$w2" "$api"; wait "$w2" "$api" 2>/dev/null || true
    psql "$url" -qc "DROP SCHEMA $schema CASCADE" >/dev/null
    echo "ok: job $job completed on w2 after w1 was killed, exactly once"
}

case "$MODE" in
    sqlite) run_sqlite ;;
    postgres) run_postgres ;;
    all) run_sqlite; run_postgres ;;
    *) echo "usage: $0 [sqlite|postgres|all]"; exit 2 ;;
esac
echo "e2e: 1 passed, 0 failed"
