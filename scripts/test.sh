#!/usr/bin/env bash
# Every check CI runs, in the order that fails fastest. Usage: scripts/test.sh
# Works on a fresh machine with rustup; it adds the rustfmt and clippy components and the
# toolchains of the declared rust-versions (MSRV) when they are missing. Quiet on success: one
# header per step, with the time since the start; a failing step prints its whole output.
set -euo pipefail
cd "$(dirname "$0")/.."

# Incremental compilation pays off only when rebuilding edited code, and costs GBs here.
export CARGO_INCREMENTAL=0
# [profile.dev]'s debug level, also for the builds the workspace's profiles do not govern: the
# temporary crate of the build-script test and cargo package's verification builds.
export CARGO_PROFILE_DEV_DEBUG=line-tables-only
# Mesa's drivers (the wgpu tests and the GPU example) warn on every device they open unless
# XDG_RUNTIME_DIR is a private directory of this user.
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
export XDG_RUNTIME_DIR="$scratch/xdg-runtime"
mkdir -m 700 "$XDG_RUNTIME_DIR"
target_dir=${CARGO_TARGET_DIR:-target}

step() {
    printf '== %s [%dm%02ds]\n' "$1" $((SECONDS / 60)) $((SECONDS % 60))
}

# Runs a command with its output in a log, printed only when the command fails.
quietly() {
    local log="$scratch/step.log"
    if ! "$@" >"$log" 2>&1; then
        cat "$log"
        echo "FAILED: $*" >&2
        exit 1
    fi
}

for component in rustfmt clippy; do
    if ! rustup component list --installed 2>/dev/null | grep -q "^$component"; then
        rustup component add "$component"
    fi
done

step "cargo fmt --check"
cargo fmt --all -- --check

step "cargo clippy -D warnings"
cargo clippy --quiet --workspace --all-targets --all-features -- -D warnings

step "cargo doc, warnings are errors"
RUSTDOCFLAGS="-D warnings" cargo doc --quiet --no-deps --all-features --workspace

step "no_std check (a #![no_std] staticlib with its own panic handler links the runtime)"
cargo build --quiet --manifest-path tests/nostd-check/Cargo.toml
cargo clippy --quiet --manifest-path tests/nostd-check/Cargo.toml -- -D warnings

step "stbn-runtime on other architectures (the AArch64 square root, the software one on wasm32)"
# Their code paths compile only for those targets; checking needs their standard library alone.
for target in aarch64-unknown-linux-gnu wasm32-unknown-unknown; do
    if ! rustup target list --installed | grep -qx "$target"; then
        quietly rustup target add "$target"
    fi
    cargo clippy --quiet -p stbn-runtime --target "$target" -- -D warnings
done

step "MSRV (each crate builds with the oldest compiler its rust-version declares)"
# The published generator crates take the workspace's rust-version; stbn-runtime declares its
# own, for its default and `alloc` features (the `wgpu` feature needs what wgpu declares: 1.87 for
# wgpu 30). Left out: test targets (criterion, a dev-dependency, needs 1.86), the stbn-demo
# package (a build.rs over stbn-build-support that would regenerate its masks) and the unpublished
# scenes, whose check would add wgpu's (a minute); both build with the current compiler above.
generator_msrv=$(sed -n 's/^rust-version = "\(.*\)"$/\1/p' Cargo.toml)
runtime_msrv=$(sed -n 's/^rust-version = "\(.*\)"$/\1/p' stbn-runtime/Cargo.toml)
for version in "$generator_msrv" "$runtime_msrv"; do
    if ! rustup toolchain list | grep -q "^$version-"; then
        rustup toolchain install "$version" --profile minimal
    fi
done
CARGO_TARGET_DIR="$target_dir/msrv" cargo "+$runtime_msrv" check --quiet -p stbn-runtime \
    --features alloc
CARGO_TARGET_DIR="$target_dir/msrv" cargo "+$generator_msrv" check --quiet \
    -p stbn-gen -p stbn-build-support -p stbn-gen-cli

step "GPU prerequisites (CPU drivers for the stbn-runtime wgpu tests and the GPU example)"
# The `wgpu` feature's tests need real adapters and fail without them: Vulkan and GL. On a machine
# with no GPU, Mesa's CPU drivers provide both: lavapipe (mesa-vulkan-drivers + the libvulkan1
# loader) and llvmpipe through EGL (libegl1, libegl-mesa0, libgl1-mesa-dri). Install them only
# when a manifest is missing (needs root and apt, as on the CI image).
if { ! compgen -G "/usr/share/vulkan/icd.d/lvp_icd.*.json" >/dev/null \
        && ! compgen -G "/etc/vulkan/icd.d/lvp_icd.*.json" >/dev/null; } \
    || ! compgen -G "/usr/share/glvnd/egl_vendor.d/*mesa*.json" >/dev/null; then
    if [ "$(id -u)" -eq 0 ] && command -v apt-get >/dev/null; then
        quietly apt-get update
        DEBIAN_FRONTEND=noninteractive quietly apt-get install -y --no-install-recommends \
            mesa-vulkan-drivers libvulkan1 libegl1 libegl-mesa0 libgl1-mesa-dri
    else
        echo "Mesa's CPU drivers (mesa-vulkan-drivers libvulkan1 libegl1 libegl-mesa0" \
            "libgl1-mesa-dri) are missing and need root and apt to install; the wgpu tests" \
            "will fail unless the machine has other Vulkan and GL drivers" >&2
    fi
fi

step "cargo test"
# Builds the examples too (dev profile), with the same feature set, for the examples step.
quietly cargo test --workspace --all-features --no-fail-fast

step "a real cargo build of a crate whose build.rs reads a broken manifest fails cleanly"
# An ignored test (it builds stbn-build-support for a temporary crate); the same flags as the
# step before, so nothing of the workspace is rebuilt.
quietly cargo test --workspace --all-features --test build_script -- --ignored \
    broken_manifest_fails_a_real_cargo_build

step "examples (the binaries the test step built)"
examples_out="$scratch/examples"
quietly "$target_dir/debug/examples/cpu_dither" "$examples_out/cpu_dither"
quietly "$target_dir/debug/examples/gpu_dither" "$examples_out/gpu_dither"
# Each must be a PNG of the examples' 256×64 pixels: the signature, then the IHDR chunk's length,
# type, width and height.
expected_header=89504e470d0a1a0a0000000d494844520000010000000040
for file in "$examples_out"/cpu_dither/{ramp,frame_0,frame_3,mean_32}.png \
    "$examples_out/gpu_dither/frame_5.png"; do
    header=$(od -An -tx1 -N24 "$file" | tr -d ' \n')
    if [ "$header" != "$expected_header" ]; then
        echo "$file is not a 256×64 PNG (its first 24 bytes: $header)" >&2
        exit 1
    fi
done

step "cargo package (the published crates build from their .crate files alone)"
# Each .crate is built as a workspace of its own, in this target directory: with the workspace's
# debug level for dependencies, it reuses the dependencies the test step built where their
# features agree.
# cargo unpacks each .crate from its temporary registry (target/package/tmp-registry) into
# $CARGO_HOME/registry/src/-<hash of that path>/ and reuses an unpacked copy that is already there,
# whatever the .crate now holds: a checkout at a path packaged before would verify the old sources.
# Only unpacked copies of this workspace's crates from such path registries are removed (cargo
# unpacks them again from the .crate); the crates.io copies and everything else stay.
for unpacked in "${CARGO_HOME:-$HOME/.cargo}"/registry/src/-*/stbn-{runtime,gen,gen-cli,build-support}-[0-9]*; do
    if [ -e "$unpacked/.cargo-ok" ]; then
        rm -rf -- "$unpacked"
    fi
done
quietly cargo package --allow-dirty --workspace --exclude stbn-demo --exclude stbn-scenes \
    --config 'profile.dev.package."*".debug = false'

step "all checks passed"
