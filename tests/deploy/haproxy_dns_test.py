#!/usr/bin/env python3
"""The HAProxy front (deploy/haproxy/myriad.cfg) follows the nodes' DNS names without a restart.

A DNS stub (dns_stub.py) answers the nodes' names; HAProxy resolves them at run time
(nodes.sh's `resolvers`). The front starts while node 1's name does not resolve yet (a pod still
Pending); node 1 then starts and its sessions are routed to it. Then node 1 stops and starts again
on another address (127.0.0.11 -> 127.0.0.31, the same port), its name now answering the new
address: the front, never restarted, routes node 1's session to node 1 at the new address within
10 s (measured from the name's change), with the edit made before the move.

Usage: haproxy_dns_test.py MYRIAD_SERVER REPO_ROOT. Exit 0 pass, 1 fail, 77 skip (no haproxy).
"""
import json
import sys
import time

from haproxy_cluster import Cluster, check, node_name, skip_without_haproxy, wait_for

NODE_ARGS = ("--lease-ms", "1000", "--max-sessions", "16")
LIMIT_S = 10.0


def main():
    if len(sys.argv) != 3:
        print(__doc__)
        return 2
    skip_without_haproxy()
    server, repo = sys.argv[1], sys.argv[2]
    cluster = Cluster(server, repo, "myriad-haproxy-dns-")
    try:
        cluster.start_node(0, args=NODE_ARGS)
        # Node 1's port is chosen now; its name is NXDOMAIN until it runs.
        cluster.reserve_port(1)
        front = cluster.start_front("front", [0, 1])
        st, h, body = front.request("GET", "/v1/health")
        check(st == 200 and h.get("x-myriad-node") == "0",
              f"/v1/health with node 1 unresolved -> {st} from node {h.get('x-myriad-node')}")
        print(f"the front started with {node_name(1)} not resolving (NXDOMAIN); node 0 answers",
              flush=True)

        # --- node 1 appears ------------------------------------------------------------------------
        node1 = cluster.start_node(1, args=NODE_ARGS)
        appeared = time.monotonic()
        st, _, body = node1.request("POST", "/v1/sessions")
        if not check(st == 201, f"POST /v1/sessions on node 1 -> {st}"):
            return 1
        created = json.loads(body)
        sid, token = created["id"], created["token"]
        path = f"/v1/sessions/{sid}/camera"
        st, _, _ = node1.request("PATCH", path, {"fovY": 42}, token)
        check(st == 200, f"PATCH camera on node 1 -> {st}")

        def from_node1(status, headers, body):
            return (status == 200 and headers.get("x-myriad-node") == "1" and
                    json.loads(body).get("fovY") == 42)

        seconds, st, h, body, seen = wait_for(front, "GET", path, token, LIMIT_S, from_node1)
        check(seconds is not None,
              f"node 1 ({node_name(1)} now resolving) not routed to within {LIMIT_S} s: {st} from "
              f"node {h.get('x-myriad-node')} {body[:200]!r} ({seen})")
        if seconds is not None:
            print(f"node 1 started at 127.0.0.11: routed to {time.monotonic() - appeared:.2f} s "
                  f"after its name resolved (answers before: {seen})", flush=True)

        # --- node 1 moves to another address --------------------------------------------------------
        node1.stop()
        stopped = time.monotonic()
        # While it is away its session answers from node 0 (restored from the store).
        def from_node0(status, headers, body):
            return status == 200 and headers.get("x-myriad-node") == "0"

        seconds, st, h, body, seen = wait_for(front, "GET", path, token, LIMIT_S, from_node0)
        check(seconds is not None,
              f"node 1's session not on node 0 while node 1 is away: {st} {body[:200]!r} ({seen})")
        st, _, _ = front.request("PATCH", path, {"fovY": 43}, token)
        check(st == 200, f"PATCH camera on node 0 -> {st}")
        print(f"node 1 stopped: its session answered from node 0 after "
              f"{time.monotonic() - stopped:.2f} s, edited there", flush=True)

        cluster.start_node(1, host="127.0.0.31", args=NODE_ARGS)  # the name now answers .31
        moved = time.monotonic()

        def from_new_node1(status, headers, body):
            return (status == 200 and headers.get("x-myriad-node") == "1" and
                    json.loads(body).get("fovY") == 43)

        seconds, st, h, body, seen = wait_for(front, "GET", path, token, LIMIT_S + 5,
                                              from_new_node1)
        took = time.monotonic() - moved
        check(seconds is not None and took <= LIMIT_S,
              f"node 1 at its new address (127.0.0.31) not routed to within {LIMIT_S} s "
              f"({took:.2f} s): {st} from node {h.get('x-myriad-node')} {body[:200]!r} ({seen})")
        print(f"node 1 restarted at 127.0.0.31 (same name, same port): its session answered from "
              f"node 1 at the new address {took:.2f} s after the name changed, with the edit made "
              f"on node 0 (answers before: {seen}); the front was never restarted", flush=True)
        check(cluster.fronts[0].process.poll() is None, "the front exited")
        print(f"DNS queries answered by the stub: {cluster.dns.queries}", flush=True)
    except (OSError, RuntimeError, ValueError, KeyError) as e:
        check(False, f"{type(e).__name__}: {e}")
    finally:
        cluster.close()
    return cluster.verdict()


if __name__ == "__main__":
    sys.exit(main())
