#!/usr/bin/env bash
# Sets up Mitsuba 3 (LLVM backend, variant llvm_ad_rgb) as a side-by-side peer for benchmarks/.
# Idempotent: re-running only checks what is already there.
#
#   source benchmarks/setup_mitsuba.sh     # also exports DRJIT_LIBLLVM_PATH into your shell
#   bash benchmarks/setup_mitsuba.sh       # just installs; prints the export line
#
# Creates benchmarks/.venv (gitignored) with mitsuba==3.9.1, drjit==1.5.0 and numpy. drjit 1.5 needs
# LLVM >= 17; Debian 12's libllvm14/15/16 abort on the first path-tracing kernel, so libllvm19 is installed.
set -euo pipefail

BENCH_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
VENV="$BENCH_DIR/.venv"
LLVM_LIB=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1

if [ ! -e "$LLVM_LIB" ]; then
    echo "setup_mitsuba: installing libllvm19" >&2
    SUDO=""
    [ "$(id -u)" -ne 0 ] && SUDO=sudo
    $SUDO apt-get update -qq
    $SUDO apt-get install -y -qq libllvm19 >/dev/null
fi

if [ ! -x "$VENV/bin/python" ]; then
    echo "setup_mitsuba: creating $VENV" >&2
    python3 -m venv "$VENV"
fi
if ! "$VENV/bin/python" -c 'import mitsuba, drjit, numpy; assert mitsuba.__version__ == "3.9.1" and drjit.__version__ == "1.5.0"' 2>/dev/null; then
    "$VENV/bin/pip" install -q "mitsuba==3.9.1" "drjit==1.5.0" numpy
fi

export DRJIT_LIBLLVM_PATH="$LLVM_LIB"
# Smoke test: the LLVM variant loads and compiles a kernel.
"$VENV/bin/python" - <<'EOF'
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")
import drjit as dr
x = dr.arange(mi.Float, 4) * 2
assert x.numpy().tolist() == [0, 2, 4, 6]
print(f"setup_mitsuba: mitsuba {mi.__version__} / drjit {dr.__version__}, variant llvm_ad_rgb OK")
EOF
echo "export DRJIT_LIBLLVM_PATH=$LLVM_LIB"
