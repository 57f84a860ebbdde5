#!/usr/bin/env bash
# The main job on the bundled example FRF; writes into ./feedtune_quickstart (run from anywhere).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
frf="$here/ballscrew_frf.csv"
out="${1:-feedtune_quickstart}"
mkdir -p "$out"
filters=(--notch 420,0.55,0.7 --notch 1080,0.05,0.7 --lpf 2000)
feedtune identify ballscrew "$frf" --out "$out/model.toml" --force
# both tuned for the highest first crossover under the same limits (default: textbook)
feedtune design ppc "$out/model.toml" "${filters[@]}" --frf "$frf" --out "$out/mcppc.toml" --force
feedtune design ppi "$out/model.toml" "${filters[@]}" --frf "$frf" --out "$out/ppi.toml" --force
feedtune export c "$out/mcppc.toml" --out "$out/mcppc.h" --force
echo "files in $out: model.toml, mcppc.toml, ppi.toml (with .json twins), mcppc.h"
