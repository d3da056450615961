#!/usr/bin/env bash
# Regenerates the README's pictures in docs/images/: one frame of a 128×128×32 scalar STBN mask
# (seed 7), the power spectrum of that frame (x–y) and of an x–frame slice, as `stbn-gen generate`
# writes them. Usage: scripts/readme-images.sh
set -euo pipefail
cd "$(dirname "$0")/.."
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
cat >"$scratch/readme.ron" <<'RON'
(masks: [(name: "stbn", kind: Scalar, size: (128, 128, 32), seed: 7, encoding: Unorm8)])
RON
cargo run --quiet --release -p stbn-gen-cli -- generate "$scratch/readme.ron" --out "$scratch/out" >/dev/null
cp "$scratch/out/stbn/stbn_0.png" docs/images/stbn_frame.png
cp "$scratch/out/dft/00_stbn_xy.png" docs/images/stbn_spectrum_xy.png
cp "$scratch/out/dft/00_stbn_xz.png" docs/images/stbn_spectrum_xz.png
