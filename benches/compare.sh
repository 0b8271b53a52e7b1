#!/usr/bin/env bash
# Runs a fixed set of slice, info and render commands on the demo grid and
# the real grids in $STRATASWEEP_DATA, writing every output into DIR, so that
# two builds can be compared byte for byte:
#   benches/compare.sh BIN DIR            # run
#   diff -r DIR_BEFORE DIR_AFTER          # compare
# The PNGs come from whatever adapter wgpu picks (llvmpipe in CI).
set -euo pipefail
bin=${1:?usage: compare.sh BIN DIR}
out=${2:?usage: compare.sh BIN DIR}
data=${STRATASWEEP_DATA:?set STRATASWEEP_DATA to the shared data folder}
mkdir -p "$out"
run() { local name=$1; shift; "$bin" "$@" -q >"$out/$name.log" 2>&1 || echo "exit $?" >>"$out/$name.log"; }

grids=(
  "reek:$data/reek/2_R001_REEK-0.EGRID"
  "spe10:$data/spe10m1/SPE10_MODEL1_CP.DATA"
  "brugge:$data/restart/BRUGGE_0010.EGRID"
  "pebi:$data/geos/pebi3d_with_properties.vtu"
  "hybrid:$data/geos/hybridHexPrismMesh.vtk"
  "elements:$data/geos/supportedElements.vtk"
  "celltypes:$data/pyvista/VTKCellTypes.vtk"
)
run demo_info info --demo --json
run demo_slice slice --demo --axis z --count 50 -o "$out/demo_slice.vtp" --stats "$out/demo_slice.json"
run demo_slice_gpu slice --demo --axis x --count 30 --device gpu --stats "$out/demo_slice_gpu.json"
run demo_iso slice --demo --property f --values 0.3:0.6:0.1 -o "$out/demo_iso.vtp"
for g in "${grids[@]}"; do
  name=${g%%:*}; path=${g#*:}
  run "${name}_info" info "$path" --json
  run "${name}_slice" slice "$path" --axis z --count 40 -o "$out/${name}_slice.vtp" --stats "$out/${name}_slice.json"
  run "${name}_slicex" slice "$path" --axis x --count 20 -o "$out/${name}_slicex.ply"
  run "${name}_render" render "$path" --size 320x240 -o "$out/${name}_render.png"
done
run demo_render render --demo --size 320x240 -o "$out/demo_render.png"
run demo_render_pre render --demo --size 320x240 --preintegrated --slices 50 -o "$out/demo_render_pre.png"
run demo_render_iso render --demo --size 320x240 --mode iso --iso 0.4,0.6 -o "$out/demo_render_iso.png"
run demo_render_slices render --demo --size 320x240 --mode slices --transfer magma --projection perspective -o "$out/demo_render_slices.png"
run reek_render_legend render "$data/reek/2_R001_REEK-0.EGRID" --size 400x300 --legend --preintegrated -o "$out/reek_render_legend.png"
run demo_view view --demo --headless --frames 1 --size 320x240 --screenshot "$out/demo_view.png"
# Timings differ from run to run: replace the numbers of the timing keys.
sed -i -E 's/^(\s*"([a-z_]*_s|build|field|load|minima|sweep|parse_mb_per_s|[a-z_]*_ms|[a-z_]*seconds)"): -?[0-9.e+-]+/\1: "TIME"/' "$out"/*.json "$out"/*.log
