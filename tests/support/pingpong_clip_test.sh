#!/usr/bin/env bash
# scripts/pingpong_clip.py (docs/BENCHMARKS.md, "Session 26"): a clip of 3 frames played back and
# forth into 7 frames is 1 2 3 2 1 2 3, every file of a frame follows it, and an existing output
# folder is refused (nothing overwritten).
set -euo pipefail
src=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$tmp/ycbv/data/0007" "$tmp/ycbv/models"
echo "001_thing" > "$tmp/ycbv/classes.txt"
for i in 1 2 3; do
  for f in color.png depth.png label.png meta.mat; do echo "$i" > "$tmp/ycbv/data/0007/00000$i-$f"; done
done
/usr/bin/python3 "$src/scripts/pingpong_clip.py" --dataset "$tmp/ycbv" --scenes 0007 --frames 7 \
  --out "$tmp/long"
got=""
for k in 1 2 3 4 5 6 7; do
  for f in color.png depth.png label.png meta.mat; do
    [ "$(cat "$tmp/long/data/0007/00000$k-$f")" = "$(cat "$tmp/long/data/0007/00000$k-color.png")" ] ||
      { echo "frame $k: $f is not the colour image's frame"; exit 1; }
  done
  got+="$(cat "$tmp/long/data/0007/00000$k-color.png") "
done
[ "$got" = "1 2 3 2 1 2 3 " ] || { echo "order '$got', expected '1 2 3 2 1 2 3 '"; exit 1; }
[ -e "$tmp/long/classes.txt" ] && [ -d "$tmp/long/models" ] || { echo "classes.txt / models not linked"; exit 1; }
[ "$(ls "$tmp/long/data/0007" | wc -l)" = 28 ] || { echo "expected 28 files"; exit 1; }
if /usr/bin/python3 "$src/scripts/pingpong_clip.py" --dataset "$tmp/ycbv" --scenes 0007 --frames 7 \
  --out "$tmp/long" 2>/dev/null; then
  echo "an existing output folder was not refused"
  exit 1
fi
echo "pingpong_clip: ok"
