#!/usr/bin/env bash
# What the stbn build integration adds to a cached `cargo build` of the demo package (stbn-demo,
# the root package: build.rs embeds the masks of assets.ron) when the manifest did not change.
#
# Usage: scripts/cached-build-time.sh [RUNS]      (RUNS timed builds per case, default 5)
#
# Method. After two warm-up builds (the first compiles everything and fills the mask cache), it
# times RUNS real `cargo build -p stbn-demo` runs of each case, with the wall clock around the
# whole cargo process, and prints the median, the minimum and every run:
#
#   noop       nothing changed: Cargo's own fingerprint check, the floor of any build.
#   touch-lib  `touch src/lib.rs`: the crate recompiles; the build script does not rerun (its
#              only rerun-if-changed inputs are assets.ron and STBN_CACHE_DIR). The baseline.
#   touch-ron  `touch assets.ron`, content unchanged: the build script reruns, every mask is a
#              cache hit (read and verified, written to OUT_DIR only if different), and the crate
#              recompiles as in touch-lib.
#
# What stbn adds to a cached build whose manifest did not change is touch-ron minus touch-lib
# (the build script's run, with the same recompilation in both), and nothing at all to noop and
# touch-lib builds, where the script does not run. The script also prints the build script's
# own report (per-mask cache time) from Cargo's saved output of the last touch-ron build.
#
# Builds go to a private target directory ($CARGO_TARGET_DIR, default target/cached-build-time)
# so that other cargo commands holding the workspace target's lock do not add waiting time. The
# machine's load average is printed before and after: on a shared machine the times are upper
# bounds.
set -euo pipefail
cd "$(dirname "$0")/.."

runs=${1:-5}
export CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-$PWD/target/cached-build-time}

build() { cargo build -q -p stbn-demo; }

# Milliseconds of one build after running "$@" (a preparation step that is not timed).
time_build() {
    "$@"
    local start end
    start=$(date +%s%N)
    build
    end=$(date +%s%N)
    echo $(((end - start) / 1000000))
}

# "median min all..." of the numbers on stdin.
summary() {
    sort -n | awk '{ v[NR] = $1; all = all (NR > 1 ? " " : "") $1 }
        END { m = (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2;
              printf "%d %d %s\n", m, v[1], all }'
}

echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "target dir: $CARGO_TARGET_DIR; $runs runs per case"
build
build

declare -A result
for case in noop touch-lib touch-ron; do
    case $case in
        noop) prepare=(true) ;;
        touch-lib) prepare=(touch src/lib.rs) ;;
        touch-ron) prepare=(touch assets.ron) ;;
    esac
    times=()
    for _ in $(seq "$runs"); do
        times+=("$(time_build "${prepare[@]}")")
    done
    result[$case]=$(printf '%s\n' "${times[@]}" | summary)
done

echo
echo "| case | median ms | min ms | runs (ms) |"
echo "|---|---:|---:|---|"
for case in noop touch-lib touch-ron; do
    read -r median min all <<<"${result[$case]}"
    echo "| $case | $median | $min | $all |"
done
read -r lib_median lib_min _ <<<"${result[touch-lib]}"
read -r ron_median ron_min _ <<<"${result[touch-ron]}"
echo
echo "added by the build script with an unchanged manifest (touch-ron - touch-lib):" \
    "median $((ron_median - lib_median)) ms, min $((ron_min - lib_min)) ms"

# The build script's report of the last touch-ron build (the newest `output` of stbn-demo).
output=$(ls -t "$CARGO_TARGET_DIR"/debug/build/stbn-demo-*/output 2>/dev/null | head -n 1 || true)
if [ -n "$output" ]; then
    echo "build script report ($output):"
    grep '^stbn:' "$output" || echo "(no report lines)"
fi
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
