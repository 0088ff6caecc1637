"""A DNS server for tests, on a UDP port of loopback: A records only, answered from a dict that the
test changes while it runs (a node restarted on another address). Names not in the dict are
NXDOMAIN; a known name asked for another type (AAAA) has no answer (NODATA). TTL 1 s. Enough for
HAProxy's `resolvers` (tests/deploy/haproxy_*.py); not a general DNS server."""
import socket
import struct
import threading


class DnsStub:
    def __init__(self, records=None, host="127.0.0.1"):
        # name (lower case, no trailing dot) -> list of IPv4 addresses
        self.records = dict(records or {})
        self.lock = threading.Lock()
        self.queries = 0
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind((host, 0))
        self.address = self.sock.getsockname()
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def set(self, name, *addresses):
        """Answers `name` with `addresses` from now on; none: NXDOMAIN."""
        with self.lock:
            if addresses:
                self.records[name.lower()] = list(addresses)
            else:
                self.records.pop(name.lower(), None)

    def close(self):
        self.sock.close()

    def _serve(self):
        while True:
            try:
                query, peer = self.sock.recvfrom(4096)
            except OSError:
                return
            try:
                answer = self._answer(query)
            except (ValueError, IndexError, struct.error):
                continue  # not a query this stub understands: no answer, as a lost packet
            try:
                self.sock.sendto(answer, peer)
            except OSError:
                return

    def _answer(self, query):
        ident, flags, qdcount = struct.unpack("!HHH", query[:6])
        if qdcount != 1 or flags & 0x8000:
            raise ValueError("not one question")
        labels = []
        at = 12
        while query[at]:
            length = query[at]
            if length & 0xC0:
                raise ValueError("compressed name in a question")
            labels.append(query[at + 1:at + 1 + length].decode("ascii").lower())
            at += 1 + length
        at += 1
        qtype, qclass = struct.unpack("!HH", query[at:at + 4])
        question = query[12:at + 4]
        name = ".".join(labels)
        with self.lock:
            self.queries += 1
            addresses = self.records.get(name)
        answers = b""
        count = 0
        if addresses is not None and qtype == 1 and qclass == 1:
            for address in addresses:
                # The name as a pointer to the question (offset 12), type A, class IN, TTL 1.
                answers += struct.pack("!HHHIH", 0xC00C, 1, 1, 1, 4) + socket.inet_aton(address)
                count += 1
        rcode = 3 if addresses is None else 0  # NXDOMAIN for an unknown name
        # Response, recursion desired copied, recursion available; no authority or additional.
        reply_flags = 0x8000 | (flags & 0x0100) | 0x0080 | rcode
        return struct.pack("!HHHHHH", ident, reply_flags, 1, count, 0, 0) + question + answers
