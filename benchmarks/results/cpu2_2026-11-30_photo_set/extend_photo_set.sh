#!/usr/bin/env bash
# extend_photo_set.sh LABELS CAPTIONS IMAGES: the command that added the box-only photos to benchmarks/realism/photos
# (30 Nov 2026), run from the repository root on the set of 156 photos with masks. Its sources, fetched from GitHub:
#   LABELS   coco/labels/val2017 of insigh1/Interactive_ABCs_with_American_Sign_Language_using_Yolov5 at a10d74895e53bce566d575cfd0c8a5614800e2db
#   CAPTIONS annotations/captions_val2017.json of ruizewang/evaluate at 1152656d3b8c66c48fc6a4357e159f5e21bd2d2d
#   IMAGES   the .jpg files of coco/images/val2017 and coco/images/train2017 of minto5z/coco_yolo at
#            4715f5ca05a6ffc148d4c4e5b0a131663655f2be, in one folder (2,693 val2017 images, no name in both)
# The set's first seven sources are passed again: the manifest keeps every source in info.origins.
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: $0 LABELS CAPTIONS IMAGES" >&2; exit 2; }
OUT=benchmarks/realism/photos
mapfile -t OLD < <(sed -n 's/^- \(github.com.*\)$/\1/p' "$OUT/ATTRIBUTION.md" | head -n 7)
args=()
for o in "${OLD[@]}"; do args+=(--origin "$o"); done
uv run python tools/realism_photos.py --extend --box-source "$1" "$2" "$3" --out "$OUT" "${args[@]}" \
  --origin "github.com/minto5z/coco_yolo at commit 4715f5ca05a6ffc148d4c4e5b0a131663655f2be (\`coco/images/val2017\`, \`coco/images/train2017\`: val2017 images, each at its val2017 size) with the YOLO labels of all val2017 images (Ultralytics' conversion of COCO's boxes, crowd regions left out) of github.com/insigh1/Interactive_ABCs_with_American_Sign_Language_using_Yolov5 at commit a10d74895e53bce566d575cfd0c8a5614800e2db (\`coco/labels/val2017\`) and the image sizes, licences and URLs of COCO's \`captions_val2017.json\` from github.com/ruizewang/evaluate at commit 1152656d3b8c66c48fc6a4357e159f5e21bd2d2d (\`annotations/captions_val2017.json\`)"
