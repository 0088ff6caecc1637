#!/usr/bin/env python3
"""The HAProxy front (deploy/haproxy/myriad.cfg) and the nodes' capacity (/v1/ready).

Two myriad-servers (--max-sessions 4, one --state-dir, --lease-ms 1000) named by a DNS stub,
behind one HAProxy front:

  - node 0 filled (4 sessions made on it directly): its /v1/ready is 503 naming "full: 4 of 4
    sessions" while /v1/health stays 200; new sessions made through the front all go to node 1,
    and node 0's own sessions are still read and edited through the front, on node 0; a session's
    stream passes through the front part by part (an edit's part within 5 s of the edit);
  - both full: POST /v1/sessions through the front is a 503 problem that names the capacity;
  - node 1 killed with the survivor full: node 1's sessions are answered 429 naming maxSessions
    (not a timeout, not a gateway error), node 0's keep answering; once one of node 0's sessions
    is deleted, one of node 1's sessions is restored on node 0 with its edit.

Usage: haproxy_capacity_test.py MYRIAD_SERVER REPO_ROOT. Exit 0 pass, 1 fail, 77 skip.
"""
import http.client
import json
import re
import signal
import sys
import time

from haproxy_cluster import Cluster, check, skip_without_haproxy, wait_for

MAX_SESSIONS = 4
NODE_ARGS = ("--lease-ms", "1000", "--max-sessions", str(MAX_SESSIONS))
# Readiness checks every 0.5 s, down after 2 failures: 1 s, and slack for a busy machine.
CHECKS_S = 5.0


def wait_ready_state(node, ready, deadline_s=5):
    end = time.monotonic() + deadline_s
    while time.monotonic() < end:
        if (node.request("GET", "/v1/ready")[0] == 200) == ready:
            return True
        time.sleep(0.05)
    return False


def stream_passes_through(front, s):
    """A session's MJPEG stream through the front: its first part, then the part of an edit made
    meanwhile, each as soon as the node sends it (HAProxy does not buffer responses)."""
    c = http.client.HTTPSConnection("localhost", front.port, context=front.context, timeout=10)
    c.request("GET", f"/v1/sessions/{s['id']}/stream?width=64&height=48&fps=10",
              headers={"Authorization": "Bearer " + s["token"]})
    r = c.getresponse()
    check(r.status == 200 and r.getheader("Content-Type", "").startswith("multipart/"),
          f"stream through the front -> {r.status} {r.getheader('Content-Type')}")
    received = b""
    frames = set()

    def read_until(count, deadline_s):
        nonlocal received
        end = time.monotonic() + deadline_s
        while len(frames) < count and time.monotonic() < end:
            received += r.read1(65536)
            frames.update(re.findall(rb"X-Myriad-Frame: (\d+)", received))
        return len(frames) >= count

    t = time.monotonic()
    first = read_until(1, 5)
    check(first, "no stream part through the front within 5 s")
    first_s = time.monotonic() - t
    t = time.monotonic()
    st, _, _ = front.request("PATCH", f"/v1/sessions/{s['id']}/camera", {"fovY": 61}, s["token"])
    check(st == 200, f"PATCH during the stream -> {st}")
    second = read_until(2, 5)
    check(second, "the edit's stream part did not come through the front within 5 s")
    print(f"stream through the front: first part after {first_s:.2f} s, the edit's part "
          f"{time.monotonic() - t:.2f} s after the PATCH was sent", flush=True)
    c.close()
    front.request("PATCH", f"/v1/sessions/{s['id']}/camera", {"fovY": 30 + s["i"]}, s["token"])


def main():
    if len(sys.argv) != 3:
        print(__doc__)
        return 2
    skip_without_haproxy()
    server, repo = sys.argv[1], sys.argv[2]
    cluster = Cluster(server, repo, "myriad-haproxy-capacity-")
    try:
        node0 = cluster.start_node(0, args=NODE_ARGS)
        cluster.start_node(1, args=NODE_ARGS)
        front = cluster.start_front("front", [0, 1])

        # --- node 0 full: readiness says so, liveness does not ------------------------------------
        mine = []
        for i in range(MAX_SESSIONS):
            st, _, body = node0.request("POST", "/v1/sessions")
            if not check(st == 201, f"POST /v1/sessions on node 0 -> {st} {body[:200]!r}"):
                return 1
            created = json.loads(body)
            mine.append({"id": created["id"], "token": created["token"], "home": 0, "i": i})
        st, _, body = node0.request("GET", "/v1/ready")
        check(st == 503 and b"full: 4 of 4 sessions" in body,
              f"/v1/ready of a full node -> {st} {body[:200]!r}")
        st, _, body = node0.request("GET", "/v1/health")
        check(st == 200, f"/v1/health of a full node -> {st} {body[:200]!r}")
        print(f"node 0 full: /v1/ready 503 {node0.request('GET', '/v1/ready')[2].decode()}, "
              f"/v1/health 200", flush=True)
        check(front.wait_states({("myriad_new", "node0"): "DOWN",
                                 ("myriad_sessions", "node0"): "UP"}, CHECKS_S),
              "the front does not see node 0 full (out of myriad_new, in myriad_sessions)")

        theirs = []
        for i in range(MAX_SESSIONS - 1):
            st, h, body = front.request("POST", "/v1/sessions")
            check(st == 201 and h.get("x-myriad-node") == "1",
                  f"a new session with node 0 full -> {st} from node {h.get('x-myriad-node')} "
                  f"{body[:200]!r}")
            if st == 201:
                created = json.loads(body)
                theirs.append({"id": created["id"], "token": created["token"], "home": 1,
                               "i": 10 + i})
        print(f"{len(theirs)} new sessions through the front with node 0 full: all on node 1",
              flush=True)
        for s in mine + theirs:
            path = f"/v1/sessions/{s['id']}/camera"
            st, h, _ = front.request("PATCH", path, {"fovY": 30 + s["i"]}, s["token"])
            check(st == 200 and h.get("x-myriad-node") == str(s["home"]),
                  f"PATCH camera of {s['id']} -> {st} from node {h.get('x-myriad-node')}")
            st, h, body = front.request("GET", path, None, s["token"])
            check(st == 200 and h.get("x-myriad-node") == str(s["home"]) and
                  json.loads(body)["fovY"] == 30 + s["i"],
                  f"GET camera of {s['id']} -> {st} from node {h.get('x-myriad-node')}")
        print("node 0's sessions read and edited through the front on node 0 while it is full",
              flush=True)
        stream_passes_through(front, mine[1])

        # --- every node full: a problem naming the capacity ---------------------------------------
        st, h, body = front.request("POST", "/v1/sessions")
        check(st == 201 and h.get("x-myriad-node") == "1", f"the 4th session on node 1 -> {st}")
        if st == 201:
            created = json.loads(body)
            theirs.append({"id": created["id"], "token": created["token"], "home": 1, "i": 20})
            st, _, _ = front.request("PATCH", f"/v1/sessions/{created['id']}/camera",
                                     {"fovY": 50}, created["token"])
            check(st == 200, f"PATCH camera -> {st}")
        check(wait_ready_state(cluster.nodes[1], False), "node 1 full but ready")
        check(front.wait_nodes([1], "DOWN", CHECKS_S, backends=("myriad_new",)),
              "the front does not see node 1 full")
        st, h, body = front.request("POST", "/v1/sessions")
        problem = json.loads(body) if h.get("content-type", "").startswith(
            "application/problem+json") else {}
        check(st == 503 and "max-sessions" in problem.get("detail", "") and
              h.get("retry-after") is not None,
              f"a new session with every node full -> {st} {h.get('content-type')} {body[:300]!r}")
        print(f"every node full: POST /v1/sessions -> {st} {problem.get('detail')!r}", flush=True)

        # --- node 1 killed, the survivor full ------------------------------------------------------
        cluster.nodes[1].kill(signal.SIGKILL)
        killed = time.monotonic()

        def capacity_problem(status, headers, body):
            return status == 429 and b"maxSessions" in body

        s = theirs[0]
        seconds, st, h, body, seen = wait_for(front, "GET", f"/v1/sessions/{s['id']}/camera",
                                              s["token"], 10, capacity_problem)
        check(seconds is not None,
              f"a dead node's session with the survivor full -> {st} {body[:300]!r} ({seen})")
        if seconds is not None:
            print(f"node 1 SIGKILLed, node 0 full: node 1's session answered {st} "
                  f"{json.loads(body).get('detail')!r} {time.monotonic() - killed:.2f} s after the "
                  f"kill (answers before: {seen})", flush=True)
        for s in mine:
            st, h, _ = front.request("GET", f"/v1/sessions/{s['id']}/camera", None, s["token"])
            check(st == 200 and h.get("x-myriad-node") == "0",
                  f"node 0's session {s['id']} -> {st} with node 1 dead")
        # Room again: one of node 0's sessions deleted, a session of node 1 restored on node 0.
        st, _, _ = front.request("DELETE", f"/v1/sessions/{mine[0]['id']}", None, mine[0]["token"])
        check(st == 204, f"DELETE -> {st}")
        s = theirs[0]
        seconds, st, h, body, seen = wait_for(front, "GET", f"/v1/sessions/{s['id']}/camera",
                                              s["token"], 10)
        check(seconds is not None and h.get("x-myriad-node") == "0" and
              json.loads(body)["fovY"] == 30 + s["i"],
              f"node 1's session once node 0 has room -> {st} {body[:300]!r} ({seen})")
        print(f"one of node 0's sessions deleted: node 1's session {s['id']} restored on node "
              f"{h.get('x-myriad-node')} with its edit", flush=True)
    except (OSError, RuntimeError, ValueError, KeyError) as e:
        check(False, f"{type(e).__name__}: {e}")
    finally:
        cluster.close()
    return cluster.verdict()


if __name__ == "__main__":
    sys.exit(main())
