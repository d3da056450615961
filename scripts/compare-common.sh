# Sourced by the scripts/compare-*-generator.sh scripts: an earlier revision checked out beside
# this tree, and the machine line their output starts with.
#
# compare_checkout ROOT REV: checks REV out in a temporary worktree and sets `scratch` (a temporary
# folder, removed with the worktree on exit), `old` (the worktree), `target` (this tree's target
# folder) and `old_target` (the old tree's). The old tree builds into its own folder: cargo names
# a workspace member's artifacts after its path relative to the workspace, so two checkouts
# sharing a target folder would overwrite each other's builds and take the other's as fresh.
compare_checkout() {
    local root=$1 rev=$2
    target=$(realpath -m "${CARGO_TARGET_DIR:-$root/target}")
    old_target=$target/compare-old
    scratch=$(mktemp -d)
    old="$scratch/old"
    # shellcheck disable=SC2064 # expand now: the paths are fixed from here on
    trap "git -C '$root' worktree remove --force '$old' 2>/dev/null || true; rm -rf '$scratch'
          git -C '$root' worktree prune" EXIT
    git -C "$root" worktree add --quiet --detach "$old" "$rev"
}

# compare_machine: the CPU model, its AVX2 / AVX-512 flags, the SIMD cap and the load.
compare_machine() {
    lscpu 2>/dev/null | sed -n 's/^Model name: *//p' || true
    { grep -o -w 'avx2\|avx512f' /proc/cpuinfo || true; } | sort -u | tr '\n' ' '
    echo "(STBN_SWAP_SIMD=${STBN_SWAP_SIMD:-unset}), load $(cut -d' ' -f1-3 /proc/loadavg)"
}
