#!/usr/bin/env bash
# Overload: wrk drives uncacheable renders far past capacity, once with the default load
# shedding and once with shedding off (a queue nobody will ever fill), same binary, same data.
# Usage: tests/load/overload.sh ZEROTILE_BIN DATA_DIR [CONNECTIONS] [SECONDS]
# DATA_DIR must hold n44.ztd: zerotile ingest --scheme geodetic --name n44 --data DIR N44W072.hgt
set -euo pipefail
bin=$1 data=$2 conns=${3:-512} secs=${4:-20}
here=$(cd "$(dirname "$0")" && pwd)
run() {
    local label=$1; shift
    "$bin" serve --data "$data" --addr 127.0.0.1:18191 "$@" >/dev/null 2>&1 &
    local pid=$!
    trap 'kill $pid 2>/dev/null' EXIT
    for _ in $(seq 100); do curl -fs http://127.0.0.1:18191/healthz >/dev/null && break; sleep 0.1; done
    echo "== $label ($*)"
    wrk -t2 -c"$conns" -d"${secs}s" --timeout 60s --latency -s "$here/overload.lua" http://127.0.0.1:18191 \
        | grep -E "Latency|50%|90%|99%|Requests/sec|status|Socket|Non-2xx"
    kill $pid; wait $pid 2>/dev/null || true
    trap - EXIT
}
run "load shedding (default)"
run "no shedding" --cpu-queue 1000000
