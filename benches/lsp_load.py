#!/usr/bin/env python3
"""`shadec lsp` and `shadec check` under load (issue 40; BENCHMARKS.md).

Drives the binary as an editor does, over stdio with Content-Length
frames, and prints medians:

- on a 2 MB document and a 50 000-line one: a burst of 20 typed edits
  (incremental changes, one character each, sent back to back), then a
  hover; the time from the last change to the hover's answer, and to the
  last version's diagnostics;
- the same documents with 1 000 misspelled names: the time from one
  change to its diagnostics (one analysis);
- `shadec check` of n declarations and n misspelled uses.

    cargo build --release && python3 benches/lsp_load.py target/release/shadec

The documents are generated here (`program`), so the figures can be
reproduced from this file alone.
"""

import json
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import queue
import time

SHADEC = sys.argv[1] if len(sys.argv) > 1 else "target/release/shadec"
REPEATS = int(os.environ.get("REPEATS", "5"))


def program(n_consts, n_statements, n_unknown):
    """n constants, n statements using them, n_unknown of the uses
    misspelled (one edit from a declared name)."""
    lines = []
    lines += [f"const k_{i:05} = 0.5;" for i in range(n_consts)]
    step = max(1, n_statements // max(1, n_unknown)) if n_unknown else 0
    for i in range(n_statements):
        name = f"k_{i % n_consts:05}"
        if n_unknown and i % step == 0 and i // step < n_unknown:
            name = f"kk_{i % n_consts:05}"
        lines.append(f"C δπx ← {name} * {name} + {name} * 0.25;")
    return "\n".join(lines) + "\n"


class Server:
    def __init__(self):
        self.p = subprocess.Popen([SHADEC, "lsp"], stdin=subprocess.PIPE, stdout=subprocess.PIPE)
        self.q = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()
        self.next_id = 1
        self.request("initialize", {"capabilities": {}})
        self.notify("initialized", {})

    def _read(self):
        out = self.p.stdout
        while True:
            length = None
            while True:
                line = out.readline()
                if not line:
                    return
                line = line.strip()
                if not line:
                    break
                if line.lower().startswith(b"content-length:"):
                    length = int(line.split(b":")[1])
            self.q.put((time.perf_counter(), json.loads(out.read(length))))

    def send(self, msg):
        body = json.dumps(msg).encode()
        self.p.stdin.write(b"Content-Length: %d\r\n\r\n" % len(body) + body)
        self.p.stdin.flush()

    def notify(self, method, params):
        self.send({"jsonrpc": "2.0", "method": method, "params": params})

    def request(self, method, params):
        i = self.next_id
        self.next_id += 1
        self.send({"jsonrpc": "2.0", "id": i, "method": method, "params": params})
        return self.wait(lambda m: m.get("id") == i and "method" not in m)

    def wait(self, pred):
        while True:
            t, m = self.q.get(timeout=600)
            if pred(m):
                return t, m

    def diagnostics(self, uri, version):
        return self.wait(lambda m: m.get("method") == "textDocument/publishDiagnostics"
                         and m["params"]["uri"] == uri and m["params"].get("version") == version)

    def close(self):
        self.request("shutdown", None)
        self.notify("exit", None)
        self.p.wait()


def burst(text, label):
    """20 one-character edits at the end of the first statement's line,
    back to back, then a hover on the first constant."""
    s = Server()
    uri = "file:///bench/doc.shd"
    s.notify("textDocument/didOpen", {"textDocument": {"uri": uri, "languageId": "shadec", "version": 1, "text": text}})
    t0 = time.perf_counter()
    s.diagnostics(uri, 1)
    first = time.perf_counter() - t0
    hover_ms, last_ms = [], []
    version = 1
    lines = text.count("\n")
    for _ in range(REPEATS):
        for k in range(20):
            version += 1
            line = lines // 2 + k
            s.notify("textDocument/didChange", {
                "textDocument": {"uri": uri, "version": version},
                "contentChanges": [{"range": {"start": {"line": line, "character": 0},
                                              "end": {"line": line, "character": 0}}, "text": " "}]})
        sent = time.perf_counter()
        t, h = s.request("textDocument/hover", {"textDocument": {"uri": uri}, "position": {"line": 2, "character": 7}})
        assert h.get("result"), h
        hover_ms.append((t - sent) * 1e3)
        t, _ = s.diagnostics(uri, version)
        last_ms.append((t - sent) * 1e3)
    s.close()
    print(f"{label}: {len(text) / 1e6:.2f} MB, {lines} lines; first analysis {first * 1e3:.0f} ms; "
          f"after 20 changes: hover {statistics.median(hover_ms):.1f} ms (max {max(hover_ms):.1f}), "
          f"last version's diagnostics {statistics.median(last_ms):.0f} ms (max {max(last_ms):.0f})")


def one_change(text, label):
    """The time from one change to its diagnostics: one analysis."""
    s = Server()
    uri = "file:///bench/doc.shd"
    s.notify("textDocument/didOpen", {"textDocument": {"uri": uri, "languageId": "shadec", "version": 1, "text": text}})
    _, d = s.diagnostics(uri, 1)
    n = len(d["params"]["diagnostics"])
    times = []
    for v in range(2, 2 + REPEATS):
        sent = time.perf_counter()
        s.notify("textDocument/didChange", {
            "textDocument": {"uri": uri, "version": v},
            "contentChanges": [{"range": {"start": {"line": 0, "character": 0}, "end": {"line": 0, "character": 0}},
                                "text": " "}]})
        t, _ = s.diagnostics(uri, v)
        times.append((t - sent) * 1e3)
    s.close()
    print(f"{label}: {n} diagnostics; one change to its diagnostics: median {statistics.median(times):.0f} ms "
          f"(max {max(times):.0f})")


def check(n):
    with tempfile.TemporaryDirectory() as d:
        for bad in (False, True):
            path = os.path.join(d, "p.shd")
            with open(path, "w") as f:
                f.write(program(n, n, n if bad else 0))
            times = []
            for _ in range(REPEATS):
                t0 = time.perf_counter()
                subprocess.run([SHADEC, "check", path], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                times.append(time.perf_counter() - t0)
            print(f"check, {n} declarations, {n if bad else 0} misspelled uses: median {statistics.median(times):.3f} s")


if __name__ == "__main__":
    two_mb = program(25000, 37000, 0)
    fifty_k = program(25000, 25000, 0)
    burst(two_mb, "2 MB document")
    burst(fifty_k, "50 000-line document")
    one_change(program(25000, 37000, 1000), "2 MB document, 1 000 unknown names")
    one_change(program(25000, 25000, 1000), "50 000-line document, 1 000 unknown names")
    for n in (2000, 4000, 8000):
        check(n)
