#!/usr/bin/env bash
# fpsolve's Monte Carlo against the numba peer on the same work (issue 12, item 1), back to
# back: REPS interleaved repetitions (default 5), then the medians. The peer runs with
# --fpsolve-work (everything `fpsolve simulate` runs: trajectories rounded to batches of 128,
# the pilot and the 2·dt bias run) and reports its wall time without numba's JIT; fpsolve's
# time is the whole process (/usr/bin/time). Both step counts are the peer's count of that
# work. The load (`uptime`) is printed with every repetition: quote it with the figures.
#
# Usage: benches/peers/compare_mc.sh [REPS]
#   FPSOLVE=path/to/fpsolve (default target/release/fpsolve; build it with
#   `cargo build --release`), PY=python with numba (default /work/peer-venv/bin/python),
#   THREADS=2.
set -euo pipefail
cd "$(dirname "$0")/../.."
REPS=${1:-5}
FPSOLVE=${FPSOLVE:-target/release/fpsolve}
PY=${PY:-/work/peer-venv/bin/python}
THREADS=${THREADS:-2}
ARGS=(--samples 4e7 --spacing 0.05 --dt 0.01 --trajectories 800 --burn-in 300 --threads "$THREADS")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
median() { tr ' ' '\n' | grep -v '^$' | sort -g | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }
peer_times="" fp_times="" steps=""
for r in $(seq "$REPS"); do
    peer=$("$PY" benches/peers/vibro_mc_numba.py "${ARGS[@]}" --fpsolve-work)
    pw=$(sed -n 's/.*; wall \([0-9.]*\) s;.*/\1/p' <<<"$peer")
    steps=$(sed -n 's/.* = \([0-9.e+-]*\) steps (.*/\1/p' <<<"$peer")
    /usr/bin/time -o "$tmp/time" -f %e "$FPSOLVE" simulate models/vibro_duffing.sde "${ARGS[@]}" \
        --out "$tmp/fpsolve" >"$tmp/fpsolve.log" 2>&1
    fw=$(tail -1 "$tmp/time")
    echo "rep $r: numba ${pw} s, fpsolve ${fw} s   (load $(uptime | sed 's/.*load average: //'))"
    peer_times="$peer_times $pw" fp_times="$fp_times $fw"
done
pm=$(median <<<"$peer_times")
fm=$(median <<<"$fp_times")
echo "$peer" | sed -n '/^quantity/,$p' | sed 's/^/numba   /'
echo "same work: $steps steps ($THREADS threads), medians of $REPS"
awk -v s="$steps" -v p="$pm" -v f="$fm" -v t="$THREADS" 'BEGIN {
    printf "numba peer (wall, JIT excluded): %.3f s  %.3e steps/s  %.3e per thread\n", p, s / p, s / p / t
    printf "fpsolve (whole process):         %.3f s  %.3e steps/s  %.3e per thread\n", f, s / f, s / f / t
    printf "fpsolve / numba speed: %.2fx\n", p / f
}'
