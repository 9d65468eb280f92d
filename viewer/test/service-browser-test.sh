#!/usr/bin/env bash
# The viewer's real-browser test against a real `wellmesh serve`: starts the service on a
# free loopback port with a scratch data directory, submits one asynchronous contour job
# from a samples CSV (OGC API - Processes execute, `Prefer: respond-async`), and runs
# viewer/test/browser.mjs on that job (the page itself waits for the job to finish).
#
# Usage: viewer/test/service-browser-test.sh WELLMESH_BIN SAMPLES.csv THRESHOLD [OUT.png]
# Needs: node with `npm ci --prefix viewer` done, curl, /usr/bin/chromium.
set -euo pipefail
if [ $# -lt 3 ]; then
  echo "usage: $0 WELLMESH_BIN SAMPLES.csv THRESHOLD [OUT.png]" >&2
  exit 2
fi
bin=$1
csv=$2
threshold=$3
out=${4:-viewer-screenshot.png}
here=$(cd "$(dirname "$0")" && pwd)
viewer_dir=$(cd "$here/.." && pwd)

data=$(mktemp -d)
port=$(node -e 'const s = require("net").createServer().listen(0, "127.0.0.1", () => { console.log(s.address().port); s.close(); })')
base="http://127.0.0.1:$port"
"$bin" serve --bind "127.0.0.1:$port" --data-dir "$data/store" --viewer-dir "$viewer_dir" \
  >"$data/serve.log" 2>&1 &
server=$!
cleanup() {
  kill "$server" 2>/dev/null || true
  wait "$server" 2>/dev/null || true
  rm -rf "$data"
}
trap cleanup EXIT

for _ in $(seq 150); do
  if curl -sf "$base/" >/dev/null; then break; fi
  if ! kill -0 "$server" 2>/dev/null; then
    echo "wellmesh serve exited:" >&2
    cat "$data/serve.log" >&2
    exit 1
  fi
  sleep 0.2
done

node -e '
  const fs = require("fs");
  const [csv, threshold, out] = process.argv.slice(1);
  const inputs = { samples_csv: fs.readFileSync(csv, "utf8"), thresholds: [Number(threshold)], density: 2.7 };
  fs.writeFileSync(out, JSON.stringify({ inputs }));
' "$csv" "$threshold" "$data/request.json"
location=$(curl -sf -D - -o "$data/response.json" -X POST \
  -H 'Content-Type: application/json' -H 'Prefer: respond-async' \
  --data-binary "@$data/request.json" "$base/processes/dmt-contour/execution" |
  tr -d '\r' | awk 'tolower($1) == "location:" { print $2 }')
job=${location##*/}
if [ -z "$job" ]; then
  echo "the service answered no job location:" >&2
  cat "$data/response.json" >&2 || true
  exit 1
fi
echo "job $job at $base"
node "$here/browser.mjs" "$base" "$job" "$out"
