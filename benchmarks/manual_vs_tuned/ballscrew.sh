#!/usr/bin/env bash
# Run in an empty folder: bash benchmarks/manual_vs_tuned/ballscrew.sh (about a minute); prints the table of the issue-12 note.
# Ball screw: manual (thesis MC-PPC: beta 4, 50 Hz, zeta 0.7, thesis filters) vs tuned, on the twin measured with
# the table mass at 0.7, 1.0 and 1.3 times Table 3.1's; thesis limits (Ms <= 3.25, PM >= 30 deg).
set -euo pipefail
m2=0.000379
for s in 0.7 1.0 1.3; do
  feedtune simulate frf -p m2=$(python -c "print($m2*$s)") -o run_m$s.csv --frf-out frf_m$s.csv --force > /dev/null
  rm run_m$s.csv
done
feedtune identify ballscrew frf_m1.0.csv --out model.toml --force > /dev/null
P="--notch 420,0.55,0.7 --notch 1080,0.05,0.7 --lpf 2000"
F="--frf frf_m0.7.csv --frf frf_m1.0.csv --frf frf_m1.3.csv"
feedtune design ppc model.toml --beta 4 --pole-hz 50 --zeta 0.7 $P --frf frf_m1.0.csv --limits thesis --allow-unstable -o manual.toml --force > /dev/null 2>&1
feedtune tune mcppc model.toml $F $P --limits thesis -o tuned.toml --force > /dev/null
feedtune tune mcppc model.toml $F --limits thesis -o tuned_own.toml --force > /dev/null
for g in manual tuned tuned_own; do
  feedtune simulate ropesnap -g $g.toml -o rs_$g.csv --force --json > rs_$g.json
  feedtune simulate track -g $g.toml -o tr_$g.csv --distance 0.1 --v-max 0.5 --a-max 9.81 --j-max 500 --force --json > tr_$g.json
done
python "$(dirname "$0")/table.py" ballscrew frf_m0.7.csv,frf_m1.0.csv,frf_m1.3.csv manual,tuned,tuned_own thesis
