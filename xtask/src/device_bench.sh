#!/bin/sh
# The device run of a bundle written by `cargo xtask device-bench --prepare` (MANIFEST.txt says
# what it holds). Runs every benchmark of the `tests` package and a short `restir-demo compare`,
# in the order below (most valuable first), each step killed past its own time budget:
#
#   device (restir-demo info), scan (2^20, 2^24, 2^25), the scan shape sweep (2^24, 2^25, one
#   run per workgroup size x items per thread), hash, trace, restir_gi, world_restir, floors,
#   reservoir, cache, denoise, history, compare (ris, restir-di, restir-gi, world-restir-gi and
#   restir-di+world-restir-gi+world-restir at equal time against ris) at 256x256 on many-lights
#   and cornell, 16 frames, and at 1920x1080 on many-lights, 8 frames.
#
# A step's budget is its share of --budget (per mille below) plus what the steps before it left
# unused, so the run ends within --budget (and the binaries' unpacking). Into --out it writes at
# most 7 files: results.txt (every RESULT line), device.txt, compare-256.md/.json,
# compare-1080.md/.json and log.txt (every step's output, its time and how it ended).
#
#   run.sh [--budget SECONDS] [--out DIR] [--lavapipe]
#
# --lavapipe: the same steps at small sizes (criterion in its test mode, trace without Sponza,
# compare at 64x64 and 96x54 for 2 frames) within 150 s unless --budget says otherwise: a CI-like check on a CPU.
# Exit status 1 when a step failed (a timeout is not a failure: it is noted), 2 on bad usage.
set -u

usage() {
    awk 'NR > 1 && !/^#/ { exit } NR > 1 { sub(/^# ?/, ""); print }' "$0"
}

budget=""
out=./device-bench-out
lavapipe=0
while [ $# -gt 0 ]; do
    case $1 in
    --budget | --out)
        [ $# -ge 2 ] || { echo "run.sh: $1 needs a value" >&2; exit 2; }
        if [ "$1" = --budget ]; then budget=$2; else out=$2; fi
        shift 2 ;;
    --lavapipe) lavapipe=1; shift ;;
    -h | --help) usage; exit 0 ;;
    *) echo "run.sh: unknown argument $1 (see --help)" >&2; exit 2 ;;
    esac
done
if [ -z "$budget" ]; then
    if [ $lavapipe = 1 ]; then budget=150; else budget=480; fi
fi
case $budget in
'' | *[!0-9]*) echo "run.sh: --budget takes whole seconds, not '$budget'" >&2; exit 2 ;;
esac
for tool in timeout gzip; do
    command -v $tool >/dev/null || { echo "run.sh: needs $tool (coreutils, gzip)" >&2; exit 2; }
done

here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$out" && out=$(cd "$out" && pwd) || exit 2
files="results.txt device.txt compare-256.md compare-256.json compare-1080.md compare-1080.json log.txt"
for f in $files; do rm -f "$out/$f"; done
log=$out/log.txt
work=$(mktemp -d "${TMPDIR:-/tmp}/device-bench.XXXXXX") || exit 2
trap 'rm -rf "$work"' EXIT
trap 'exit 130' INT TERM
say() { echo "$*" | tee -a "$log"; }

# The binaries: as they are, or gzipped (a bundle over 64 MiB unpacked) into the work directory.
bin=$work/bin
mkdir -p "$bin"
for f in "$here"/bin/*; do
    case $f in
    *.gz) gzip -dc "$f" >"$bin/$(basename "$f" .gz)" && chmod +x "$bin/$(basename "$f" .gz)" ;;
    *) ln -s "$f" "$bin/$(basename "$f")" ;;
    esac
done

# wgpu opens libvulkan.so.1 with dlopen: the machine's own loader first, the bundle's if it has
# none. The driver (ICD) must be the machine's.
if ! { ldconfig -p 2>/dev/null | grep -q 'libvulkan\.so\.1 '; } && [ -e "$here/lib/libvulkan.so.1" ]; then
    LD_LIBRARY_PATH=$here/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
    export LD_LIBRARY_PATH
    say "no libvulkan.so.1 on this machine: using the bundle's ($here/lib)"
fi
# trace's Sponza; without the scenes the bench prints a skip line and runs the built-in scenes.
RESTIR_SCENES_DIR=$here/scenes
CRITERION_HOME=$work/criterion
export RESTIR_SCENES_DIR CRITERION_HOME

start=$(date +%s)
shares=0
failed=""
timed_out=""
say "device-bench: budget ${budget}s, lavapipe=$lavapipe, bundle $here, out $out, $(date -u '+%Y-%m-%d %H:%M:%S UTC')"
[ -f "$here/MANIFEST.txt" ] && sed -n '1,3p' "$here/MANIFEST.txt" >>"$log"

# step NAME SHARE COMMAND...: runs COMMAND until the step's deadline (SHARE per mille of the
# budget after the last step's deadline), its stdout and stderr into log.txt, its RESULT lines (each once)
# into results.txt; notes how it ended.
step() {
    name=$1
    shares=$((shares + $2))
    shift 2
    : >"$work/step.out"
    t0=$(date +%s)
    left=$((start + shares * budget / 1000 - t0))
    if [ $left -lt 1 ]; then
        say "--- $name: skipped, no time left in the budget"
        timed_out="$timed_out $name"
        return
    fi
    echo "=== $name (budget ${left}s): $*" >>"$log"
    timeout -k 10 "$left" "$@" >"$work/step.out" 2>>"$log"
    rc=$?
    cat "$work/step.out" >>"$log"
    grep '^RESULT ' "$work/step.out" | awk '!seen[$0]++' >>"$out/results.txt"
    took=$(($(date +%s) - t0))
    case $rc in
    0) how=ok ;;
    124 | 137) how="TIMEOUT: killed at its budget of ${left}s"; timed_out="$timed_out $name" ;;
    *) how="FAILED (exit $rc)"; failed="$failed $name" ;;
    esac
    say "--- $name: $how, ${took}s, $(grep -c '^RESULT ' "$work/step.out") RESULT lines"
}

# compare NAME SHARE SIZE ARGS...: the main methods at equal time against ris; its report.md and
# report.json become NAME.md and NAME.json.
compare() {
    name=$1
    share=$2
    size=$3
    shift 3
    step "$name" "$share" "$bin/restir-demo" compare --size "$size" \
        --methods ris,restir-di,restir-gi,world-restir-gi,restir-di+world-restir-gi+world-restir \
        --equal-time-to ris --no-exr --quiet --cache "$work/cache" --out "$work/$name" "$@"
    for ext in md json; do
        [ -f "$work/$name/report.$ext" ] && cp "$work/$name/report.$ext" "$out/$name.$ext"
    done
}

if [ $lavapipe = 1 ]; then
    crit=""                                     # criterion's test mode: each function once
    sizes="SCAN_BENCH_SIZES=20"
    shapes="32x512 64x64"
    sweep_sizes=20
    RESTIR_SCENES_DIR=$here/no-scenes           # trace skips Sponza (its skip line)
    small="GI_BENCH_SIZE=32 WR_BENCH_SIZE=32 CACHE_BENCH_SIZE=32 DENOISE_BENCH_SIZE=32 HISTORY_BENCH_SIZE=32 HISTORY_BENCH_SEEDS=1"
    c256="64x64 --scene cornell,many-lights --frames 2 --equal-time-frames 2 --reference-spp 8"
    c1080="96x54 --scene cornell --frames 2 --equal-time-frames 2 --reference-spp 8"
else
    crit="--bench --warm-up-time 0.3 --measurement-time 0.7 --noplot"
    sizes=""
    shapes="256x8 256x32 256x64 128x16 128x32 128x64 64x32 64x64 64x128 32x64 32x256"
    sweep_sizes=24,25
    small=""
    c256="256x256 --scene many-lights,cornell --frames 16 --equal-time-frames 8 --reference-spp 256"
    c1080="1920x1080 --scene many-lights --frames 8 --equal-time-frames 4 --reference-spp 128"
fi

# Shares per mille: 980 in all, 20 left for unpacking and the steps' ends.
step device 30 "$bin/restir-demo" info
cp "$work/step.out" "$out/device.txt"
# $sizes, $small, $crit, $c256 and $c1080 are word lists: unquoted on purpose.
step scan 80 env SCAN_BENCH_CRITERION=0 $sizes "$bin/scan"
per_shape=$((165 / $(echo $shapes | wc -w)))
for shape in $shapes; do
    step "scan-${shape}" $per_shape env SCAN_BENCH_CRITERION=0 SCAN_BENCH_SIZES=$sweep_sizes \
        SCAN_BENCH_WG="${shape%x*}" SCAN_BENCH_ITEMS="${shape#*x}" "$bin/scan"
done
step hash 60 "$bin/hash" $crit
step trace 60 "$bin/trace" $crit
step restir_gi 60 env $small "$bin/restir_gi"
step world_restir 50 env WR_BENCH_CRITERION=0 $small "$bin/world_restir"
step floors 20 "$bin/floors" $crit
step reservoir 20 "$bin/reservoir" $crit
step cache 40 env $small "$bin/cache"
step denoise 30 env $small "$bin/denoise"
step history 60 env $small "$bin/history"
compare compare-256 130 $c256
compare compare-1080 175 $c1080

say "device-bench: $(($(date +%s) - start))s of ${budget}s; timed out or skipped:${timed_out:- none}; failed:${failed:- none}"
say "written into $out:"
for f in $files; do
    [ -f "$out/$f" ] && say "  $f ($(wc -c <"$out/$f") bytes$([ "$f" = results.txt ] && echo ", $(wc -l <"$out/$f") RESULT lines"))"
done
[ -z "$failed" ]
