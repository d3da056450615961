#!/usr/bin/env bash
# Times the filter-adapted generator of this tree against that of an earlier revision at their
# default budgets, seed by seed, alternating which build runs first so machine drift hits both,
# and prints each run's summary row of `stbn-gen generate` (seconds, low bands, histogram
# deviations, filtered error, step-integrand errors, test functions for vector masks) prefixed
# with `old` or `new`.
#
# Usage: scripts/compare-filter-adapted-generator.sh REV [SIZE] [SEEDS] [SPACE]
#   REV    the revision to compare against (a commit, tag or branch)
#   SIZE   WxHxD, default 128x128x64
#   SEEDS  comma separated, default 1,2,3
#   SPACE  a vector kind for a filter-adapted vector mask (e.g. UnitVec3); default scalar
#
# The old revision is checked out in a temporary worktree and builds its own `stbn-gen` in its own
# target folder (scripts/compare-common.sh says why).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
rev=${1:?usage: scripts/compare-filter-adapted-generator.sh REV [SIZE] [SEEDS] [SPACE]}
IFS=x read -r w h d <<<"${2:-128x128x64}"
seeds=${3:-1,2,3}
space=${4:+"space: Some($4), "}
# shellcheck source=scripts/compare-common.sh
. "$root/scripts/compare-common.sh"
compare_checkout "$root" "$rev"

build() { # TREE TARGET
    (cd "$1" && CARGO_TARGET_DIR=$2 cargo build --quiet --release -p stbn-gen-cli)
}
build "$old" "$old_target"
build "$root" "$target"
compare_machine
order="old new"
header=
for seed in ${seeds//,/ }; do
    manifest="$scratch/seed$seed.ron"
    printf '(masks: [(name: "fast", kind: FilterAdapted, %ssize: (%s, %s, %s), seed: %s, encoding: Unorm16)])\n' \
        "$space" "$w" "$h" "$d" "$seed" >"$manifest"
    for label in $order; do
        binary=$target/release/stbn-gen
        [ "$label" = old ] && binary=$old_target/release/stbn-gen
        rm -rf "$scratch/out"
        "$binary" generate "$manifest" --out "$scratch/out" >/dev/null
        summary="$scratch/out/csv/summary.csv"
        if [ -z "$header" ]; then
            header=1
            echo "seed,build,$(head -1 "$summary")"
        fi
        echo "$seed,$label,$(tail -1 "$summary")"
    done
    [ "$order" = "old new" ] && order="new old" || order="old new"
done
