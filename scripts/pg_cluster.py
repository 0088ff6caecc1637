#!/usr/bin/env python3
# Copyright 2026 The Myriad Authors. Licensed under the Apache License, Version 2.0.
"""A throw-away PostgreSQL cluster for tests: Debian's `postgresql` package, a data directory
and a unix socket in a temporary directory, a random port, no TCP listener.

PostgreSQL refuses to run as root, and CI runs as root: then initdb and postgres run as the
`postgres` system user the package creates (runuser), and the temporary directory is theirs.
As any other user they run as that user. Used by scripts/chaos.py and scripts/with_postgres.py.

    with PostgresCluster() as pg:
        url = pg.url          # postgresql://myriad@/myriad?host=/tmp/...&port=NNNNN
"""

import glob
import os
import pwd
import random
import shutil
import subprocess
import tempfile
import time


class Unavailable(Exception):
    """No PostgreSQL server binaries here (or no user to run them as)."""


def server_bin_dir():
    """The newest /usr/lib/postgresql/N/bin holding initdb and postgres."""
    candidates = []
    for d in glob.glob("/usr/lib/postgresql/*/bin"):
        try:
            version = int(d.split("/")[-2])
        except ValueError:
            continue
        if os.access(os.path.join(d, "initdb"), os.X_OK) and os.access(
                os.path.join(d, "postgres"), os.X_OK):
            candidates.append((version, d))
    if not candidates:
        raise Unavailable("no PostgreSQL server binaries (/usr/lib/postgresql/*/bin; Debian: "
                          "apt-get install postgresql)")
    return max(candidates)[1]


class PostgresCluster:
    def __init__(self, keep=False):
        self.bin = server_bin_dir()
        self.keep = keep
        self.prefix = []
        self.owner = None
        if os.geteuid() == 0:
            try:
                self.owner = pwd.getpwnam("postgres")
            except KeyError as e:
                raise Unavailable("running as root and there is no `postgres` user to run "
                                  "PostgreSQL as") from e
            if shutil.which("runuser"):
                self.prefix = ["runuser", "-u", "postgres", "--"]
            elif shutil.which("setpriv"):
                self.prefix = ["setpriv", f"--reuid={self.owner.pw_uid}",
                               f"--regid={self.owner.pw_gid}", "--clear-groups", "--"]
            else:
                raise Unavailable("running as root without runuser or setpriv")
        self.root = None
        self.process = None
        self.port = None

    def _own(self, path):
        if self.owner is not None:
            os.chown(path, self.owner.pw_uid, self.owner.pw_gid)

    def start(self):
        self.root = tempfile.mkdtemp(prefix="myriad-pg-")
        os.chmod(self.root, 0o755)
        self._own(self.root)
        data = os.path.join(self.root, "data")
        self.socket_dir = os.path.join(self.root, "socket")
        os.mkdir(self.socket_dir)
        os.chmod(self.socket_dir, 0o777)
        self._own(self.socket_dir)
        log = os.path.join(self.root, "initdb.log")
        with open(log, "w") as out:
            self._own(log)
            result = subprocess.run(
                self.prefix + [os.path.join(self.bin, "initdb"), "-D", data, "-A", "trust",
                               "-U", "myriad", "-E", "UTF8", "--locale=C", "--no-sync"],
                stdout=out, stderr=subprocess.STDOUT, cwd=self.root)
        if result.returncode != 0:
            raise RuntimeError("initdb failed: " + open(log).read()[-2000:])
        self.log_path = os.path.join(self.root, "postgres.log")
        # The tests kill servers, never the database: fsync off keeps a 2-core CI machine quick.
        for _ in range(5):
            self.port = random.randint(20000, 60000)
            self.log = open(self.log_path, "a")
            self._own(self.log_path)
            self.process = subprocess.Popen(
                self.prefix + [os.path.join(self.bin, "postgres"), "-D", data,
                               "-k", self.socket_dir, "-p", str(self.port),
                               "-c", "listen_addresses=", "-c", "fsync=off",
                               "-c", "synchronous_commit=off", "-c", "full_page_writes=off",
                               "-c", "max_connections=200"],
                stdout=self.log, stderr=subprocess.STDOUT, cwd=self.root)
            socket = os.path.join(self.socket_dir, f".s.PGSQL.{self.port}")
            deadline = time.time() + 30
            while time.time() < deadline and self.process.poll() is None:
                if os.path.exists(socket) and self._ready():
                    break
                time.sleep(0.1)
            if self.process.poll() is None and os.path.exists(socket):
                self._createdb()
                return self
            self.process.kill()
            self.process.wait()
        raise RuntimeError("postgres did not start: " + open(self.log_path).read()[-2000:])

    def _ready(self):
        isready = os.path.join(self.bin, "pg_isready")
        if not os.access(isready, os.X_OK):
            return True
        return subprocess.run([isready, "-q", "-h", self.socket_dir, "-p", str(self.port)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode == 0

    def _createdb(self):
        psql = os.path.join(self.bin, "psql")
        if not os.access(psql, os.X_OK):
            psql = shutil.which("psql") or psql
        self.psql_path = psql
        subprocess.run([psql, "-q", "-h", self.socket_dir, "-p", str(self.port), "-U", "myriad",
                        "-d", "postgres", "-c", "CREATE DATABASE myriad"], check=True,
                       stdout=subprocess.DEVNULL)

    def psql(self, sql):
        """Runs `sql` in the cluster's database; returns its unaligned output."""
        return subprocess.run([self.psql_path, "-qAt", "-h", self.socket_dir, "-p", str(self.port),
                               "-U", "myriad", "-d", "myriad", "-c", sql], check=True,
                              capture_output=True, text=True).stdout

    @property
    def url(self):
        return f"postgresql://myriad@/myriad?host={self.socket_dir}&port={self.port}"

    def stop(self):
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=15)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        if self.root and not self.keep:
            shutil.rmtree(self.root, ignore_errors=True)

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()
