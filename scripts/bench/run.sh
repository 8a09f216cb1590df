#!/usr/bin/env bash
# bskin pipeline benchmark: bskin next to its peers (pydicom + scikit-image contours; the VTK
# flying-edges surface pipeline), measured alternately in the same run.
#
# What it does: makes a Python venv with the peers pinned below (pydicom, numpy, scikit-image,
# vtk, pylibjpeg + pylibjpeg-libjpeg for the JPEG / JPEG-LS copies), builds bskin and the
# decode-only baseline (examples/decode_only.rs) in release, generates the synthetic series
# with `bskin phantom`, then runs scripts/bench/bench.py (see its header for the cases).
#
# Needs: cargo (and cmake >= 3.20 for CharLS: `python3 -m pip install 'cmake>=3.20,<4'`),
# python3 >= 3.10 with venv, GNU time at /usr/bin/time (Debian: apt-get install -y time),
# network access to PyPI the first time. Real-data cases use ../shared/data beside the checkout
# when present (skipped otherwise).
#
# Prints: markdown tables (per case and tool: runs, wall min/median s, CPU s, peak RSS MB,
# slices/s), the ratios bskin/peer, bskin's per-stage busy times (report.json) and the
# memory-scaling figures; progress goes to stderr. Everything measured goes to
# $BENCH_WORK/results.json.
#
# Usage: scripts/bench/run.sh [--quick] [--reps N] [--long S] [--no-real] [--no-scaling]
#                             [--cases synthetic,skull,skull-jpegls,skull-jpegll]
# Env:   BENCH_WORK (default /tmp/bskin-bench: venv, generated series, outputs),
#        CARGO_TARGET_DIR (default target/).
# --quick: 256x256x100 synthetic series only (and the scaling check on 100 vs 500 slices),
# 2 runs per tool (about 2 minutes).
# Full run: 3 runs per tool on the synthetic series and the skull, 2 on its transcoded copies;
# the 2-process contours peer on the synthetic series and the skull only.
# A full run takes ~25 min on 2 cores (most of it: bskin run on the skull and its copies).
set -euo pipefail
cd "$(dirname "$0")/../.."
WORK="${BENCH_WORK:-/tmp/bskin-bench}"
TARGET="${CARGO_TARGET_DIR:-target}"
mkdir -p "$WORK"

[ -x /usr/bin/time ] || { echo "run.sh: /usr/bin/time missing (apt-get install -y time)" >&2; exit 2; }

VENV="$WORK/venv"
if [ ! -x "$VENV/bin/python" ]; then
    python3 -m venv "$VENV"
fi
PEERS="pydicom==3.0.2 numpy==2.4.6 scikit-image==0.26.0 vtk==9.7.2 pylibjpeg==2.1.0 pylibjpeg-libjpeg==2.5.0"
if ! "$VENV/bin/python" -c 'import pydicom, numpy, skimage, vtk, pylibjpeg, libjpeg' 2>/dev/null; then
    echo "run.sh: installing the Python peers: $PEERS" >&2
    "$VENV/bin/pip" install -q $PEERS
fi

echo "run.sh: building bskin (release) in $TARGET" >&2
cargo build --release --quiet --bin bskin --example decode_only

exec "$VENV/bin/python" scripts/bench/bench.py \
    --bskin "$TARGET/release/bskin" --decode "$TARGET/release/examples/decode_only" \
    --python "$VENV/bin/python" --work "$WORK" "$@"
