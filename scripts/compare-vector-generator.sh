#!/usr/bin/env bash
# Times the vector generator of this tree against that of an earlier revision at their default
# budgets, seed by seed, alternating which build runs first so machine drift hits both, and prints the
# quality bench's lines of each run (seconds, energy, low bands, filtered error, integration
# errors) prefixed with `old` or `new`.
#
# Usage: scripts/compare-vector-generator.sh REV [SIZE] [SEEDS]
#   REV    the revision to compare against (a commit, tag or branch)
#   SIZE   WxHxD, default 128x128x64
#   SEEDS  comma separated, default 1,2,3
# STBN_VECTOR_SPACES picks the spaces (default vec2,unitvec3,cosine_hemisphere); STBN_SWAP_SIMD=avx2
# caps the tile loop's instructions (to measure an AVX2 machine on an AVX-512 one).
#
# The old revision is checked out in a temporary worktree and runs this tree's copy of
# stbn-gen/benches/vector.rs (it uses the public API only), so both print the same figures.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
rev=${1:?usage: scripts/compare-vector-generator.sh REV [SIZE] [SEEDS]}
size=${2:-128x128x64}
seeds=${3:-1,2,3}
export STBN_VECTOR_SPACES=${STBN_VECTOR_SPACES:-vec2,unitvec3,cosine_hemisphere}
# shellcheck source=scripts/compare-common.sh
. "$root/scripts/compare-common.sh"
compare_checkout "$root" "$rev"
cp "$root/stbn-gen/benches/vector.rs" "$old/stbn-gen/benches/vector.rs"

bench() { # TREE TARGET [cargo args...]
    local tree=$1 dir=$2
    shift 2
    (cd "$tree" && CARGO_TARGET_DIR=$dir cargo bench --quiet -p stbn-gen --features analysis \
        --bench vector "$@")
}
bench "$old" "$old_target" --no-run
bench "$root" "$target" --no-run
compare_machine
order="old new"
for seed in ${seeds//,/ }; do
    for label in $order; do
        tree=$root dir=$target
        [ "$label" = old ] && tree=$old dir=$old_target
        STBN_VECTOR_SEED=$seed STBN_VECTOR_QUALITY=$size STBN_VECTOR_QUALITY_BUDGETS=default \
            bench "$tree" "$dir" | sed -e '/^$/d' -e "s/^/$label /"
    done
    [ "$order" = "old new" ] && order="new old" || order="old new"
done
