#!/usr/bin/env bash
# Runs the README's and CI's sample commands, and more covering every placement, --relax 0,
# anisotropy, the inspect reports, an input error and (with ../shared/data) the grid, LAS and
# drill-hole corpora, with two wellmesh binaries, and compares every output file, standard
# output, standard error and exit code byte for byte: the check that a restructuring kept
# the program's behaviour. Both binaries write into the same path, so messages naming files
# compare too.
# Usage, from the repository root: tests/e2e/compare_outputs.sh OLD_BIN NEW_BIN OUT_DIR
# (OUT_DIR must not exist). Build the old binary from `git archive OLD | tar -x -C DIR`.
set -uo pipefail
old=$1 new=$2 out=$3
[ -e "$out" ] && { echo "$out exists: give a new directory"; exit 2; }
mkdir -p "$out"
S=../shared/data
cmds=(
  "copper|contour sample_wells/copper_wells.csv --crs EPSG:32633 -o @/copper.glb --summary @/copper.json --tileset @/tiles --geojson @/copper.geojson --obj @/copper.obj --vtu @/copper.vtu"
  "grade|contour sample_wells/copper_grade.csv --crs EPSG:32633 -t 0.5 -t 1.0 --method ibc -o @/grade.glb --summary @/grade.json"
  "grade_mt|contour sample_wells/copper_grade.csv -t 0.5 --method mt -o @/grade_mt.glb --summary @/grade_mt.json"
  "grade_coi|contour sample_wells/copper_grade.csv -t 0.5 -t 1.0 --method coi -o @/grade_coi.glb --summary @/grade_coi.json"
  "grade_coi0|contour sample_wells/copper_grade.csv -t 0.5 --method coi --relax 0 -o @/grade_coi0.glb --summary @/grade_coi0.json"
  "grade_ibc0|contour sample_wells/copper_grade.csv -t 0.5 --method ibc --relax 0 -o @/grade_ibc0.glb --summary @/grade_ibc0.json"
  "grade_mid|contour sample_wells/copper_grade.csv -t 0.5 --method midpoint -o @/grade_mid.glb --summary @/grade_mid.json"
  "grade_dist|contour sample_wells/copper_grade.csv -t 0.5 --method distance -o @/grade_dist.glb --summary @/grade_dist.json"
  "grade_curv|contour sample_wells/copper_grade.csv -t 0.5 --method curvature --lattice 5 -o @/grade_curv.glb --summary @/grade_curv.json"
  "wells_curv|contour sample_wells/copper_wells.csv --threshold 0.5 --method curvature -o @/w.glb --summary @/w.json"
  "wells_dist|contour sample_wells/copper_wells.csv --method distance -o @/wd.glb --summary @/wd.json"
  "wells_mid|contour sample_wells/copper_wells.csv --method midpoint -o @/wm.glb --summary @/wm.json"
  "dh|contour --collars sample_wells/copper_collars.csv --surveys sample_wells/copper_surveys.csv --intervals sample_wells/copper_assays.csv --variable cu --threshold 0.5 --threshold 1 --method ibc --relax 3 -o @/t.glb --summary @/t.json"
  "tom|contour --collars sample_wells/tom_zone/collar.csv --surveys sample_wells/tom_zone/survey.csv --intervals sample_wells/tom_zone/assay.csv --variable Zn_pct --threshold 5 --crs EPSG:32609 -o @/tom_zn5.glb --summary @/tom_zn5.json --tileset @/tom"
  "tom_aniso|contour --collars sample_wells/tom_zone/collar.csv --surveys sample_wells/tom_zone/survey.csv --intervals sample_wells/tom_zone/assay.csv --variable Zn_pct --threshold 5 --anisotropy 1,1,3 --azimuth 30 --dip 10 -o @/tom_an.glb --summary @/tom_an.json"
  "tsbf|contour --collars sample_wells/tom_zone/collar.csv --surveys sample_wells/tom_zone/survey.csv --intervals sample_wells/tom_zone/interp.csv --variable code --inside TSBF --threshold 0.5 --method curvature -o @/tsbf.glb --summary @/tsbf.json"
  "tom_inspect|inspect --collars sample_wells/tom_zone/collar.csv --surveys sample_wells/tom_zone/survey.csv --intervals sample_wells/tom_zone/assay.csv --variable Zn_pct --json"
  "forrestania_inspect|inspect --collars sample_wells/forrestania/collar.csv --surveys sample_wells/forrestania/survey.csv --intervals sample_wells/forrestania/assay.csv --json"
  "nlog_error|inspect --las sample_wells/nlog_l07 --variable GR --json"
  "headsq|contour --grid $S/vtk_headsq/quarter.nhdr -t 1000 -o @/headsq.glb --summary @/headsq.json"
  "cc|contour --collars $S/drilldown_copper_creek/collar.csv --surveys $S/drilldown_copper_creek/survey.csv --intervals $S/drilldown_copper_creek/assay.csv --variable Cu_pct -t 0.3 -o @/cc.glb --summary @/cc.json"
  "babbitt|contour --collars $S/babbitt_pygslib/collar_BABBITT.csv --surveys $S/babbitt_pygslib/survey_BABBITT.csv --intervals $S/babbitt_pygslib/assay_BABBITT.csv --variable CU --unit ft -t 0.3 -o @/bab.glb --summary @/bab.json"
  "thalanga|contour --collars $S/thalanga_loopresources/ThalangaML_collar.csv --surveys $S/thalanga_loopresources/ThalangaML_survey.csv --intervals $S/thalanga_loopresources/ThalangaML_Geology.csv --variable Lith1_Validated --inside MS -o @/th.glb --summary @/th.json"
  "ararangua|contour --collars $S/ararangua_coal_geomod3D/ara_collar.csv --intervals $S/ararangua_coal_geomod3D/ara_lito.csv --variable LITO --inside Carvão -o @/ara.glb --summary @/ara.json"
  "mcmurray|contour --las $S/mcmurray_athabasca_las_subset/logs --locations $S/mcmurray_athabasca_las_subset/DERIVED_wells_utm12_kb_tops.csv --variable GR -t 75 -o @/mc.glb --summary @/mc.json"
  "forrestania|contour --collars $S/drilldown_forrestania/collar.csv --surveys $S/drilldown_forrestania/survey.csv --intervals $S/drilldown_forrestania/assay.csv --variable Ni_ppm -t 1000 -o @/fo.glb --summary @/fo.json"
  "bad|contour @/../bad.csv -o @/bad.glb"
)
printf 'well,x,y,z,value\nA,1,2,nan,1\n' > "$out/bad.csv"
for side in old new; do
  bin=$old; [ $side = new ] && bin=$new
  dir="$out/cur"; mkdir -p "$dir"
  for entry in "${cmds[@]}"; do
    tag=${entry%%|*}; args=${entry#*|}
    if [[ $args == *'$S'* || $args == *"$S"* ]] && [ ! -d "$S" ]; then
      echo "$tag: skipped, needs $S" >"$dir/$tag.stdout"; continue
    fi
    eval "set -- ${args//@/$dir}"
    extra=(); [ "$1" = contour ] && extra=(-q)
    "$bin" "$@" "${extra[@]}" >"$dir/$tag.stdout" 2>"$dir/$tag.stderr"
    echo "exit $?" >>"$dir/$tag.stdout"
  done
  mv "$dir" "$out/$side"
done
if diff -r "$out/old" "$out/new" >"$out/diff.txt"; then
  echo "identical: $(find "$out/new" -type f | wc -l) files, $(du -sh "$out/new" | cut -f1)"
else
  echo "DIFFERENT:"; head -50 "$out/diff.txt"; exit 1
fi
