#!/usr/bin/env python3
"""Paired comparison of flexcal with the IPA dataset's own baselines, pose by pose.

Runs the dataset's `baseline.py` in place (it needs NumPy, SciPy and pandas)
on TRAIN -> VALIDATE, and compares its per-pose validation errors with the
per-pose errors flexcal wrote for the same pair (`flexcal calibrate ...
--validate VALIDATE --residuals FLEXCAL.csv`). Prints both means, the mean
of the paired difference (flexcal - baseline) with its standard error from
batch means over contiguous blocks of poses (errors of neighbouring poses are
correlated, so the naive standard error understates it), the correlation of
the two error vectors and both maxima.

usage: scripts/ipa-paired-baseline.py TRAIN.csv VALIDATE.csv dh|dh+g FLEXCAL.csv [DATASET_DIR]
"""

import csv
import runpy
import sys
from pathlib import Path

import numpy as np


def main():
    if len(sys.argv) not in (5, 6):
        sys.exit(__doc__.strip().splitlines()[-1])
    train, validate, model, ours_csv = sys.argv[1:5]
    dataset = Path(sys.argv[5]) if len(sys.argv) == 6 else Path(__file__).parents[2] / "shared/datasets/ipa-ur10"
    baseline = dataset / "baseline.py"
    if not baseline.exists():
        sys.exit(f"{baseline}: not found (pass the dataset directory as the fifth argument)")
    with open(ours_csv, newline="") as f:
        ours = np.array([float(row["position_error_mm"]) for row in csv.DictReader(f)])
    argv = sys.argv
    sys.argv = ["baseline.py", train, validate, model]
    try:
        theirs = np.asarray(runpy.run_path(str(baseline), run_name="__main__")["ev"], dtype=float)
    finally:
        sys.argv = argv
    if len(theirs) != len(ours):
        sys.exit(f"{ours_csv}: {len(ours)} poses, the baseline validated {len(theirs)}: not the same poses")
    d = ours - theirs
    blocks = [b.mean() for b in np.array_split(d, 15)]
    print(f"poses {len(d)}; mean flexcal {ours.mean():.4f} mm, {model} {theirs.mean():.4f} mm")
    print(
        f"paired difference flexcal - {model}: {d.mean():+.4f} mm, standard error {np.std(blocks, ddof=1) / np.sqrt(len(blocks)):.4f} mm "
        f"(15 blocks), naive {d.std(ddof=1) / np.sqrt(len(d)):.4f} mm; flexcal lower on {100 * np.mean(d < 0):.1f} % of the poses"
    )
    print(f"correlation of the per-pose errors {np.corrcoef(ours, theirs)[0, 1]:.4f}; max flexcal {ours.max():.4f} mm, {model} {theirs.max():.4f} mm")


if __name__ == "__main__":
    main()
