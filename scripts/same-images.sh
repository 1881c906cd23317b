#!/usr/bin/env bash
# Checks that a change renders byte-identical images: builds restir-demo at BASE (a git
# revision) in a temporary worktree and at the working tree, renders the fixed set of
# scripts/render-golden.sh with both, and compares every EXR byte for byte.
# usage: scripts/same-images.sh BASE   (e.g. scripts/same-images.sh HEAD~3)
# AFTER_ARGS: render arguments for the working tree's binary only, for a default that changed
# on purpose (e.g. AFTER_ARGS="--bounces 1" checks that one bounce renders as before).
# GOLDEN_FILTER: only the images whose names match this extended regex (render-golden.sh).
set -euo pipefail
base=${1:?usage: scripts/same-images.sh BASE}
root=$(git rev-parse --show-toplevel)
work=$(mktemp -d)
trap 'git -C "$root" worktree remove --force "$work/base" >/dev/null 2>&1 || true; rm -rf "$work"' EXIT
git -C "$root" worktree add --detach "$work/base" "$base" >/dev/null
# The base revision builds in its own target directory so the working tree's stays warm.
(cd "$work/base" && CARGO_TARGET_DIR="$root/target/same-images-base" cargo build --release -q -p demo)
(cd "$root" && cargo build --release -q -p demo)
"$root/scripts/render-golden.sh" "$root/target/same-images-base/release/restir-demo" "$work/before" >/dev/null
# shellcheck disable=SC2086 # AFTER_ARGS is a list of arguments
"$root/scripts/render-golden.sh" "$root/target/release/restir-demo" "$work/after" ${AFTER_ARGS:-} >/dev/null
count=0
for f in $(cd "$work/before" && find . -name '*.exr' | sort); do
  cmp -s "$work/before/$f" "$work/after/$f" || { echo "DIFFERENT: $f"; exit 1; }
  count=$((count + 1))
done
[ "$count" -gt 0 ] || { echo "no images rendered"; exit 1; }
echo "identical: $count EXRs (base $base)"
