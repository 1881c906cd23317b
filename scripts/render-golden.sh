#!/usr/bin/env bash
# Renders a fixed set of images (same seeds, same sizes) with the restir-demo binary BIN into
# OUT: nee, ris and world-restir (static and orbiting camera) on cornell and many-lights, and
# nee, ris and world-restir on furnace and colonnade.
# `scripts/same-images.sh` runs it for two revisions and checks the EXRs are byte-identical.
# usage: scripts/render-golden.sh BIN OUT
set -euo pipefail
bin=$1
out=$2
mkdir -p "$out"
for scene in cornell many-lights; do
  for method in nee ris world-restir; do
    "$bin" render --scene "$scene" --lights 2000 --method "$method" --size 64x48 --frames 6 \
      --seed 7 --out "$out/$scene-$method-static" >/dev/null 2>>"$out/render.log"
  done
  "$bin" render --scene "$scene" --lights 2000 --method world-restir --animation orbit \
    --anim-frames 4 --orbit-degrees 20 --size 64x48 --frames 6 --seed 7 \
    --out "$out/$scene-world-restir-orbit" >/dev/null 2>>"$out/render.log"
done
for scene in furnace colonnade; do
  for method in nee ris world-restir; do
    "$bin" render --scene "$scene" --method "$method" --size 48x32 --frames 4 --seed 7 \
      --out "$out/$scene-$method-static" >/dev/null
  done
done
find "$out" -name '*.exr' | sort
