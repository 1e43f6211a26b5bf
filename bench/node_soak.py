#!/usr/bin/env python3
"""Soak benchmark of ecs_node (issue 7): frames of N points sent at a fixed rate over loopback TCP
for a given time; reports latency p50/p99 (the node's own, arrival to delivery), sustained
throughput, drops, and the node's resident memory sampled every 10 s (it must not grow).

    python3 bench/node_soak.py --node build/tools/ecs_node --points 100000 --hz 10 --seconds 600

Standard library only (no install needed)."""
import argparse, json, math, os, random, re, signal, socket, struct, subprocess, sys, threading, time


def make_frame(n, seed):
    """A binary PCD of n points: a wavy terrain patch with a box on it, noise, like a LiDAR sweep."""
    rnd = random.Random(seed)
    body = bytearray()
    for _ in range(n):
        x, y = rnd.uniform(-20, 20), rnd.uniform(-20, 20)
        z = 0.3 * math.sin(0.3 * x) * math.cos(0.2 * y) + rnd.gauss(0, 0.01)
        if abs(x - 5) < 2 and abs(y) < 2:
            z += 1.5
        body += struct.pack("<fff", x, y, z)
    header = ("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH %d\nHEIGHT 1\n"
              "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS %d\nDATA binary\n" % (n, n)).encode()
    return header + bytes(body)


def free_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    p = s.getsockname()[1]
    s.close()
    return p


def connect(port):
    for _ in range(200):
        try:
            return socket.create_connection(("127.0.0.1", port))
        except OSError:
            time.sleep(0.05)
    raise SystemExit("cannot connect to port %d" % port)


def rss_mib(pid):
    with open("/proc/%d/status" % pid) as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return -1.0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--node", default="build/tools/ecs_node")
    ap.add_argument("--points", type=int, default=100000)
    ap.add_argument("--hz", type=float, default=10.0)
    ap.add_argument("--seconds", type=float, default=600.0)
    ap.add_argument("--json", default="")
    ap.add_argument("--node-args", default="--queue 4 --policy drop-oldest --workers 2 --terr 2e-3")
    a = ap.parse_args()

    frames = [make_frame(a.points, s) for s in range(6)]
    pin, pout = free_port(), free_port()
    err = open("/tmp/ecs_node_soak.log", "w")
    node = subprocess.Popen([a.node, "--source", "tcp:%d" % pin, "--sink", "tcp-listen:%d" % pout,
                             "--stats-interval", "10"] + a.node_args.split(), stderr=err)
    prod, cons = connect(pin), connect(pout)
    received = [0]
    stop = threading.Event()

    def consume():
        buf = b""
        while True:
            try:
                chunk = cons.recv(1 << 20)
            except OSError:
                return
            if not chunk:
                return
            buf += chunk
            while len(buf) >= 8:
                n = struct.unpack("<Q", buf[:8])[0]
                if len(buf) < 8 + n:
                    break
                buf = buf[8 + n:]
                received[0] += 1

    t = threading.Thread(target=consume, daemon=True)
    t.start()
    rss = []
    sent = 0
    start = time.monotonic()
    next_rss = start
    while time.monotonic() - start < a.seconds:
        due = start + sent / a.hz
        now = time.monotonic()
        if now < due:
            time.sleep(due - now)
        f = frames[sent % len(frames)]
        prod.sendall(struct.pack("<Q", len(f)) + f)
        sent += 1
        if time.monotonic() >= next_rss:
            rss.append((round(time.monotonic() - start, 1), round(rss_mib(node.pid), 1)))
            next_rss += 10.0
    elapsed = time.monotonic() - start
    prod.close()
    time.sleep(2.0)
    node.send_signal(signal.SIGTERM)
    node.wait(timeout=120)
    err.close()
    log = open("/tmp/ecs_node_soak.log").read()
    m = re.search(r"summary: frames in (\d+) out (\d+) dropped (\d+) bad (\d+).*p50 ([\d.]+) p99 ([\d.]+)", log)
    s = dict(zip(["in", "out", "dropped", "bad", "p50_ms", "p99_ms"], [float(x) for x in m.groups()])) if m else {}
    warm = [r for t_, r in rss if t_ >= 60.0] or [r for _, r in rss]
    result = {"points_per_frame": a.points, "rate_hz": a.hz, "seconds": round(elapsed, 1), "sent": sent,
              "received": received[0], "summary": s,
              "delivered_per_second": round(received[0] / elapsed, 2),
              "points_per_second": round(received[0] * a.points / elapsed),
              "rss_mib": rss, "rss_after_1min_min_max": [min(warm), max(warm)] if warm else None,
              "node_args": a.node_args}
    print(json.dumps(result, indent=2))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(result, f, indent=2)


if __name__ == "__main__":
    main()
