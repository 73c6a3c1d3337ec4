#!/usr/bin/env bash
# The peer benchmarks of ezy on the EzyRoller drive scene (see README.md).
#
#   bash benches/peers/run.sh [EZY]          EZY: path to the ezy binary
#                                            (adds ezy's own rows from
#                                            `EZY bench drive`)
#   SCAN=1 bash benches/peers/run.sh         also print each peer's error
#                                            over a grid of tolerances
#
# Environment: NICE (prefix of every measured command, e.g. "nice -n 10"),
# CPP_REPS (21), PY_REPS (5), PROCESS_REPS (21 for a compiled peer, 3 for a
# Python one), EZY_REPEAT (21).
#
# Builds the C++ peers into build/, creates .venv with requirements.txt,
# runs every peer at its tuned tolerance (the loosest of {1, 3} x 10^-k
# with error <= 1e-9 at t = 60 s against reference.csv, found with SCAN=1),
# times each whole process (median of PROCESS_REPS starts with one
# integration each, by spawn_time.py: posix_spawn, as `ezy bench` starts
# its own) and prints a Markdown table.
set -euo pipefail
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
EZY=${1:-}
if [ -n "$EZY" ]; then
  if [ ! -x "$EZY" ]; then
    echo "no ezy binary at $EZY" >&2
    exit 1
  fi
  EZY=$(cd "$(dirname "$EZY")" && pwd)/$(basename "$EZY")  # before the cd below
fi
cd "$HERE"
NICE=${NICE:-}
CPP_REPS=${CPP_REPS:-21}
PY_REPS=${PY_REPS:-5}
EZY_REPEAT=${EZY_REPEAT:-21}
CXX=${CXX:-g++}
CXXFLAGS=${CXXFLAGS:--O3 -march=native -std=c++17}

# --- build -------------------------------------------------------------------
mkdir -p build
echo "building the C++ peers: $CXX $CXXFLAGS" >&2
for p in dae_schur reduced; do
  # shellcheck disable=SC2086
  $NICE "$CXX" $CXXFLAGS -o "build/$p" "$p.cpp"
done

# ezy-core's own DOP853 on the same hand-derived reduced ODE, in Rust
# (ezy-core/examples/peer_reduced.rs): the integrator's share of the gap
echo "building the Rust peer: cargo build --release -p ezy-core --example peer_reduced" >&2
(cd "$HERE/../.." && $NICE cargo build --release -q -p ezy-core --example peer_reduced)
TARGET_DIR=${CARGO_TARGET_DIR:-$HERE/../../target}
RUST_PEER="$(cd "$TARGET_DIR" && pwd)/release/examples/peer_reduced"

# --- Python environment ------------------------------------------------------
PY=.venv/bin/python
if [ ! -x "$PY" ]; then
  echo "creating .venv" >&2
  python3 -m venv .venv
  .venv/bin/pip install -q --upgrade pip >&2
fi
.venv/bin/pip install -q -r requirements.txt >&2

# --- the peers: command | tuned tolerance | integration repetitions | starts --
# Tolerances (rtol = atol) from SCAN=1 on the reference machine; errors there:
#   dae_schur 1e-11: 4.2e-10 (3e-11: 1.4e-9)    reduced 3e-11: 5.3e-10 (1e-10: 2.2e-9)
#   peer_reduced (Rust) 3e-11: 5.1e-10 (1e-10: 2.0e-9, measured with ezy's own DOP853 on minimal coordinates)
#   dae_schur --no-projection 1e-11: 7.3e-10     scipy_numpy 1e-11: 7.2e-10 (3e-11: 2.1e-9)
#   casadi_cvodes 3e-14: 4.7e-10 (1e-13: 1.2e-9) sympy_codegen 3e-11: 5.9e-10 (1e-10: 1.7e-9)
#   pydy_scipy 1e-11: 7.0e-10 (3e-11: 2.3e-9)
FAST=${PROCESS_REPS:-21}   # whole-process starts of a compiled peer
SLOW=${PROCESS_REPS:-3}    # of a Python one (seconds each for SymPy, PyDy)
PEERS=(
  "build/dae_schur|1e-11|$CPP_REPS|$FAST"
  "build/dae_schur --no-projection|1e-11|$CPP_REPS|$FAST"
  "build/reduced|3e-11|$CPP_REPS|$FAST"
  "build/reduced --every 0.01|3e-11|$CPP_REPS|$FAST"
  "$RUST_PEER|3e-11|$CPP_REPS|$FAST"
  "$PY scipy_numpy.py|1e-11|$PY_REPS|$SLOW"
  "$PY casadi_cvodes.py|3e-14|$PY_REPS|$SLOW"
  "$PY sympy_codegen.py|3e-11|$PY_REPS|$SLOW"
  "$PY pydy_scipy.py|1e-11|$PY_REPS|$SLOW"
)

if [ "${SCAN:-0}" = 1 ]; then
  echo "## tolerance scan (error = max |q, qd - reference| at t = 60 s)"
  for entry in "${PEERS[@]}"; do
    IFS='|' read -r cmd _ _ _ <<<"$entry"
    for tol in 1e-9 3e-10 1e-10 3e-11 1e-11 3e-12 1e-12 3e-13 1e-13 3e-14 1e-14; do
      # shellcheck disable=SC2086
      $NICE $cmd --rtol "$tol" --reps 1 2>/dev/null | awk -F, '{print $1 " | " $2 " | " $3 " | " $6}'
    done
  done
  echo
fi

RESULTS=$(mktemp)
trap 'rm -f "$RESULTS"' EXIT
for entry in "${PEERS[@]}"; do
  IFS='|' read -r cmd tol reps starts <<<"$entry"
  echo "running: $cmd --rtol $tol --reps $reps" >&2
  # shellcheck disable=SC2086
  line=$($NICE $cmd --rtol "$tol" --reps "$reps" 2>/dev/null | tail -1)
  # shellcheck disable=SC2086
  whole=$($NICE "$PY" spawn_time.py "$starts" $cmd --rtol "$tol" --reps 1)
  echo "$line,$whole" >>"$RESULTS"
done

EZY_OUT=""
if [ -n "$EZY" ]; then
  echo "running: $EZY bench drive --repeat $EZY_REPEAT" >&2
  # shellcheck disable=SC2086
  EZY_OUT=$($NICE "$EZY" bench drive --repeat "$EZY_REPEAT")
fi

EZY_OUT="$EZY_OUT" CPP_REPS="$CPP_REPS" PY_REPS="$PY_REPS" EZY_REPEAT="$EZY_REPEAT" FAST="$FAST" SLOW="$SLOW" \
  "$PY" - "$RESULTS" <<'EOF'
import os, re, sys

def t(s):
    s = float(s)
    return f"{s * 1e6:.1f} µs" if s < 1e-3 else f"{s * 1e3:.2f} ms" if s < 1 else f"{s:.2f} s"

print("| tool | formulation | tolerance | RHS evals | integration | whole process | error |")
print("|---|---|---|---|---|---|---|")
rows = []
ezy = os.environ.get("EZY_OUT", "")
in_table = False
for line in ezy.splitlines():
    if line.startswith("setting"):
        in_table = True
        continue
    if not in_table or line.startswith("whole process") or not line.strip():
        continue
    cells = re.split(r"\s{2,}", line.strip())
    if len(cells) != 6:
        continue
    setting, integ, _output, evals, err, whole = cells
    m = re.search(r"rtol = atol = (\S+?),", setting)
    tol = m.group(1) if m else setting.split(",")[0]
    form = ("reduced on the minimal coordinates model! derives: 7 states, closed form, Maggi 2 x 2"
            if "reduced (minimal coordinates)" in setting else
            "reduced: coordinate partitioning, 7 states, dependent coordinates by Newton"
            if "reduced" in setting else "DAE index-1 Schur + mass-weighted projection")
    print(f"| ezy `bench` | {form}; {setting} | {tol} | "
          f"{evals} | {integ} | {whole} | {err} |")
for line in open(sys.argv[1]):
    f = line.strip().split(",")
    tool, form = f[0], ",".join(f[1:-5])
    tol, evals, integ, err, whole = f[-5:]
    print(f"| {tool} | {form} | {tol} | {evals} | {t(integ)} | {t(whole)} | {float(err):.1e} |")
print()
e = os.environ
print(f"integration: median of the peer's own repetitions (C++ {e['CPP_REPS']}, Python {e['PY_REPS']}) "
      "inside one process;")
print(f"whole process: median of fresh processes with one integration each (C++ and Rust {e['FAST']}, Python {e['SLOW']},")
print(f"ezy {e['EZY_REPEAT']} by `ezy bench`), each started by posix_spawn with no shell in between: interpreter")
print("start, imports, symbolic derivation and C compilation where the peer does them, integration, and for")
print("ezy the CSV written and synced.")
if ezy:
    print()
    print("```")
    print(ezy)
    print("```")
EOF
