#!/usr/bin/env python3
"""Two HAProxy fronts (deploy/haproxy/myriad.cfg, the same nodes.sh file) route every session id
to the same node without talking to each other.

Three myriad-servers (--node-id 0..2, one --state-dir, --lease-ms 1000) named by a DNS stub,
fronts A and B (B started later). Checked for 12 real sessions (made through both fronts) and
for 300 other session ids (100 naming each node; each node answers 404 for them, saying who it
is in X-Myriad-Node), and 24 more sessions made on node 2 directly:

  - all nodes up: every id is answered by the node it names, through both fronts;
  - node 2 SIGKILLed: its sessions asked at once through both fronts (before the fronts see it
    down) answer 200 from a survivor; once both fronts see it down, every id is answered by the
    same node through A as through B; node 2's ids are spread over both survivors, the others stay
    home; each of node 2's sessions answers 200 from the survivor that first answered it,
    whichever front is asked, alternately (no 409);
  - node 2 restarted: its sessions are answered by node 2 again through both fronts.

Usage: haproxy_fronts_test.py MYRIAD_SERVER REPO_ROOT. Exit 0 pass, 1 fail, 77 skip (no haproxy).
"""
import concurrent.futures
import json
import secrets
import signal
import sys
import time

from haproxy_cluster import Cluster, check, skip_without_haproxy, wait_for

NODES = 3
SESSIONS = 12
IDS_PER_NODE = 100
VICTIM = 2
EXTRA_ON_VICTIM = 24
NODE_ARGS = ("--lease-ms", "1000", "--max-sessions", "64")


def routes(front, ids, pool):
    """{id: node that answered} for GET /v1/sessions/{id} through `front` (404 expected)."""
    def one(sid):
        st, h, body = front.request("GET", f"/v1/sessions/{sid}", None, "0" * 32)
        check(st == 404, f"GET {sid} through {front.name} -> {st} {body[:200]!r}")
        return sid, h.get("x-myriad-node")
    return dict(pool.map(one, ids))


def main():
    if len(sys.argv) != 3:
        print(__doc__)
        return 2
    skip_without_haproxy()
    server, repo = sys.argv[1], sys.argv[2]
    cluster = Cluster(server, repo, "myriad-haproxy-fronts-")
    try:
        for i in range(NODES):
            cluster.start_node(i, args=NODE_ARGS)
        a = cluster.start_front("A", range(NODES))
        sessions = []
        for i in range(SESSIONS // 2):
            st, h, body = a.request("POST", "/v1/sessions")
            check(st == 201, f"POST /v1/sessions through A -> {st}")
            sessions.append(json.loads(body))
        b = cluster.start_front("B", range(NODES))
        for i in range(SESSIONS // 2):
            st, h, body = b.request("POST", "/v1/sessions")
            check(st == 201, f"POST /v1/sessions through B -> {st}")
            sessions.append(json.loads(body))
        # More sessions on the node that will crash, made there directly.
        for i in range(EXTRA_ON_VICTIM):
            st, h, body = cluster.nodes[VICTIM].request("POST", "/v1/sessions")
            check(st == 201, f"POST /v1/sessions on node {VICTIM} -> {st}")
            sessions.append(json.loads(body))
        ids = [f"s-{n:02x}{secrets.token_hex(7)}" for n in range(NODES)
               for _ in range(IDS_PER_NODE)]

        with concurrent.futures.ThreadPoolExecutor(4) as pool:
            # --- every node up ----------------------------------------------------------------------
            for s in sessions:
                for front in (a, b):
                    st, h, _ = front.request("GET", f"/v1/sessions/{s['id']}/camera", None,
                                             s["token"])
                    check(st == 200 and h.get("x-myriad-node") == str(int(s["id"][2:4], 16)),
                          f"{s['id']} through {front.name} -> {st} from node "
                          f"{h.get('x-myriad-node')}")
            on_a, on_b = routes(a, ids, pool), routes(b, ids, pool)
            differ = [sid for sid in ids if on_a[sid] != on_b[sid]]
            away = [sid for sid in ids if on_a[sid] != str(int(sid[2:4], 16))]
            print(f"all nodes up: {len(ids)} ids, {len(differ)} routed differently by A and B, "
                  f"{len(away)} not on the node they name", flush=True)
            check(not differ and not away, f"ids routed apart: {differ[:5]}, away: {away[:5]}")

            # --- node 2 crashes ---------------------------------------------------------------------
            victim = VICTIM
            cluster.nodes[victim].kill(signal.SIGKILL)
            # Its sessions asked at once, through both fronts, before they see it down: each is
            # restored by the node that every later request goes to.
            mine = [s for s in sessions if int(s["id"][2:4], 16) == victim]

            def first_answer(k_s):
                k, s = k_s
                seconds, st, h, body, seen = wait_for(
                    (a, b)[k % 2], "GET", f"/v1/sessions/{s['id']}/camera", s["token"], 10,
                    poll=0.02)
                check(seconds is not None, f"{s['id']} after the crash: {st} ({seen})")
                s["failover"] = h.get("x-myriad-node")
                return seconds

            t = time.monotonic()
            with concurrent.futures.ThreadPoolExecutor(len(mine)) as at_once:
                list(at_once.map(first_answer, enumerate(mine)))
            print(f"node {victim} SIGKILLed: its {len(mine)} sessions, asked at once through both "
                  f"fronts, answered within {time.monotonic() - t:.2f} s", flush=True)
            probe = next(sid for sid in ids if sid.startswith(f"s-{victim:02x}"))
            for front in (a, b):
                seconds, st, h, body, seen = wait_for(
                    front, "GET", f"/v1/sessions/{probe}", "0" * 32, 10,
                    lambda st, h, body: st == 404 and h.get("x-myriad-node") != str(victim))
                check(seconds is not None, f"{front.name} still sends node {victim}'s ids to it: "
                      f"{st} {body[:200]!r} ({seen})")
            on_a, on_b = routes(a, ids, pool), routes(b, ids, pool)
            differ = [sid for sid in ids if on_a[sid] != on_b[sid]]
            moved = [on_a[sid] for sid in ids if sid.startswith(f"s-{victim:02x}")]
            spread = {n: moved.count(n) for n in sorted(set(moved))}
            away = [sid for sid in ids if not sid.startswith(f"s-{victim:02x}") and
                    on_a[sid] != str(int(sid[2:4], 16))]
            print(f"node {victim} SIGKILLed: {len(differ)} of {len(ids)} ids routed differently "
                  f"by A and B; node {victim}'s {len(moved)} ids on survivors {spread}; "
                  f"{len(away)} of the others off their node", flush=True)
            check(not differ, f"A and B disagree on {len(differ)} ids: {differ[:5]}")
            check(len(spread) == NODES - 1 and str(victim) not in spread,
                  f"node {victim}'s ids not spread over the survivors: {spread}")
            check(not away, f"ids of live nodes moved: {away[:5]}")

            check(len(mine) > EXTRA_ON_VICTIM, f"no session made through the fronts on node "
                  f"{victim}")
            for s in mine:
                served = []
                statuses = []
                for k in range(6):
                    front = (a, b)[k % 2]
                    seconds, st, h, body, seen = wait_for(
                        front, "GET", f"/v1/sessions/{s['id']}/camera", s["token"], 10)
                    statuses.append(st)
                    served.append(h.get("x-myriad-node"))
                    check(409 not in seen, f"{s['id']}: 409 through {front.name} ({seen})")
                check(statuses == [200] * 6 and set(served) == {s["failover"]} and
                      served[0] != str(victim),
                      f"{s['id']} through A and B alternately: {statuses} from nodes {served}, "
                      f"first answered by node {s['failover']}")
            print(f"node {victim}'s {len(mine)} sessions: each answered 200 by one survivor "
                  f"through A and B alternately", flush=True)

            # --- node 2 back --------------------------------------------------------------------------
            cluster.start_node(victim, args=NODE_ARGS)
            for s in mine:
                for front in (a, b):
                    seconds, st, h, body, seen = wait_for(
                        front, "GET", f"/v1/sessions/{s['id']}/camera", s["token"], 10,
                        lambda st, h, body: st == 200 and h.get("x-myriad-node") == str(victim))
                    check(seconds is not None, f"{s['id']} not home through {front.name}: {st} "
                          f"from node {h.get('x-myriad-node')} ({seen})")
            on_a, on_b = routes(a, ids, pool), routes(b, ids, pool)
            differ = [sid for sid in ids if on_a[sid] != on_b[sid]]
            away = [sid for sid in ids if on_a[sid] != str(int(sid[2:4], 16))]
            print(f"node {victim} restarted: its sessions home through both fronts; "
                  f"{len(differ)} ids routed differently, {len(away)} not on their node",
                  flush=True)
            check(not differ and not away, f"after the restart: {differ[:5]}, {away[:5]}")
    except (OSError, RuntimeError, ValueError, KeyError) as e:
        check(False, f"{type(e).__name__}: {e}")
    finally:
        cluster.close()
    return cluster.verdict()


if __name__ == "__main__":
    sys.exit(main())
