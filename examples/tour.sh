#!/usr/bin/env bash
# The README's "Tour of the commands", verbatim, on the bundled example files (run from anywhere):
#   bash examples/tour.sh /tmp/tour
# writes every output into the scratch folder given (default ./feedtune_tour), which must be new or empty:
# the commands do not overwrite files (no --force). The folder gets a link "examples" to this directory so that
# the commands read examples/... as they do from the repository root.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
out="${1:-feedtune_tour}"
mkdir -p "$out"
if [ -n "$(ls -A "$out")" ]; then
    echo "tour.sh: $out is not empty; give a new or empty folder" >&2
    exit 2
fi
cd "$out"
ln -s "$here" examples
start=$SECONDS
set -x

# ball screw: FRF -> model -> MC-PPC and P-PI -> check -> C header
feedtune identify ballscrew examples/ballscrew_frf.csv --out model.toml
feedtune design ppc model.toml --notch 420,0.55,0.7 --notch 1080,0.05,0.7 --lpf 2000 \
    --frf examples/ballscrew_frf.csv --out mcppc.toml
feedtune design ppi model.toml --notch 420,0.55,0.7 --notch 1080,0.05,0.7 --lpf 2000 \
    --frf examples/ballscrew_frf.csv --out ppi.toml
feedtune tune mcppc model.toml --frf examples/ballscrew_frf_m70.csv --frf examples/ballscrew_frf_m100.csv \
    --frf examples/ballscrew_frf_m130.csv --out mcppc_family.toml
feedtune analyze mcppc.toml --frf examples/ballscrew_frf.csv --check
feedtune export c mcppc.toml --out mcppc.h --u-max 10 --anti-windup clamp

# the digital twin and the logs
feedtune trajectory --distance 0.1 --v-max 0.5 --a-max 9.81 --j-max 500 --out traj.csv
feedtune simulate track --trajectory traj.csv --gains mcppc.toml --seed 1 --out run.csv
feedtune simulate frf --seed 1 --out excitation.csv
feedtune frf excitation.csv --input u --output x1,x2 --reference r --method periodic --out frf.csv
feedtune identify rigid examples/ballscrew_reversals.csv --position x2 --input u --velocity-threshold 3 \
    --out rigid.toml
feedtune identify friction examples/ballscrew_reversals.csv --model rigid.toml --position x2 --min-speed 0.1 \
    --out friction.toml
feedtune prefilter examples/ballscrew_track.csv --gains mcppc.toml --out mcppc_pf.toml
feedtune analyze track examples/ballscrew_track.csv --json
feedtune analyze ropesnap examples/ballscrew_ropesnap.csv --json

# gantry
feedtune identify gantry examples/gantry_frf_x-0.3.csv examples/gantry_frf_x0.csv examples/gantry_frf_x0.3.csv \
    --x -0.3 --x 0 --x 0.3 --span 1.484 --out gantry.toml
feedtune design gantry gantry.toml --crossover-hz 60 --pm-deg 40 --damping-increase 5.9 --out mimo.toml
feedtune design pid gantry.toml --match mimo.toml --out pid.toml
feedtune design loopshape gantry.toml --crossover-hz 130 --pm-deg 35 --out axis.toml
feedtune simulate gantry ropesnap --gains mimo.toml --axis-gains axis.toml --out gantry_ropesnap.csv

# report and demo
feedtune report model.toml mcppc.toml ppi.toml friction.toml examples/ballscrew_frf.csv \
    examples/ballscrew_track.csv examples/ballscrew_ropesnap.csv --out report.html
feedtune project init --model model.toml --frf examples/ballscrew_frf_m70.csv --gains gains.toml \
    --structure mcppc --set tune.lpf=800
feedtune demo --out demo_out

set +x
echo "tour done in $((SECONDS - start)) s; files in $PWD: report.html, demo_out/report.html and every --out above"
