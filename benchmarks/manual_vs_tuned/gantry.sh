#!/usr/bin/env bash
# Run in an empty folder: bash benchmarks/manual_vs_tuned/gantry.sh (about two minutes); prints the table of the issue-12 note.
# Gantry: manual (section 4.4.2: MIMO 60 Hz, PM 40 deg, +590 % damping, the thesis h(s); PIDs matched to its Ms
# with its notches and low-pass) vs tuned on the twin's FRFs at x = -0.3, 0, 0.3 m; textbook limits.
set -euo pipefail
feedtune simulate gantry frf -o g.csv --x -0.3 --x 0 --x 0.3 --force > /dev/null
rm -f g_x-0.3.csv g_x0.csv g_x0.3.csv
feedtune identify gantry g_x-0.3_frf.csv g_x0_frf.csv g_x0.3_frf.csv --x -0.3 --x 0 --x 0.3 --span 1.484 --out gantry.toml --force > /dev/null
H="--notch 110,0.5,0.7 --notch 320,0.2,0.9 --notch 400,0.15,1.0 --notch 940,0.6,0.75 --lpf 450 --lead 154,70"
F="--frf g_x-0.3_frf.csv --frf g_x0_frf.csv --frf g_x0.3_frf.csv"
feedtune design gantry gantry.toml --crossover-hz 60 --pm-deg 40 --damping-increase 5.9 $H --frf g_x0_frf.csv -o manual_mimo.toml --force > /dev/null
feedtune design pid gantry.toml --match manual_mimo.toml --frf g_x0_frf.csv -o manual_pid.toml --force > /dev/null
feedtune tune gantry gantry.toml $F $H -o tuned_mimo.toml --force > /dev/null
feedtune tune gantry gantry.toml $F $H --filters own -o tuned_mimo_own.toml --force > /dev/null
feedtune tune pid gantry.toml $F -o tuned_pid.toml --force > /dev/null
for g in manual_mimo tuned_mimo tuned_mimo_own manual_pid tuned_pid; do
  feedtune simulate gantry ropesnap -g $g.toml -o rs_$g.csv --force --json > rs_$g.json
  feedtune simulate gantry track -g $g.toml -o tr_$g.csv --force --json > tr_$g.json
done
python "$(dirname "$0")/table.py" gantry g_x-0.3_frf.csv,g_x0_frf.csv,g_x0.3_frf.csv manual_mimo,tuned_mimo,tuned_mimo_own,manual_pid,tuned_pid textbook
