#!/usr/bin/env python3
"""Latency over a network (issue 35): myriad-server and a client in two network namespaces
joined by a veth pair whose ends run `tc netem` (delay, jitter, loss and a rate cap on the
server's side, delay, jitter and loss on the client's), measured by myriad-net-probe:

  1. edit-to-decoded-frame percentiles for JPEG, VP9 and H.264 side by side (a still scene; the
     sun switched dark/bright every --interval ms; an edit's time runs from just before its
     PATCH is sent to the first decoded picture that shows it);
  2. a cap drop: an animated scene's stream (VP9 unless --cap-codecs says more) under the --rate
     cap; after --drop-at seconds the cap falls to --drop-rate. The stream must adapt (the
     bitrate its pictures carry fits the new cap) within 2 s, and its lag (edits timed as in 1.)
     must not grow: the median of the last 2 s at most 150 ms (or half) above that of 2-4 s
     after the drop. JPEG has no rate adaptation: its cap drop is reported, not checked.

Needs root and `ip netns` (iproute2). Where the kernel has no sch_netem (some VM kernels), the
rate cap is applied with tbf alone and the output says that delay, jitter and loss were not.
Prints a table and, with --json, writes every figure.
--ctest: a bounded run (< 60 s) with checks, exit 0 pass, 1 fail, 77 skip (not root, no netns).

Usage: bench-network.py MYRIAD_SERVER MYRIAD_NET_PROBE [--size WxH] [--fps F] [--edits N]
       [--interval MS] [--delay MS] [--jitter MS] [--loss PCT] [--rate MBIT] [--cap-rate MBIT]
       [--drop-rate MBIT]
       [--drop-at S] [--cap-seconds S] [--bitrate KBPS] [--cap-codecs vp9,h264,jpeg]
       [--json PATH] [--ctest]
"""
import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import time

SERVER_IP, CLIENT_IP, PORT = "10.213.7.1", "10.213.7.2", 8080


def sh(*args, check=True):
    r = subprocess.run(list(args), capture_output=True, text=True)
    if check and r.returncode != 0:
        raise RuntimeError(f"{' '.join(args)}: {r.stderr.strip()}")
    return r


class Link:
    """Two namespaces and a veth pair between them, with netem on both ends."""

    def __init__(self, tag):
        self.server_ns, self.client_ns = f"myr-s{tag}", f"myr-c{tag}"
        self.server_if, self.client_if = f"myrs{tag}", f"myrc{tag}"

    def up(self, a):
        sh("ip", "netns", "add", self.server_ns)
        sh("ip", "netns", "add", self.client_ns)
        sh("ip", "link", "add", self.server_if, "type", "veth", "peer", "name", self.client_if)
        for ns, dev, ip in ((self.server_ns, self.server_if, SERVER_IP),
                            (self.client_ns, self.client_if, CLIENT_IP)):
            sh("ip", "link", "set", dev, "netns", ns)
            sh("ip", "-n", ns, "addr", "add", f"{ip}/24", "dev", dev)
            sh("ip", "-n", ns, "link", "set", dev, "up")
            sh("ip", "-n", ns, "link", "set", "lo", "up")
        # netem where the kernel has it (sch_netem); else only the rate cap, by tbf, and the
        # report says that delay, jitter and loss were not applied.
        r = sh("ip", "netns", "exec", self.client_ns, "tc", "qdisc", "add", "dev",
               self.client_if, "root", "netem", *self.netem(a), check=False)
        self.netem_ok = r.returncode == 0
        self.netem_error = r.stderr.strip()
        self.shape(a, a.rate, "add")

    @staticmethod
    def netem(a, rate=None):
        spec = ["delay", f"{a.delay}ms", f"{a.jitter}ms", "loss", f"{a.loss}%"]
        if rate:
            spec += ["rate", f"{rate}mbit"]
        return spec

    def shape_command(self, a, rate, verb="change"):
        if self.netem_ok:
            qdisc = ["netem", *self.netem(a, rate)]
        else:
            # A queue of up to a second at the cap, as a home router's buffer holds (netem's
            # default is 1000 packets): a stream must not fill it (its lag would be the queue's).
            qdisc = ["tbf", "rate", f"{rate}mbit", "burst", "32kbit", "latency", "1000ms"]
        return ["ip", "netns", "exec", self.server_ns, "tc", "qdisc", verb, "dev", self.server_if,
                "root", *qdisc]

    def shape(self, a, rate, verb="change"):
        sh(*self.shape_command(a, rate, verb))

    def down(self):
        sh("ip", "netns", "del", self.server_ns, check=False)
        sh("ip", "netns", "del", self.client_ns, check=False)


def probe(a, link, codec, extra, interval):
    cmd = ["ip", "netns", "exec", link.client_ns, a.probe, "--url", f"http://{SERVER_IP}:{PORT}",
           "--codec", codec, "--size", a.size, "--fps", str(a.fps), "--interval",
           str(interval), *extra]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    if r.returncode != 0:
        raise RuntimeError(f"myriad-net-probe {codec}: {r.stderr.strip()}")
    return json.loads(r.stdout)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("server")
    p.add_argument("probe")
    p.add_argument("--size", default="640x360")
    p.add_argument("--fps", type=int, default=30)
    p.add_argument("--edits", type=int, default=40)
    p.add_argument("--interval", type=int, default=500)
    p.add_argument("--cap-interval", type=int, default=1000,
                   help="ms between edits during the cap drop (each edit changes the whole "
                        "picture: a frame of several times the bitrate's share)")
    p.add_argument("--delay", type=float, default=10.0, help="one way, ms (RTT: twice)")
    p.add_argument("--jitter", type=float, default=2.0)
    p.add_argument("--loss", type=float, default=1.0, help="percent, each direction")
    p.add_argument("--rate", type=float, default=10.0, help="Mbit/s, server to client")
    p.add_argument("--cap-rate", type=float, default=None,
                   help="Mbit/s before the drop (default: --rate)")
    p.add_argument("--drop-rate", type=float, default=3.0)
    p.add_argument("--drop-at", type=float, default=5.0)
    p.add_argument("--cap-seconds", type=float, default=14.0)
    p.add_argument("--bitrate", type=int, default=8000, help="the video streams' asked kbit/s")
    p.add_argument("--cap-codecs", default="vp9,h264,jpeg")
    p.add_argument("--server-args", default="--lights 16")
    p.add_argument("--json")
    p.add_argument("--ctest", action="store_true")
    a = p.parse_args()

    if os.geteuid() != 0 or shutil.which("ip") is None or shutil.which("tc") is None:
        print("SKIP: needs root, ip and tc (iproute2)")
        return 77
    link = Link(str(os.getpid() % 100000))
    try:
        link.up(a)
    except RuntimeError as e:
        link.down()
        print(f"SKIP: no network namespaces here: {e}")
        return 77

    server = None
    failures = []

    def check(ok, message):
        if not ok:
            failures.append(message)
            print("FAIL: " + message, flush=True)

    try:
        log = open(os.path.join("/tmp", f"bench-network-server-{os.getpid()}.log"), "wb")
        server = subprocess.Popen(["ip", "netns", "exec", link.server_ns, a.server, "--host",
                                   SERVER_IP, "--port", str(PORT), *a.server_args.split()],
                                  stdout=subprocess.PIPE, stderr=log)
        line = server.stdout.readline().decode()
        if not re.search(r"listening on", line):
            raise RuntimeError(f"the server did not start: {line!r}")
        rtt = sh("ip", "netns", "exec", link.client_ns, "ping", "-c", "3", "-i", "0.2", SERVER_IP,
                 check=False).stdout
        m = re.search(r"= [\d.]+/([\d.]+)/", rtt)
        if link.netem_ok:
            shaping = (f"netem {a.delay} ms +- {a.jitter} ms each way, {a.loss}% loss each way, "
                       f"{a.rate} Mbit/s server to client")
        else:
            shaping = (f"tbf {a.rate} Mbit/s server to client; NO delay, jitter or loss: this "
                       f"kernel has no netem ({link.netem_error})")
        print(f"link: {shaping}; ping RTT avg {m.group(1) if m else '?'} ms; stream {a.size} at "
              f"{a.fps} fps, video asks {a.bitrate} kbit/s", flush=True)
        report = {"link": {"netem": link.netem_ok,
                           "delayMs": a.delay if link.netem_ok else 0,
                           "jitterMs": a.jitter if link.netem_ok else 0,
                           "lossPct": a.loss if link.netem_ok else 0,
                           "rateMbit": a.rate, "dropRateMbit": a.drop_rate,
                           "pingRttMs": float(m.group(1)) if m else None},
                  "size": a.size, "fps": a.fps, "edits": {}, "capDrop": {}}

        # 1. Edit-to-decoded-frame, side by side.
        print(f"{'codec':6} {'edits':>5} {'missed':>6} {'p50 ms':>8} {'p95 ms':>8} {'p99 ms':>8} "
              f"{'max ms':>8}", flush=True)
        for codec in ("jpeg", "vp9", "h264"):
            extra = ["--mode", "edits", "--edits", str(a.edits)]
            if codec != "jpeg":
                extra += ["--bitrate", str(a.bitrate)]
            r = probe(a, link, codec, extra, a.interval)
            report["edits"][codec] = r
            e = r["editToDecodedMs"]
            print(f"{codec:6} {r['edits']:>5} {r['missed']:>6} {e['p50']:>8.1f} {e['p95']:>8.1f} "
                  f"{e['p99']:>8.1f} {e['max']:>8.1f}", flush=True)
            if a.ctest:
                check(r["missed"] <= 1, f"{codec}: {r['missed']} edits never showed")
                check(e["p50"] <= 150, f"{codec}: edit-to-decoded median {e['p50']:.0f} ms > 150")
                check(e["p95"] <= 400, f"{codec}: edit-to-decoded p95 {e['p95']:.0f} ms > 400")

        # 2. The cap drop.
        cap_rate = a.cap_rate or a.rate
        for codec, attempt in ((c, n) for c in a.cap_codecs.split(",") for n in (1, 2)):
            if attempt == 2 and (not a.ctest or codec == "jpeg" or not lag_grew):
                continue
            link.shape(a, cap_rate)
            extra = ["--mode", "cap", "--seconds", str(a.cap_seconds), "--at", str(a.drop_at),
                     "--run", " ".join(link.shape_command(a, a.drop_rate)),
                     "--cap-kbps", str(a.drop_rate * 1000)]
            if codec != "jpeg":
                extra += ["--bitrate", str(a.bitrate)]
            r = probe(a, link, codec, extra, a.cap_interval)
            report["capDrop"][codec] = r
            before = [w for w in r["windows"] if w["t"] + 0.5 <= r["changeAtS"]]
            after = [w for w in r["windows"] if w["t"] >= r["changeAtS"] + 2.0]
            mean = lambda ws, k: sum(w[k] for w in ws) / max(1, len(ws))
            early, late = r["editMsTwoToFourSecondsAfter"], r["editMsLastTwoSeconds"]
            print(f"cap drop {cap_rate:g} -> {a.drop_rate:g} Mbit/s, {codec}: before "
                  f"{mean(before, 'kbps'):.0f} kbit/s {mean(before, 'pictures') * 2:.1f} fps, "
                  f"edit p50 {r['editMsBeforeChange']['p50']:.0f} ms; fits the new cap after "
                  f"{r['adaptedAfterS']:.1f} s; 2 s on {mean(after, 'kbps'):.0f} kbit/s "
                  f"{mean(after, 'pictures') * 2:.1f} fps; edit p50 2-4 s after "
                  f"{early['p50']:.0f} ms, last 2 s {late['p50']:.0f} ms (max {late['max']:.0f})",
                  flush=True)
            print("  windows (t s: kbit/s, pictures, edit ms): " + ", ".join(
                f"{w['t']:g}: {w['kbps']:.0f}/{w['pictures']}/{w['editMs']:.0f}"
                for w in r["windows"]), flush=True)
            # JPEG has no rate adaptation (its quality is the client's choice): its frames
            # come slower at the new cap, reported but not checked.
            if a.ctest and codec != "jpeg":
                check(mean(before, "kbps") > a.drop_rate * 1000,
                      f"{codec}: the stream carried {mean(before, 'kbps'):.0f} kbit/s before the "
                      f"drop, not more than the new cap: the drop tests nothing")
                check(0 <= r["adaptedAfterS"] <= 2.0,
                      f"{codec}: fitted the new cap after {r['adaptedAfterS']} s (2 at most)")
                # Lag that grows without bound shows as seconds more by the end; a few edits a
                # window on 2 busy cores vary by a hundred milliseconds.
                # A window holds a few edits, so one stall of the 2 shared cores (a key frame,
                # another test's process) can double its median: a lag that grows without
                # bound grows again, so the cap drop is measured once more before failing.
                lag_grew = not (late["n"] > 0 and early["n"] > 0 and
                                late["p50"] <= max(early["p50"] + 150, 1.5 * early["p50"]))
                lag_text = (f"{codec}: lag grew: edit p50 {early['p50']:.0f} ms 2-4 s after the "
                            f"drop, {late['p50']:.0f} ms in the last 2 s")
                if lag_grew and attempt == 1:
                    print(f"  {lag_text}; measuring the cap drop once more", flush=True)
                else:
                    check(not lag_grew, lag_text)
                check(late["n"] > 0 and late["max"] <= 1500,
                      f"{codec}: edits took up to {late['max']:.0f} ms at the end")
        link.shape(a, a.rate)
        if a.json:
            with open(a.json, "w") as f:
                json.dump(report, f, indent=1)
    except (RuntimeError, subprocess.TimeoutExpired) as e:
        check(False, str(e))
    finally:
        if server:
            server.terminate()
            try:
                server.wait(15)
            except subprocess.TimeoutExpired:
                server.kill()
        link.down()
    if failures:
        print(f"{len(failures)} failure(s)")
        return 1
    print("PASS" if a.ctest else "done")
    return 0


if __name__ == "__main__":
    sys.exit(main())
