#!/usr/bin/env bash
# The python_client CTest: the Python package installed as a new user on Debian 12 installs it
# (client/python/README.md), then its pytest suite against a real myriad-server.
#   tests/python/run_tests.sh PYTHON MYRIAD_SERVER REPO [pytest arguments...]
# PYTHON is Debian's python3 (its numpy, Pillow and pytest come from python3-numpy, python3-pil,
# python3-pytest). A venv made with --system-site-packages sees them; pip installs a copy of
# client/python into it offline (--no-index --no-build-isolation: setuptools and wheel from
# Debian), so the tests import the installed package, not the source tree.
set -euo pipefail
python=$1 server=$(realpath "$2") repo=$(realpath "$3")
shift 3
work=$(mktemp -d /tmp/myriad-python-client-XXXXXX)
trap 'rm -rf "$work"' EXIT
"$python" -m venv --system-site-packages "$work/venv"
mkdir "$work/src"
tar -C "$repo/client/python" --exclude=build --exclude='*.egg-info' --exclude=__pycache__ \
    -cf - . | tar -C "$work/src" -xf -
"$work/venv/bin/pip" install --quiet --no-index --no-build-isolation "$work/src"
cd "$work"
"$work/venv/bin/python" -c 'import myriad, sys; print("myriad", myriad.__version__, "from", myriad.__file__)'
export MYRIAD_SERVER="$server"
exec "$work/venv/bin/python" -m pytest -p no:cacheprovider -q -rs "$repo/tests/python" "$@"
