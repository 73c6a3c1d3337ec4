#!/usr/bin/env bash
# Instructions per run of ezy's fastest DOP853 settings on `drive` against
# the C++ peer (benches/peers/reduced.cpp), counted by callgrind inside
# ezy's `simulate` and the C++'s `dop853::integrate` only, over 6 runs:
#
#   bash benches/peers/icount.sh            (needs valgrind and g++)
#
# Prints, per run: ezy with output at 60 s only and every 0.01 s, the C++
# the same, and the ratios the performance targets are stated in.
set -euo pipefail
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
cd "$HERE/../.."
cargo build --release -q -p ezy-models --example drive_runs
BIN=${CARGO_TARGET_DIR:-target}/release/examples/drive_runs
mkdir -p "$HERE/build"
g++ -O3 -std=c++17 -o "$HERE/build/reduced_generic" "$HERE/reduced.cpp"
ic() { valgrind --tool=callgrind --callgrind-out-file=/dev/null "$@" 2>&1 | sed -n 's/.*refs: *//p' | tr -d ,; }
e=$(ic --toggle-collect='ezy_core::simulate::simulate*' "$BIN" 6 60)
OUT=$(mktemp)
o=$(valgrind --tool=callgrind --callgrind-out-file="$OUT" --toggle-collect='ezy_core::simulate::simulate*' "$BIN" 6 0.01 2>&1 | sed -n 's/.*refs: *//p' | tr -d ,)
# the output batches (each sample's full state, energies, residuals, the
# observer), which `ezy bench` times apart from the integration
f=$(callgrind_annotate --inclusive=yes "$OUT" | sed -n 's/^ *\([0-9,]*\) .*Run<M,O>>::flush .*/\1/p' | head -1 | tr -d ,)
rm -f "$OUT"
cd "$HERE"  # the C++ reads reference.csv from here
c=$(ic --toggle-collect='*dop853::integrate*' build/reduced_generic --rtol 3e-11 --reps 6)
ce=$(ic --toggle-collect='*dop853::integrate*' build/reduced_generic --rtol 3e-11 --every 0.01 --reps 6)
python3 -c "
e, o, f, c, ce = $e / 6, $o / 6, ${f:-0} / 6, $c / 6, $ce / 6
print(f'ezy, output at 60 s only:  {e / 1e6:.3f} M instructions a run')
print(f'ezy, output every 0.01 s:  {o / 1e6:.3f} M ({o / e:.3f}x); without the output batches {(o - f) / 1e6:.3f} M ({(o - f) / e:.3f}x)')
print(f'C++, output at the end:    {c / 1e6:.3f} M')
print(f'C++, output every 0.01 s:  {ce / 1e6:.3f} M ({ce / c:.3f}x)')
print(f'ezy / C++: {e / c:.3f} (output at 60 s only), {o / ce:.3f} (every 0.01 s)')"
