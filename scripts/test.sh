#!/usr/bin/env bash
# Every check CI runs, in the order that fails fastest. Usage: scripts/test.sh
# Works on a fresh machine with rustup; it adds the rustfmt and clippy components and the
# toolchains of the declared rust-versions (MSRV) when they are missing.
set -euo pipefail
cd "$(dirname "$0")/.."

for component in rustfmt clippy; do
    if ! rustup component list --installed 2>/dev/null | grep -q "^$component"; then
        rustup component add "$component"
    fi
done

echo "== cargo fmt --check"
cargo fmt --all -- --check

echo "== cargo clippy -D warnings"
cargo clippy --workspace --all-targets --all-features -- -D warnings

echo "== no_std check (a #![no_std] staticlib with its own panic handler links the runtime)"
cargo build --manifest-path tests/nostd-check/Cargo.toml
cargo clippy --manifest-path tests/nostd-check/Cargo.toml -- -D warnings

echo "== MSRV (each crate builds with the oldest compiler its rust-version declares)"
# The generator crates and the scenes take the workspace's rust-version; stbn-runtime declares its
# own, for its default and `alloc` features (the `wgpu` feature needs what wgpu declares: 1.87 for
# wgpu 30). Left out: test targets (criterion, a dev-dependency, needs 1.86) and the stbn-demo
# package, a build.rs over stbn-build-support that would regenerate its masks (minutes).
generator_msrv=$(sed -n 's/^rust-version = "\(.*\)"$/\1/p' Cargo.toml)
runtime_msrv=$(sed -n 's/^rust-version = "\(.*\)"$/\1/p' stbn-runtime/Cargo.toml)
for version in "$generator_msrv" "$runtime_msrv"; do
    if ! rustup toolchain list | grep -q "^$version-"; then
        rustup toolchain install "$version" --profile minimal
    fi
done
CARGO_TARGET_DIR=target/msrv cargo "+$runtime_msrv" check -p stbn-runtime --features alloc
CARGO_TARGET_DIR=target/msrv cargo "+$generator_msrv" check \
    -p stbn-gen -p stbn-build-support -p stbn-gen-cli -p stbn-scenes

echo "== GPU prerequisites (CPU drivers for the stbn-runtime wgpu tests)"
# The `wgpu` feature's tests need real adapters and fail without them: Vulkan and GL. On a machine
# with no GPU, Mesa's CPU drivers provide both: lavapipe (mesa-vulkan-drivers + the libvulkan1
# loader) and llvmpipe through EGL (libegl1, libegl-mesa0, libgl1-mesa-dri). Install them only
# when a manifest is missing (needs root and apt, as on the CI image).
if { ! compgen -G "/usr/share/vulkan/icd.d/lvp_icd.*.json" >/dev/null \
        && ! compgen -G "/etc/vulkan/icd.d/lvp_icd.*.json" >/dev/null; } \
    || ! compgen -G "/usr/share/glvnd/egl_vendor.d/*mesa*.json" >/dev/null; then
    if [ "$(id -u)" -eq 0 ] && command -v apt-get >/dev/null; then
        apt-get update
        DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends \
            mesa-vulkan-drivers libvulkan1 libegl1 libegl-mesa0 libgl1-mesa-dri
    else
        echo "Mesa's CPU drivers (mesa-vulkan-drivers libvulkan1 libegl1 libegl-mesa0" \
            "libgl1-mesa-dri) are missing and need root and apt to install; the wgpu tests" \
            "will fail unless the machine has other Vulkan and GL drivers" >&2
    fi
fi

echo "== cargo test"
cargo test --workspace --all-features --no-fail-fast

echo "== a real cargo build of a crate whose build.rs reads a broken manifest fails cleanly"
cargo test -p stbn-demo --test build_script -- --ignored broken_manifest_fails_a_real_cargo_build
