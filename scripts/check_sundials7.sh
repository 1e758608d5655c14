#!/usr/bin/env bash
# Build and test impactgen against SUNDIALS 7, on a Debian machine whose own SUNDIALS is 6.x.
#
# Debian unstable's libsundials-dev (7.x) is downloaded from deb.debian.org and unpacked into a
# temporary folder (not installed). Its static libraries are linked: its shared ones need the
# OpenMPI of unstable. That SUNDIALS is built with MPI, so MPI's development files must be
# installed (mpi-default-dev); this script installs them when it runs as root.
#
#   scripts/check_sundials7.sh                    the kernels driver and the paper's tests
#   scripts/check_sundials7.sh tests/             any pytest arguments: here the whole suite
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-$( [ -x .venv/bin/python ] && echo .venv/bin/python || echo python3 )}
MIRROR=${DEBIAN_MIRROR:-http://deb.debian.org/debian}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

have_mpi() {
    for package in mpi ompi-c mpich; do pkg-config --exists "$package" 2>/dev/null && return 0; done
    return 1
}
if ! have_mpi; then
    if [ "$(id -u)" = 0 ]; then
        apt-get install -y -q mpi-default-dev pkg-config >/dev/null
    else
        echo "check_sundials7: install MPI's development files first: sudo apt-get install mpi-default-dev" >&2
        exit 2
    fi
fi

echo "check_sundials7: looking up libsundials-dev in Debian unstable"
curl -fsSL "$MIRROR/dists/sid/main/binary-amd64/Packages.xz" | xz -dc > "$work/Packages"
deb=$(awk '/^Package: /{p=$2} /^Filename: /{if (p == "libsundials-dev") print $2}' "$work/Packages" | head -1)
if [ -z "$deb" ]; then
    echo "check_sundials7: Debian unstable has no libsundials-dev" >&2
    exit 2
fi
echo "check_sundials7: $deb"
curl -fsSL -o "$work/dev.deb" "$MIRROR/$deb"
dpkg-deb -x "$work/dev.deb" "$work/root"

prefix="$work/sundials"
mkdir -p "$prefix/lib"
ln -s "$work/root/usr/include" "$prefix/include"
for lib in core cvodes arkode nvecserial sunmatrixdense sunlinsoldense; do
    cp "$work/root/usr/lib/x86_64-linux-gnu/libsundials_$lib.a" "$prefix/lib/"
done
grep -m1 '#define SUNDIALS_VERSION ' "$prefix/include/sundials/sundials_config.h"

export SUNDIALS_DIR="$prefix" IMPACTGEN_CACHE_DIR="$work/cache"
"$PY" -c 'from impactgen.sundials import find_sundials as f; s = f(); print("check_sundials7: SUNDIALS", s.version, "with", " ".join(s.cc_args()))'
if [ $# -eq 0 ]; then
    set -- tests/test_small_kernels.py tests/test_paper.py
fi
"$PY" -m pytest -q -p no:cacheprovider "$@"
