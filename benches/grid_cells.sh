#!/usr/bin/env bash
# Time and peak memory of the grid solver by cell count, 5k to 320k cells, as whole
# processes: `fpsolve solve models/vibro_impact_duffing.sde --method grid --cells NX,NV`
# (the error estimate's half-cells solve included, as in the default job). The largest size
# is 560x1120 (627,200 cells, ~2.9 GB): the CLI's memory guard (grid::Cells::memory_bytes,
# 320 bytes per n·log2 n, 1.33 times the measured peak there) stops near 700k cells under
# its 4 GiB cap.
#
# Usage: cargo build --release && benches/grid_cells.sh [RUNS]   (default 5 runs per size)
#        FPSOLVE_BIN=/path/to/other/fpsolve benches/grid_cells.sh [RUNS]   (another build, e.g.
#        a "before" binary; run both in the same minutes, interleaved, on a quiet machine)
# Prints, per size: cells, median wall time (s), min and max wall time, max resident set
# size (MB, the largest over the runs), and the solver's own timings (ms) from summary.json.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${FPSOLVE_BIN:-target/release/fpsolve}
runs=${1:-5}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
echo "load before: $(uptime)"
printf '%-9s %-8s %-9s %-17s %-8s %s\n' cells n median_s min..max_s rss_MB "solver ms (assemble/solve/estimate/total)"
for cells in 50,100 100,200 200,400 392,800 560,1120; do
    nx=${cells%,*}; nv=${cells#*,}
    times=(); rss=0
    for _ in $(seq "$runs"); do
        line=$( { /usr/bin/time -f '%e %M' "$bin" solve models/vibro_impact_duffing.sde \
            --method grid --cells "$cells" --out "$out" --quiet >/dev/null; } 2>&1 | tail -1)
        times+=("${line% *}")
        kb=${line#* }
        (( kb > rss )) && rss=$kb
    done
    sorted=$(printf '%s\n' "${times[@]}" | sort -g)
    median=$(echo "$sorted" | awk '{a[NR]=$1} END{print a[int((NR+1)/2)]}')
    range="$(echo "$sorted" | head -1)..$(echo "$sorted" | tail -1)"
    ms=$(python3 -c "import json;t=json.load(open('$out/summary.json'))['grid']['report']['timings'];print('%.0f/%.0f/%.0f/%.0f'%(t['assemble_ms'],t['solve_ms'],t['estimate_ms'],t['total_ms']))")
    printf '%-9s %-8s %-9s %-17s %-8s %s\n' "$cells" $((nx * nv)) "$median" "$range" $((rss / 1024)) "$ms"
done
echo "load after: $(uptime)"
