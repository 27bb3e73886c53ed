#!/usr/bin/env bash
# Regenerates the README's pictures (docs/img/) with bubblemesh itself.
#
#   scripts/make_pictures.sh
#
# Needs a Rust toolchain; the viewer screenshot also needs Debian's
# `chromium` (skipped with a message when it is absent). Every picture comes
# from the command line exactly as a user would run it.
set -euo pipefail
cd "$(dirname "$0")/.."

cargo build --release --quiet -p bubblemesh-cli
bm=target/release/bubblemesh
img=docs/img
mkdir -p "$img"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

echo "plate with two holes: quality colours"
$bm mesh examples/plate_two_holes.toml -o "$img/plate_quality.png" --size 0.03 --width 800 --quiet

echo "graded spacing with the bubbles drawn"
$bm mesh examples/plate_two_holes.toml -o "$img/plate_bubbles.png" --size "0.02 + 0.05*x" \
  --bubbles --width 800 --quiet

echo "two faces coloured by entity (SVG)"
$bm mesh examples/two_faces.toml -o "$img/two_faces_entity.svg" --size "0.04 + 0.04*y" \
  --color entity --width 640 --quiet

if [ -f examples/sphere.toml ]; then
  echo "sphere (a closed surface) seen from (1,-1,1), with and without bubbles"
  $bm mesh examples/sphere.toml -o "$img/sphere.png" --size 0.15 --width 420 --quiet
  $bm mesh examples/sphere.toml -o "$img/sphere_bubbles.png" --size 0.15 --bubbles --width 420 --quiet
fi

echo "energy history and histograms"
$bm mesh examples/plate_two_holes.toml -o "$tmp/plate.msh" --size "0.02 + 0.05*x" \
  --plots "$tmp/plots" --quiet
for f in energy radius_ratio angles length_ratio; do
  cp "$tmp/plots/$f.svg" "$img/$f.svg"
done

echo "the bubbles settling (stage 1, then stage 2 after 4 and 32 steps, then final)"
$bm mesh examples/plate_two_holes.toml -o "$tmp/settle.msh" --size 0.08 --width 480 \
  --frames "$tmp/frames" --quiet
frames=("$tmp"/frames/frame_*.png)
last=$((${#frames[@]} - 1))
cp "$tmp/frames/frame_000.png" "$img/settle_1_stage1.png"
cp "$tmp/frames/frame_003.png" "$img/settle_2_step4.png"
cp "$tmp/frames/frame_006.png" "$img/settle_3_step32.png"
cp "${frames[$last]}" "$img/settle_4_final.png"

browser=$(command -v chromium || command -v chromium-browser || true)
if [ -n "$browser" ]; then
  echo "the HTML viewer, in headless $browser"
  $bm mesh examples/plate_two_holes.toml -o "$tmp/plate.html" --size 0.04 --quiet
  "$browser" --headless --no-sandbox --disable-gpu --disable-background-networking \
    --disable-component-update --disable-sync --no-first-run --hide-scrollbars \
    --user-data-dir="$tmp/profile" --virtual-time-budget=5000 --window-size=960,600 \
    --screenshot="$img/viewer.png" "file://$(realpath "$tmp/plate.html")" 2>/dev/null
else
  echo "no chromium: docs/img/viewer.png not regenerated" >&2
fi
ls -l "$img"
