#!/usr/bin/env bash
# Does profile-guided optimisation speed up decode + mesh? Builds an instrumented zerotile,
# trains it on tiles other than the bench's three (so the answer is not tuned to them), builds
# the release binary with that profile, then alternates it with the plain release binary on
# the bench's tiles (`pgo_compare.py`). Answer on 2026-12-06: no, 1.00–1.09× the plain build's
# time (docs/terrain-mesh.md, "What was tried").
#
# Needs llvm-profdata of rustc's LLVM major version (`rustc -vV`; Debian: apt install llvm-22).
# The instrumented build is thin LTO: rustc 1.95's LLVM segfaults in the loop vectoriser on a
# fat-LTO instrumented build. Four release builds' worth of time (~25 min on 2 busy cores).
# Usage: codec/benches/terrain-peer/pgo.sh [ROUNDS]   (work files in $PGO_DIR, default /tmp/zt-pgo)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$(git -C "$here" rev-parse --show-toplevel)
work=${PGO_DIR:-/tmp/zt-pgo}
llvm=$(rustc -vV | sed -n 's/^LLVM version: \([0-9]*\).*/\1/p')
profdata=$(command -v "llvm-profdata-$llvm" || echo "/usr/lib/llvm-$llvm/bin/llvm-profdata")
[ -x "$profdata" ] || { echo "pgo.sh: no llvm-profdata for LLVM $llvm (apt install llvm-$llvm)" >&2; exit 2; }
mkdir -p "$work/prof"
rm -f "$work"/prof/*.profraw
cd "$repo"

CARGO_PROFILE_RELEASE_LTO=thin RUSTFLAGS="-Cprofile-generate=$work/prof" \
    CARGO_TARGET_DIR="$work/target-gen" cargo build --release -p zerotile
dem="$repo/../shared/data/dem"
sweep=0,0.1,0.25,0.5,0.75,1,1.5,2,3,4,6,8,12,16,24,32,48,64,96
for w in 97 53; do
    for input in "N44W072.hgt --crop 700,100,257" "N44W072.hgt --crop 900,850,257" \
        "pysheds_dem.tif --crop 0,0,257" "terra_elev_vinschgau.tif --crop 40,60,129"; do
        read -r file crop <<<"$input"
        # shellcheck disable=SC2086  # crop is the flag and its value
        "$work/target-gen/release/zerotile" eval terrain "$dem/$file" $crop --wavelet "$w" \
            --threshold "$sweep" --json >/dev/null 2>&1
    done
done
"$profdata" merge -o "$work/merged.profdata" "$work"/prof/*.profraw

RUSTFLAGS="-Cprofile-use=$work/merged.profdata" CARGO_TARGET_DIR="$work/target-use" \
    cargo build --release -p zerotile
cargo build --release -p zerotile
python3 "$here/pgo_compare.py" "${CARGO_TARGET_DIR:-$repo/target}/release/zerotile" \
    "$work/target-use/release/zerotile" "${1:-7}"
