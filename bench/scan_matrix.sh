#!/usr/bin/env bash
# The scan front end's full matrix (issue 36): the plate with small openings, the case-3 block and the
# bicone, each scanned on a grid, at random, Poisson-disk resampled and as overlapping partial views of
# different density; noise σ 0, ε/4, ε/2 (ε 0.1 mm); view offsets ε/5; 0.5 % strays; seeds 1–3. Every
# run is held against the truth (tests/tools/scan_matrix.cpp says how) and printed as a Markdown row;
# docs/scan.md keeps the table. Usage: bench/scan_matrix.sh [BUILD_DIR] [scan-matrix options...]
set -euo pipefail
build="${1:-build/release}"
shift || true
start=$(date +%s)
status=0
"$build/tests/scan-matrix" --parts plate_small_openings,case3_block,bicone --samplings grid,random,poisson,views \
  --sigmas 0,0.025,0.05 --seeds 1,2,3 --tolerance 0.1 --view-offset 0.02 --stray-fraction 0.005 "$@" || status=$?
echo "matrix time: $(( $(date +%s) - start )) s on $(nproc) cores"
exit "$status"
