#!/usr/bin/env python3
# Copyright 2026 The Myriad Authors. Licensed under the Apache License, Version 2.0.
"""Runs a command with a throw-away PostgreSQL cluster (scripts/pg_cluster.py), its URL in the
environment as MYRIAD_TEST_POSTGRES; exits with the command's status, or 77 (CTest's skip) when
there are no PostgreSQL server binaries.

    scripts/with_postgres.py build/tests/myriad_store_tests
"""

import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pg_cluster import PostgresCluster, Unavailable  # noqa: E402


def main():
    if len(sys.argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    try:
        cluster = PostgresCluster()
    except Unavailable as e:
        print(f"SKIP: {e}")
        return 77
    with cluster as pg:
        env = dict(os.environ, MYRIAD_TEST_POSTGRES=pg.url)
        return subprocess.run(sys.argv[1:], env=env).returncode


if __name__ == "__main__":
    sys.exit(main())
