"""UR10 identification from the IPA series C from Python, to compare with
the Rust benchmark `cargo bench -p flexcal-calib --bench calib --
ur10_series_c_2773_poses`: the same identification with the same options
(positions only, uniform weights: the IPA defaults) from Rust.

    python crates/flexcal-py/benches/calib_ipa.py

Prints the median and minimum wall time of the identification and the
machine's load (uptime) before and after.
"""

import pathlib
import statistics
import subprocess
import sys
import time

import flexcal

IPA = pathlib.Path(__file__).resolve().parents[3].parent / "shared/datasets/ipa-ur10"
SERIES_C = IPA / "Series_C" / "measurements_random_poses.csv"
REPEAT = 20


def uptime():
    return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()


if not SERIES_C.exists():
    print(f"IPA data absent ({SERIES_C}): nothing to measure")
    sys.exit(0)

robot = flexcal.Robot.builtin("ur10")
data = flexcal.MeasurementSet.read_csv(SERIES_C, format="ipa")
print(f"load before: {uptime()}")
times = []
for _ in range(REPEAT):
    start = time.perf_counter()
    result = flexcal.calibrate(robot, data)
    times.append(time.perf_counter() - start)
print(f"load after: {uptime()}")
print(
    f"identification of the UR10 from series C ({len(data)} poses, rank {result.rank}): "
    f"median {statistics.median(times) * 1e3:.1f} ms, min {min(times) * 1e3:.1f} ms over {REPEAT}"
)
