#!/usr/bin/env python3
"""Clients that ask and never read: N connections each ask for a different large mesh tile
(N44W072's zoom-3 .json at distinct small thresholds, 2-4 MB each) and take none of it. The
answer caches are bounded; what each stalled connection holds is not, until the server's
write-stall limit closes it (30 s). Prints the server's RSS as the clients come, 10 s and
40 s after the last, and once they have gone.

usage: tests/load/stalled_readers.py BIN DATA_DIR PORT N
DATA_DIR must hold n44.ztd: zerotile ingest --name n44 --data DIR ../shared/data/dem/N44W072.hgt
"""
import socket
import subprocess
import sys
import time
import urllib.request

binp, data, port, n = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
server = subprocess.Popen(
    [binp, "serve", "--data", data, "--addr", f"127.0.0.1:{port}", "--cache-mb", "64"],
    stdout=subprocess.PIPE,
    stderr=subprocess.DEVNULL,
)
server.stdout.readline()


def rss_mb():
    with open(f"/proc/{server.pid}/status") as f:
        line = next(l for l in f if l.startswith("VmRSS"))
    return int(line.split()[1]) // 1024


print("start: RSS", rss_mb(), "MB", flush=True)
clients = []
for i in range(n):
    s = socket.create_connection(("127.0.0.1", port))
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    t = 0.3 + 0.0007 * i
    path = f"/v1/datasets/n44/tiles/3/{i % 5}/{(i // 5) % 5}.json?threshold={t:.4f}"
    s.sendall(f"GET {path} HTTP/1.1\r\nHost: a\r\n\r\n".encode())
    clients.append(s)
    if (i + 1) % max(1, n // 4) == 0:
        time.sleep(3)
        print(f"{i + 1} stalled readers: RSS {rss_mb()} MB", flush=True)
time.sleep(10)
print(f"{n} stalled, 10 s later: RSS {rss_mb()} MB", flush=True)
time.sleep(30)
print(f"{n} stalled, 40 s later: RSS {rss_mb()} MB", flush=True)
t0 = time.time()
urllib.request.urlopen(f"http://127.0.0.1:{port}/healthz", timeout=10).read()
print(f"healthz answered in {(time.time() - t0) * 1000:.0f} ms")
for s in clients:
    s.close()
time.sleep(3)
print("clients gone: RSS", rss_mb(), "MB")
server.terminate()
server.wait(timeout=20)
