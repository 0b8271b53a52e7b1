#!/usr/bin/env bash
# The real-GPU check, for a machine with a GPU but no Rust toolchain and no
# display (a GPU server): the GPU test binaries, the headless orbit benches
# and the emission bench, in one run that prints every figure.
#
#   benches/real_gpu.sh pack [DIR]   here: build, strip and pack the release
#                                    binary, the GPU test binaries and
#                                    ../shared/data into DIR/pack.tar.xz
#                                    (default .dev, which git should ignore)
#   benches/real_gpu.sh run [DIR]    there, from the repository root: unpack,
#                                    generate the grids and run everything;
#                                    figures and PNGs go to $OUT (default
#                                    /tmp/real-gpu; REAL_GPU_SMALL=1 uses
#                                    small grids, for a dry run)
#
# The test binaries keep the paths they were built with (the fixtures under
# this checkout, the CLI under target/release), so `run` links this checkout
# to the build's path when that path does not exist there.
set -uo pipefail
cmd=${1:-}
dir=${2:-.dev}
# The test binaries (tests/<name>/main.rs) and, after a colon, a filter:
# the whole gpu and view binaries, and the cli binary's GPU module only.
tests="gpu view cli:gpu::"
bins() { for t in $tests; do echo "${t%%:*}"; done; }

pack() {
  set -e
  cargo build --release
  cargo test --release --no-run $(printf -- '--test %s ' $(bins))
  local tmp
  tmp=$(mktemp -d)
  strip -o "$tmp/stratasweep" target/release/stratasweep
  for t in $(bins); do
    f=$(ls -t target/release/deps/"$t"-* | grep -v -e '\.d$' -e '\.rmeta$' | head -1)
    strip -o "$tmp/$t" "$f"
  done
  if [ -d ../shared/data ]; then cp -a ../shared/data "$tmp/data"; fi
  pwd >"$tmp/build_root"
  mkdir -p "$dir"
  tar -C "$tmp" -cf - . | xz -4 -T0 >"$dir/pack.tar.xz"
  rm -rf "$tmp"
  ls -l "$dir/pack.tar.xz"
}

run() {
  local out=${OUT:-/tmp/real-gpu} p=/tmp/real-gpu-pack t0
  mkdir -p "$out" "$p"
  exec > >(tee "$out/log.txt") 2>&1
  t0=$(date +%s)
  el() { echo "[+$(($(date +%s) - t0))s] $*"; }
  tar -C "$p" -xJf "$dir/pack.tar.xz" || exit 1
  local build_root
  build_root=$(cat "$p/build_root")
  if [ ! -e "$build_root" ]; then mkdir -p "$(dirname "$build_root")" && ln -s "$PWD" "$build_root"; fi
  mkdir -p target/release && cp "$p/stratasweep" target/release/
  local s=$PWD/target/release/stratasweep
  export STRATASWEEP_REQUIRE_GPU=1 RUST_BACKTRACE=1
  [ -d "$p/data" ] && export STRATASWEEP_DATA=$p/data
  nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv 2>/dev/null | tail -1
  lscpu | grep -E 'Model name|^CPU\(s\)'
  "$s" render --demo --size 64x48 --slices 8 -o /tmp/probe.png || exit 1
  local f=200,200,100 w=256,256,256
  [ -n "${REAL_GPU_SMALL:-}" ] && f=40,40,20 w=32,32,32
  ("$s" generate faulted --dims $f --faults 6 -o /tmp/f200.grdecl -q &&
    "$s" generate warped --dims $w -o /tmp/w256.vts -q) >/tmp/gen.log 2>&1 &
  local gen=$! failed=0
  el "GPU tests"
  for e in $tests; do
    local t=${e%%:*} filter=
    [ "$t" != "$e" ] && filter=${e#*:}
    timeout 300 "$p/$t" $filter --test-threads=4 >"$out/$t.txt" 2>&1 || failed=$((failed + 1))
    grep -E '^test result|panicked|FAILED' "$out/$t.txt" | cut -c1-400 | sed "s/^/$t: /"
  done
  el "tests done ($failed binaries failed)"
  wait $gen || { cat /tmp/gen.log; exit 1; }
  ob() {
    el "orbit $*"
    timeout 150 "$s" view "$@" --orbit-bench 24 --headless --json -q >/tmp/ob.json
    echo "rc=$? $(tr -d '\n ' </tmp/ob.json)"
  }
  ob --demo
  ob /tmp/f200.grdecl --slices 200
  ob /tmp/f200.grdecl --slices 200 --cells sweep
  ob /tmp/f200.grdecl --slices 500
  ob /tmp/f200.grdecl --slices 50 --preintegrated
  ob /tmp/f200.grdecl --slices 200 --size 1920x1080
  ob /tmp/w256.vts --slices 200
  el "render"
  /usr/bin/time -f '%e s %M KB' "$s" render /tmp/w256.vts -o "$out/w256.png" -q
  "$s" render /tmp/f200.grdecl --property PORO -o "$out/f200.png" --legend -q
  el "emission bench"
  timeout 150 "$s" bench /tmp/f200.grdecl --axis z --count 200 --device cpu,gpu -q
  el "end"
  exit $((failed > 0))
}

case $cmd in
pack) pack ;;
run) run ;;
*)
  sed -n '2,16p' "$0"
  exit 2
  ;;
esac
