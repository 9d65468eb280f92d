#!/usr/bin/env bash
# Every real data set in ../shared/data contours into closed bodies through the CLI, with an
# account of what was read. Usage: tests/real_data_contour.sh WELLMESH_BIN OUT_DIR
set -euo pipefail
bin=$1
out=$2
data="$(cd "$(dirname "$0")/../.." && pwd)/shared/data"
[ -d "$data" ] || { echo "no shared data at $data: skipped"; exit 0; }
mkdir -p "$out"
run() {
  local name=$1
  shift
  "$bin" contour "$@" -q -o "$out/$name.glb" --summary "$out/$name.json" 2>/dev/null
  python3 - "$out/$name.json" "$name" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
bodies = [b for shell in s["shells"] for b in shell["bodies"]]
open_ = [b for b in bodies if not b["closed"]]
inverted = [b for b in bodies if b["volume"] <= 0]
print(f"{sys.argv[2]:12} {len(bodies):4} bodies, {sum(b['truncated'] for b in bodies):3} truncated, "
      f"{len(open_)} open, {len(inverted)} of volume <= 0, "
      f"{sum(b['mt_fallback'] for b in bodies)} rebuilt by MT, "
      f"samples {s['counts'].get('samples')}, dropped unknown {s['counts'].get('unknown_dropped')}, "
      f"{len(s['warnings'])} warnings")
sys.exit(1 if open_ or inverted or not bodies else 0)
PY
}
d=$data/drilldown_tom_zone
run tom_zone --collars $d/collar.csv --surveys $d/survey.csv --intervals $d/assay.csv --variable Zn_pct -t 5
d=$data/drilldown_copper_creek
run copper_creek --collars $d/collar.csv --surveys $d/survey.csv --intervals $d/assay.csv --variable Cu_pct -t 0.3
d=$data/babbitt_pygslib
run babbitt --collars $d/collar_BABBITT.csv --surveys $d/survey_BABBITT.csv --intervals $d/assay_BABBITT.csv --variable CU --unit ft -t 0.3
d=$data/drilldown_forrestania
run forrestania --collars $d/collar.csv --surveys $d/survey.csv --intervals $d/assay.csv --variable Ni_ppm -t 1000
d=$data/thalanga_loopresources
run thalanga --collars $d/ThalangaML_collar.csv --surveys $d/ThalangaML_survey.csv --intervals $d/ThalangaML_Geology.csv --variable Lith1_Validated --inside MS
d=$data/ararangua_coal_geomod3D
run ararangua --collars $d/ara_collar.csv --intervals $d/ara_lito.csv --variable LITO --inside Carvão
d=$data/mcmurray_athabasca_las_subset
run mcmurray --las $d/logs --locations $d/DERIVED_wells_utm12_kb_tops.csv --variable GR -t 75
echo "all real data sets contoured into closed bodies"
