"""flexcal: elasto-geometric calibration of industrial robots, from Python.

Robots (forward and inverse models, joint and parameter Jacobians),
measurement sets, identification with its identifiability report, fuzzy
models and frame finite-element structures, on NumPy arrays. Every array is
in SI units (m, rad); mm and degrees appear only in files and in the JSON
report, in fields named with their unit.

    >>> import numpy as np, flexcal
    >>> robot = flexcal.Robot.builtin("ur10")
    >>> robot.fk(np.zeros((10, robot.dof))).shape
    (10, 4, 4)

Errors are raised as subclasses of ``flexcal.FlexcalError`` carrying the
library's one-line message. See docs/python.md in the repository.
"""

from ._flexcal import (
    AccuracyResult,
    ArrayTypeError,
    CalibrationError,
    CalibrationResult,
    Campaign,
    CommandedPath,
    CrossCheckResult,
    ErrorStatistics,
    FileError,
    FlexcalError,
    FuzzyModel,
    FuzzyModelError,
    InputError,
    InternalError,
    KinematicsError,
    MeasurementError,
    MeasurementSet,
    NotFiniteError,
    Parameter,
    RankDeficientError,
    Robot,
    SelectionCandidate,
    SelectionResult,
    ShapeError,
    SplitCheckResult,
    Structure,
    StructureError,
    TargetCalibrationResult,
    TargetMeasurementSet,
    TargetValidationResult,
    UnknownEstimate,
    UnknownParameterError,
    UnknownRobotError,
    UnreachableError,
    ValidationResult,
    __version__,
    calibrate as _calibrate_one_target,
    calibrate_targets as _calibrate_targets,
    compensate_path,
    plan,
)

__all__ = [
    "AccuracyResult",
    "ArrayTypeError",
    "CalibrationError",
    "CalibrationResult",
    "Campaign",
    "CommandedPath",
    "CrossCheckResult",
    "ErrorStatistics",
    "FileError",
    "FlexcalError",
    "FuzzyModel",
    "FuzzyModelError",
    "InputError",
    "InternalError",
    "KinematicsError",
    "MeasurementError",
    "MeasurementSet",
    "NotFiniteError",
    "Parameter",
    "RankDeficientError",
    "Robot",
    "SelectionCandidate",
    "SelectionResult",
    "ShapeError",
    "SplitCheckResult",
    "Structure",
    "StructureError",
    "TargetCalibrationResult",
    "TargetMeasurementSet",
    "TargetValidationResult",
    "UnknownEstimate",
    "UnknownParameterError",
    "UnknownRobotError",
    "UnreachableError",
    "ValidationResult",
    "__version__",
    "calibrate",
    "calibrate_targets",
    "compensate_path",
    "plan",
]


def calibrate(robot, data, *args, **kwargs):
    """Identifies the robot from a measurement set: a ``MeasurementSet``
    (one target on the TCP) gives a ``CalibrationResult``, a
    ``TargetMeasurementSet`` (several targets per pose, positions and,
    where given, orientations) a ``TargetCalibrationResult``. Both run the
    library's one identification; the keyword arguments are those of each
    (docs/python.md)."""
    if isinstance(data, TargetMeasurementSet):
        return _calibrate_targets(robot, data, *args, **kwargs)
    return _calibrate_one_target(robot, data, *args, **kwargs)


def calibrate_targets(robot, data, *args, **kwargs):
    """Deprecated alias of ``calibrate`` for a ``TargetMeasurementSet``,
    kept for one release: ``flexcal.calibrate`` takes either kind of set."""
    import warnings

    warnings.warn(
        "flexcal.calibrate_targets is deprecated and will be removed in the next release: "
        "flexcal.calibrate takes a TargetMeasurementSet too",
        DeprecationWarning,
        stacklevel=2,
    )
    return _calibrate_targets(robot, data, *args, **kwargs)
