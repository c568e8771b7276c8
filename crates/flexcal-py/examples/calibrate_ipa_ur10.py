"""Calibrating the UR10 on the IPA laser-tracker data, notebook style.

Identify on series B (joint configurations), validate on series C (random
poses), print the identifiability report and plot the position error of
every validation pose before and after calibration.

    python crates/flexcal-py/examples/calibrate_ipa_ur10.py [OUTPUT.png]

The data is read from ../shared/datasets/ipa-ur10 beside the repository.
The plot uses matplotlib's Agg backend (no display needed) and is skipped,
with a message, when matplotlib is not installed.
"""

import pathlib
import sys

import numpy as np

import flexcal

# %% The data
repository = pathlib.Path(__file__).resolve().parents[3]
ipa = repository.parent / "shared" / "datasets" / "ipa-ur10"
series_b = ipa / "Series_B" / "measurements_joint_configurations.csv"
series_c = ipa / "Series_C" / "measurements_random_poses.csv"
if not (series_b.exists() and series_c.exists()):
    print(f"IPA UR10 data absent ({ipa}): nothing to do")
    sys.exit(0)

robot = flexcal.Robot.builtin("ur10")
train = flexcal.MeasurementSet.read_csv(series_b, format="ipa")
test = flexcal.MeasurementSet.read_csv(series_c, format="ipa")
print(f"{robot}: {len(train)} identification poses, {len(test)} validation poses")

# %% Identification (positions only, uniform weights: the IPA protocol)
result = flexcal.calibrate(robot, train)
print(f"rank {result.rank} of {result.n_unknowns}, {result.termination}")
print("not identifiable:", ", ".join(result.non_identifiable) or "none")
for note in result.notes:
    print("note:", note)
print(f"{'parameter':>12} {'delta':>10}  standard error")
for u in result.parameters:
    if u.status == "identified" and u.unit in ("m", "rad"):
        scale, unit = (1e3, "mm") if u.unit == "m" else (np.degrees(1.0), "deg")
        print(f"{u.name:>12} {u.delta * scale:>+10.4f}  {u.standard_error * scale:.4f} {unit}")

# %% Validation on series C (only the tracker -> base transform re-fitted)
validation = result.validate(test)
for label, s in [("before", validation.before), ("after", validation.after)]:
    print(
        f"validation {label}: mean {s.position_mean * 1e3:.3f} mm, "
        f"RMS {s.position_rms * 1e3:.3f} mm, max {s.position_max * 1e3:.3f} mm"
    )

# %% The error of every validation pose
try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    print("matplotlib is not installed: no plot (pip install matplotlib)")
    sys.exit(0)

# Errors of the nominal robot: the same validation with nothing identified.
nominal = flexcal.calibrate(robot, train, fix=robot.parameter_names).validate(test)
output = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "ipa_ur10_errors.png")
figure, axes = plt.subplots(figsize=(9, 4))
poses = np.arange(len(test))
axes.plot(poses, nominal.position_errors * 1e3, ".", label="nominal robot", alpha=0.6)
axes.plot(poses, validation.position_errors * 1e3, ".", label="calibrated on B")
axes.set_xlabel("validation pose (series C)")
axes.set_ylabel("position error (mm)")
axes.set_title("UR10, IPA laser-tracker data: identified on B, validated on C")
axes.legend()
figure.tight_layout()
figure.savefig(output, dpi=120)
print(f"plot written to {output}")
