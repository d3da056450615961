#!/usr/bin/env bash
# Every check CI runs, in the order that fails fastest. Usage: scripts/test.sh
# Works on a fresh machine with the Rust toolchain (rustfmt and clippy components) installed.
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
