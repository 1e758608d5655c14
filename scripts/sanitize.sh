#!/usr/bin/env bash
# Memory safety of the C: build the model and the CVODE glue with AddressSanitizer and
# UndefinedBehaviorSanitizer, then
#   1. run the glue driver (tests/c/glue_driver.c: every path, errors included) and the
#      kernels driver (tests/c/kernels_driver.c) with LeakSanitizer on: any leak, overflow
#      or undefined behaviour fails;
#   2. run the simulation tests with the instrumented cffi extension loaded into Python.
# Usage: scripts/sanitize.sh [pytest arguments]   (run after 'make setup')
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-.venv/bin/python}
[ -x "$PY" ] || PY=python3
CC=${CC:-cc}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

echo "sanitize: 1/2 glue driver under ASan + UBSan + LeakSanitizer"
"$PY" - "$work" <<'PY'
import sys
from pathlib import Path
from impactgen.build import GLUE_FILES, _native
from impactgen.codegen.emit import generate_model
from impactgen.codegen.expressions import ModelSpec
work = Path(sys.argv[1])
gen = generate_model(ModelSpec(2))
for name, text in gen.files().items():
    (work / name).write_text(text)
for name in GLUE_FILES:
    (work / name).write_text(_native(name))
PY
sundials=$("$PY" -c 'from impactgen.sundials import find_sundials as f; print(" ".join(f().cc_args()))')
glue_sources=$("$PY" -c 'from impactgen.build import GLUE_FILES as g; print(" ".join("src/impactgen/native/" + f for f in g if f.endswith(".c")))')
"$CC" -std=c99 -Wall -Wextra -Werror -g -O1 -fno-omit-frame-pointer -fsanitize=address,undefined \
    -fno-sanitize-recover=undefined -I"$work" "$work"/*.c tests/c/glue_driver.c $sundials -lm -o "$work/driver"
ASAN_OPTIONS=detect_leaks=1:halt_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 "$work/driver"
"$CC" -std=c99 -Wall -Wextra -Werror -g -O1 -fno-omit-frame-pointer -fsanitize=address,undefined \
    -fno-sanitize-recover=undefined -I"$work" "$work/small_kernels.c" tests/c/kernels_driver.c \
    $sundials -lm -o "$work/kernels"
ASAN_OPTIONS=detect_leaks=1:halt_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 "$work/kernels"

echo "sanitize: the phase machine in the pure-C driver, and the FMI glue driven as an importer would"
"$PY" - "$work" <<'PY'
import sys
from pathlib import Path
import impactgen
from impactgen.codegen.emit import driver_files, generate_model
from impactgen.engines import model_spec
from impactgen.fmu.package import fmu_sources
work = Path(sys.argv[1])
scene = impactgen.load_scene("paper")
driver = work / "driver_model"
driver.mkdir()
gen = generate_model(model_spec(scene))
for name, text in driver_files(gen, scene).items():
    (driver / name).write_text(text)
fmu = work / "fmu"
fmu.mkdir()
for name, text in fmu_sources(scene, "both").files.items():
    (fmu / name).write_text(text)
PY
SAN="-std=c99 -Wall -Wextra -Werror -g -O1 -fno-omit-frame-pointer -fsanitize=address,undefined -fno-sanitize-recover=undefined"
"$CC" $SAN -I"$work/driver_model" -Isrc/impactgen/native examples/c/impact_driver.c "$work/driver_model/model.c" \
    "$work/driver_model/model_params.c" $glue_sources \
    $sundials -lm -o "$work/impact_driver"
ASAN_OPTIONS=detect_leaks=1:halt_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 "$work/impact_driver" > /dev/null
"$CC" $SAN -DFMU_MODEL_EXCHANGE -DFMU_CO_SIMULATION -I"$work/fmu" "$work"/fmu/*.c tests/c/fmu_driver.c \
    $sundials -lm -o "$work/fmu_driver"
ASAN_OPTIONS=detect_leaks=1:halt_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 "$work/fmu_driver"

echo "sanitize: 2/2 simulation tests with the instrumented extension"
asan=$("$CC" -print-file-name=libasan.so)
export IMPACTGEN_SANITIZE=1 IMPACTGEN_CACHE_DIR="$work/cache"
# CPython itself keeps memory until exit: leaks are checked by the driver above, not here.
export ASAN_OPTIONS=detect_leaks=0:halt_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
# The sanitizer runtime is preloaded into this Python only: the compilers that build the
# instrumented models inherit the environment, and under the preloaded runtime's allocator
# they take about a third more CPU for the same objects.
LD_PRELOAD="$asan" "$PY" -c 'import os, sys; del os.environ["LD_PRELOAD"]; import pytest; sys.exit(pytest.main(sys.argv[1:]))' \
    -q -p no:cacheprovider tests/test_paper.py tests/test_phases.py tests/test_energy.py tests/test_coulomb.py \
    tests/test_sustained.py tests/test_memory.py tests/test_api.py tests/test_methods.py "$@"
echo "sanitize: clean"
