#!/usr/bin/env bash
# Same-process A/B of the EZW decoder: a base commit's codec (default 32a86f3, the coder
# before the bitmap rewrite) against this work tree's, interleaved on the same N44W072 257²
# tile, medians of thread CPU time (the bench machine is shared). Prints two tables: decode
# to T, and decode to budget/8 + bintree mesh within 7/8·budget (the mesher is this work
# tree's in both columns). Usage: codec/benches/ezw-ab/run.sh [BASE_COMMIT]; ROUNDS=n.
set -euo pipefail
base=${1:-32a86f3}
here=$(cd "$(dirname "$0")" && pwd)
repo=$(git -C "$here" rev-parse --show-toplevel)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/base" "$work/ab/src"
git -C "$repo" archive "$base" | tar -x -C "$work/base"
# Two packages may not share a name in one build: rename the base's codec.
sed -i 's/^name = "zerotile-codec"$/name = "zerotile-codec-base"/' "$work/base/codec/Cargo.toml"
cp "$here/src/main.rs" "$work/ab/src/"
cp "$repo/Cargo.lock" "$work/ab/"
cat > "$work/ab/Cargo.toml" <<TOML
[package]
name = "ezw-ab"
version = "0.0.0"
edition = "2021"
publish = false

[dependencies]
old = { package = "zerotile-codec-base", path = "$work/base/codec" }
new = { package = "zerotile-codec", path = "$repo/codec" }
libc = "0.2"

[workspace]

# As the workspace's bench profile.
[profile.release]
lto = "thin"
codegen-units = 16
TOML
# A target directory of its own: the base and the work tree build the same crate names, and
# cargo's mtime-based freshness must never mix them up.
export CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-$repo/target}/ezw-ab
cargo build --release --manifest-path "$work/ab/Cargo.toml"
DEM=${DEM:-$repo/../shared/data/dem/N44W072.hgt} "$CARGO_TARGET_DIR/release/ezw-ab"
