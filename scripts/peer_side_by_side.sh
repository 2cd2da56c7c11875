#!/usr/bin/env bash
# Side by side in one sitting: the reference library's DFSPH dam break (SPlisHSPlasH, built with
# ../shared/peer-bench) and sphaptics' DFSPH on the same scene (scenes/peer/dam_break_50k.yaml),
# runs interleaved so that both see the same machine. Wall time of the whole process, including
# start-up. Both simulate the same 0.5 s: the reference stops at 0.5 s (--stopAt), sphaptics ends a frame
# exactly, so it runs 10 frames of 1/20 s (until session 53 it ran the scene's 13 frames of 1/25 s, 0.52 s,
# 4.7 % more steps than 0.5 s, and the ratios were taken from the wall times). Writes CSV to stdout:
# code,config,run,wall_s,simulated_s,steps,density_iterations_per_step; then, on stderr, each configuration's
# median wall time, per simulated second, and its ratio to the reference's default configuration.
#   PEER_BIN=.../SPlisHSPlasH/bin/SPHSimulator PEER_SCENES=.../scenes scripts/peer_side_by_side.sh [REPS]
# PEER_CONFIGS and SPH_CONFIGS choose a subset (defaults: all three and all four below); SPHAPTICS picks the
# binary (default build/cli/sphaptics) and SPHAPTICS_BASELINE adds a second one's defaults (before and after).
set -euo pipefail
reps=${1:-3}
: "${PEER_BIN:?set PEER_BIN to the SPHSimulator binary of SPlisHSPlasH (../shared/peer-bench/README.md)}"
: "${PEER_SCENES:?set PEER_SCENES to the folder 03_make_scenes.py wrote}"
top=$(cd "$(dirname "$0")/.." && pwd)
sph=${SPHAPTICS:-$top/build/cli/sphaptics}
scene=$top/scenes/peer/dam_break_50k.yaml
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-2}
now() { date +%s.%N; }
echo "code,config,run,wall_s,simulated_s,steps,density_iterations_per_step" | tee "$work/csv"
# The reference at twice its Courant number too (its step is cflFactor 0.4 diameter / |v|max, so
# cflFactor 2 is sphaptics' fluid.dfsph.cfl 0.8, the default since session 50): ratios at equal steps.
sed 's/"cflFactor": 1,/"cflFactor": 2,/' "$PEER_SCENES/dambreak50k_dfsph.json" > "$work/dambreak50k_dfsph_cfl0.8.json"
grep -q '"cflFactor": 2,' "$work/dambreak50k_dfsph_cfl0.8.json" || { echo "no cflFactor 1 in $PEER_SCENES/dambreak50k_dfsph.json" >&2; exit 1; }
for k in $(seq 1 "$reps"); do
  for c in ${PEER_CONFIGS:-dambreak50k_dfsph dambreak50k_dfsph_akinci dambreak50k_dfsph_cfl0.8}; do
    json=$PEER_SCENES/$c.json
    [ -f "$json" ] || json=$work/$c.json
    t0=$(now); "$PEER_BIN" --no-gui --stopAt 0.5 --output-dir "$work/peer" "$json" > "$work/peer.log" 2>&1; t1=$(now)
    it=$(sed -n 's/.*Average number: DFSPH - iterations: \([0-9.]*\).*/\1/p' "$work/peer.log" | tail -1)
    steps=$(sed -n 's/.*Total number: DFSPH - iterations: \([0-9]*\).*/\1/p' "$work/peer.log" | tail -1)
    steps=$(awk -v n="$steps" -v a="$it" 'BEGIN { if (a > 0) printf "%.0f", n / a }')
    echo "splishsplash,$c,$k,$(echo "$t1 - $t0" | bc),0.5,$steps,$it"
  done
  # the three wall models at the scene's settings (the reference's: Courant number 0.4; the pressure step
  # bound at sphaptics' default, 0.5 since session 50), then the default walls at the Courant number 0.8:
  # sphaptics' defaults since session 50 (session 48: with the Chebyshev semi-iteration the longer step pays)
  # (with SPHAPTICS_BASELINE, another sphaptics binary, e.g. main before a change, runs the defaults too, in
  # the same sitting: configuration baseline_extrapolated_cfl0.8)
  for w in ${SPH_CONFIGS:-single extrapolated mirrored extrapolated_cfl0.8} ${SPHAPTICS_BASELINE:+baseline_extrapolated_cfl0.8}; do
    bin=$sph
    case $w in baseline_*) bin=$SPHAPTICS_BASELINE ;; esac
    walls=${w#baseline_}
    extra=(--set simulation.frame_rate=20 --set fluid.dfsph.walls=${walls%_cfl*})
    case $w in *_cfl*) extra+=(--set fluid.dfsph.cfl=${w#*_cfl}) ;; esac
    t0=$(now); "$bin" run "$scene" -o "$work/sph" "${extra[@]}" > "$work/sph.log" 2>&1; t1=$(now)
    done_line=$(grep '^done:' "$work/sph.log")
    sim=$(echo "$done_line" | sed -n 's/.* \([0-9.]*\) s simulated.*/\1/p')
    steps=$(echo "$done_line" | sed -n 's/.* \([0-9]*\) steps.*/\1/p')
    it=$(sed -n 's/.*DFSPH: \([0-9.]*\) density.*/\1/p' "$work/sph.log")
    echo "sphaptics,dfsph_walls_$w,$k,$(echo "$t1 - $t0" | bc),$sim,$steps,$it"
  done
done | tee -a "$work/csv"
# the summary: medians over the rounds, per simulated second, against the reference's default configuration
python3 - "$work/csv" >&2 <<'PY'
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1])))
runs, by_round = {}, {}
for r in rows:
    per_s = float(r["wall_s"]) / float(r["simulated_s"])
    runs.setdefault((r["code"], r["config"]), []).append(per_s)
    by_round[(r["code"], r["config"], r["run"])] = per_s
ref = runs.get(("splishsplash", "dambreak50k_dfsph"))
ref_med = statistics.median(ref) if ref else None
print("summary (wall s per simulated second, medians of the rounds; ratios to the reference's default")
print("configuration: of the medians, and the median of each round's own ratio):")
for (code, config), v in runs.items():
    med = statistics.median(v)
    line = f"  {code:13s} {config:32s} {med:7.2f} s  (runs {', '.join(f'{x:.2f}' for x in v)})"
    if ref_med:
        own = [by_round[(code, config, k)] / by_round[("splishsplash", "dambreak50k_dfsph", k)]
               for (c2, g2, k) in by_round if (c2, g2) == (code, config)
               and ("splishsplash", "dambreak50k_dfsph", k) in by_round]
        line += f"  {med / ref_med:.3f}x the reference; per round {statistics.median(own):.3f}x"
    print(line)
PY
