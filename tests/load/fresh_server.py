"""A fresh `zerotile serve` for one measurement (empty caches), shared by the cold-run
scripts in this folder."""
import contextlib
import json
import subprocess
import sys
import time
import urllib.request


@contextlib.contextmanager
def fresh_server(binary: str, data: str, addr: str, dataset: str):
    """Starts BINARY serving DATA on ADDR, waits for DATASET's layer.json and yields it (a
    dict); the server is stopped on leaving, whatever happened inside."""
    server = subprocess.Popen([binary, "serve", "--data", data, "--addr", addr],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        for _ in range(100):
            try:
                with urllib.request.urlopen(f"http://{addr}/v1/datasets/{dataset}/layer.json") as r:
                    layer = json.load(r)
                break
            except OSError:
                time.sleep(0.1)
        else:
            sys.exit(f"the server at {addr} did not answer (is the port taken?)")
        yield layer
    finally:
        server.terminate()
        server.wait()
