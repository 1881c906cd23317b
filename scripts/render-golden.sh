#!/usr/bin/env bash
# Renders a fixed set of images (same seeds, same sizes) with the restir-demo binary BIN into
# OUT: every method and variant of the registry, static and with an orbiting camera, on cornell
# and many-lights; the baselines and world-restir on furnace and colonnade; the radiance cache
# (unbounded paths); the denoiser after ris and restir-gi; and a set at one bounce without MIS
# (--bounces 1 --mis off) on cornell.
# `scripts/same-images.sh` runs it for two revisions and checks the EXRs are byte-identical.
# usage: scripts/render-golden.sh BIN OUT [EXTRA-RENDER-ARGS...]
# GOLDEN_FILTER: an extended regex; only the images whose names match it are rendered (e.g.
# GOLDEN_FILTER='restir-(di|gi)' for a change that touches only those methods).
set -euo pipefail
bin=$1
out=$2
shift 2
extra=("$@")
mkdir -p "$out"
methods=(nee ris ris:4
  world-restir world-restir:no-reuse world-restir:temporal world-restir:spatial
  world-restir:no-adaptive world-restir:no-jitter world-restir:biased world-restir:one-over-z
  world-restir:paper-grid world-restir:unified
  restir-di restir-di:no-reuse restir-di:temporal restir-di:spatial restir-di:biased
  world-restir+restir-di world-restir+restir-di:gi-tiles world-restir+restir-di:biased
  restir-gi restir-gi:no-reuse restir-gi:temporal restir-gi:spatial restir-gi:biased
  restir-gi+world-restir restir-di+restir-gi+world-restir
  world-restir-gi world-restir-gi:no-reuse world-restir-gi:biased world-restir-gi+world-restir)
render() { # name, args...
  local name=$1
  shift
  [[ -z ${GOLDEN_FILTER:-} || $name =~ $GOLDEN_FILTER ]] || return 0
  "$bin" render "$@" "${extra[@]}" --out "$out/$name" >/dev/null 2>>"$out/render.log" ||
    { echo "render $name failed:" >&2; tail -3 "$out/render.log" >&2; exit 1; }
}
for scene in cornell many-lights; do
  for method in "${methods[@]}"; do
    tag=${method//[:+]/_}
    render "$scene-$tag-static" --scene "$scene" --lights 2000 --method "$method" --size 64x48 \
      --frames 6 --seed 7
    render "$scene-$tag-orbit" --scene "$scene" --lights 2000 --method "$method" \
      --animation orbit --anim-frames 4 --orbit-degrees 20 --size 64x48 --frames 6 --seed 7
  done
done
for scene in furnace colonnade; do
  for method in nee ris world-restir restir-di world-restir+restir-di; do
    tag=${method//[:+]/_}
    render "$scene-$tag-static" --scene "$scene" --method "$method" --size 48x32 --frames 4 --seed 7
  done
done
for scene in cornell many-lights; do
  for method in ris+cache restir-gi+cache world-restir-gi+cache; do
    tag=${method//[:+]/_}
    render "$scene-$tag-static" --scene "$scene" --lights 2000 --method "$method" --size 64x48 \
      --frames 6 --seed 7 --bounces 64
  done
done
# The denoiser after the raw methods it is fed, orbiting (its history reprojected).
for scene in cornell many-lights; do
  for method in ris restir-gi; do
    render "$scene-$method-denoise-orbit" --scene "$scene" --lights 2000 --method "$method" \
      --denoise --animation orbit --anim-frames 4 --orbit-degrees 20 --size 64x48 --frames 6 \
      --seed 7
  done
done
for method in nee ris world-restir restir-di restir-gi world-restir+restir-di \
  restir-di+restir-gi+world-restir; do
  tag=${method//[:+]/_}
  render "cornell-$tag-bounces1-nomis" --scene cornell --method "$method" --size 48x32 --frames 4 \
    --seed 7 --bounces 1 --mis off
done
find "$out" -name '*.exr' | sort
