#!/usr/bin/env bash
# Install everything impactgen needs on a fresh Debian/Ubuntu machine: SUNDIALS CVODES, a C
# compiler and the Python headers (apt-get), then a virtual environment with impactgen.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=${VENV:-.venv}
PYTHON=${PYTHON:-python3}

have_cvodes() {
    local d
    for d in ${SUNDIALS_DIR:+"$SUNDIALS_DIR/include"} ${CONDA_PREFIX:+"$CONDA_PREFIX/include"} \
             /usr/include /usr/local/include /opt/homebrew/include; do
        [ -f "$d/cvodes/cvodes.h" ] && return 0
    done
    return 1
}

packages=()
have_cvodes || packages+=(libsundials-dev)
command -v cc >/dev/null 2>&1 || packages+=(gcc libc6-dev)
"$PYTHON" -c 'import venv, ensurepip' >/dev/null 2>&1 || packages+=(python3-venv)
"$PYTHON" - <<'PY' || packages+=(python3-dev)
import os, sys, sysconfig
sys.exit(0 if os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")) else 1)
PY

if [ ${#packages[@]} -gt 0 ]; then
    if command -v apt-get >/dev/null 2>&1; then
        sudo=""
        [ "$(id -u)" -ne 0 ] && sudo="sudo"
        echo "setup: installing ${packages[*]} with apt-get"
        $sudo apt-get update -qq
        DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${packages[@]}" >/dev/null
    else
        echo "setup: please install ${packages[*]} (SUNDIALS CVODES 6.x or 7.x, a C compiler," \
             "Python headers), or set SUNDIALS_DIR to where SUNDIALS is installed" >&2
        exit 1
    fi
fi

if [ ! -x "$VENV/bin/python" ]; then
    echo "setup: creating the virtual environment $VENV"
    "$PYTHON" -m venv "$VENV"
fi
echo "setup: installing impactgen with its test, plot, sweep and benchmark extras into $VENV"
"$VENV/bin/python" -m pip install -q --disable-pip-version-check -e ".[test,plot,sweep,bench,fmu]"
