#!/usr/bin/env bash
# Same-run peer figure for the terrain codec: the criterion bench's decode to T/8 + bintree
# mesh (`decode_and_mesh_257`) and Martini's createTile + getMesh on the same 257² tiles
# (terrain_mesh.py's three: N44W072, fuji, jacksboro), run back to back so both see the
# same machine load (the bench machine is shared).
# Usage: codec/benches/terrain-peer/run.sh; REPEAT=n sets Martini's timed runs (default 51).
# For ratios that survive the machine's drift, rounds.py alternates both sides instead
# (codec/benches/terrain-peer/rounds.py [ROUNDS] [ITERATIONS], both Martinis, about 3 min at 9 31).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$(git -C "$here" rev-parse --show-toplevel)
target=${CARGO_TARGET_DIR:-$repo/target}
(cd "$repo" && cargo bench -p zerotile-codec --bench terrain -- decode_and_mesh_257 >&2)
python3 "$here/peer.py" "$target/criterion" "${REPEAT:-51}"
