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

echo "== cargo test"
cargo test --workspace --all-features

echo "== a real cargo build of a crate whose build.rs reads a broken manifest fails cleanly"
cargo test -p stbn-demo --test build_script -- --ignored broken_manifest_fails_a_real_cargo_build
