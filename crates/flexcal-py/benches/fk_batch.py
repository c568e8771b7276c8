"""Batched forward model of 100 000 UR10 configurations from Python:
flexcal's batched call against pinocchio's Python bindings in a loop and,
when installed, the Robotics Toolbox (on fewer configurations: it is slow).

    python crates/flexcal-py/benches/fk_batch.py [N]

Needs the flexcal package (pip install ./crates/flexcal-py); pinocchio
(`pip install pin`) and roboticstoolbox-python are optional. pinocchio
loads the UR10 URDF from ../shared/robots/urdf beside the repository.
Prints the time per configuration of each and the machine's load (/proc/loadavg).
"""

import pathlib
import subprocess
import sys
import time

import numpy as np

import flexcal

N = int(sys.argv[1]) if len(sys.argv) > 1 else 100_000
REPEAT = 5
URDF = pathlib.Path(__file__).resolve().parents[3].parent / "shared/robots/urdf/ur10_robot.urdf"


def best_of(repeat, function):
    """Minimum wall time of `repeat` runs (s): the least disturbed by other load."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times)


def uptime():
    """The machine's load average (1, 5, 15 min): /proc/loadavg, else `uptime`."""
    try:
        return "loadavg " + pathlib.Path("/proc/loadavg").read_text().strip()
    except OSError:
        pass
    try:
        return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    except OSError:
        return "load unavailable"


rng = np.random.default_rng(0)
q = rng.uniform(-np.pi, np.pi, size=(N, 6))
robot = flexcal.Robot.builtin("ur10")
results = {}

print(f"load before: {uptime()}")
for threads in [1, None]:
    label = "flexcal fk, 1 thread" if threads == 1 else "flexcal fk, all cores"
    t = best_of(REPEAT, lambda: robot.fk(q, threads=threads))
    results[label] = t / N
    t = best_of(REPEAT, lambda: robot.fk(q, output="pose", threads=threads))
    results[label.replace("fk", "fk (positions, quaternions)")] = t / N

try:
    import pinocchio

    model = pinocchio.buildModelFromUrdf(str(URDF))
    data = model.createData()
    frame = model.getFrameId("tool0") if model.existFrame("tool0") else model.nframes - 1
    # pinocchio's configuration vector for the UR10's six revolute joints is q itself.

    def pinocchio_loop():
        for qk in q:
            pinocchio.forwardKinematics(model, data, qk)
            pinocchio.updateFramePlacement(model, data, frame)

    def pinocchio_fk_only():
        for qk in q:
            pinocchio.forwardKinematics(model, data, qk)

    results["pinocchio loop (forwardKinematics + frame)"] = best_of(3, pinocchio_loop) / N
    results["pinocchio loop (forwardKinematics only)"] = best_of(3, pinocchio_fk_only) / N
    # Same robot: flexcal's TCP against pinocchio's tool0 up to the base
    # frames' convention (distances between poses agree).
    a = robot.fk(q[:50])[:, :3, 3]
    b = []
    for qk in q[:50]:
        pinocchio.forwardKinematics(model, data, qk)
        pinocchio.updateFramePlacement(model, data, frame)
        b.append(data.oMf[frame].translation.copy())
    b = np.array(b)
    da = np.linalg.norm(a[1:] - a[:-1], axis=1)
    db = np.linalg.norm(b[1:] - b[:-1], axis=1)
    print(f"pinocchio vs flexcal, TCP distances between poses agree to {np.abs(da - db).max():.1e} m")
except ImportError:
    print("pinocchio not installed (pip install pin): skipped")

try:
    import roboticstoolbox as rtb

    # The DH model: rtb.models.UR10() (URDF) fetches its meshes from GitHub at load time.
    ur10 = rtb.models.DH.UR10()
    n_rtb = min(N, 2_000)

    def rtb_loop():
        for qk in q[:n_rtb]:
            ur10.fkine(qk)

    results[f"roboticstoolbox fkine loop ({n_rtb} configurations)"] = best_of(3, rtb_loop) / n_rtb
except Exception as error:  # noqa: BLE001 - any import failure means: not available
    print(f"roboticstoolbox not available ({type(error).__name__}: {error}): skipped")

print(f"load after: {uptime()}")
print(f"{N} UR10 configurations, best of {REPEAT}:")
for label, seconds in results.items():
    print(f"  {label:<50} {seconds * 1e9:10.1f} ns per configuration")
reference = results.get("pinocchio loop (forwardKinematics + frame)")
if reference:
    for label, seconds in results.items():
        if label.startswith("flexcal"):
            print(f"  {label:<50} {reference / seconds:10.1f} x faster than pinocchio's loop")
