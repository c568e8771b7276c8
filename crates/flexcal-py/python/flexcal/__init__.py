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
    UnknownEstimate,
    UnknownParameterError,
    UnknownRobotError,
    UnreachableError,
    ValidationResult,
    __version__,
    calibrate,
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


def calibrate_targets(robot, data, *args, **kwargs):
    """Deprecated alias of ``calibrate``, kept for one release:
    ``flexcal.calibrate`` takes a ``MeasurementSet`` of several targets as
    it takes one of one target."""
    import warnings

    warnings.warn(
        "flexcal.calibrate_targets is deprecated and will be removed in the next release: "
        "flexcal.calibrate takes a MeasurementSet of several targets too",
        DeprecationWarning,
        stacklevel=2,
    )
    return calibrate(robot, data, *args, **kwargs)


class _TargetMeasurementSet:
    """Deprecated: the constructors of a ``MeasurementSet`` of several
    targets under their old names, kept for one release.
    ``isinstance(x, flexcal.TargetMeasurementSet)`` is not supported: test
    ``x.format == "targets"``."""

    @staticmethod
    def from_arrays(targets, q, positions, fixed=(), pose_ids=None, source="arrays", orientations=None):
        """``MeasurementSet.from_arrays(q, positions, ..., targets=targets)``."""
        return MeasurementSet.from_arrays(
            q,
            positions,
            orientations=orientations,
            pose_ids=pose_ids,
            source=source,
            targets=targets,
            fixed=list(fixed),
        )

    @staticmethod
    def read_csv(path, targets):
        """``MeasurementSet.read_csv(path, targets=targets)``."""
        return MeasurementSet.read_csv(path, targets=targets)

    @staticmethod
    def pooled(sets):
        """``MeasurementSet.pooled(sets)``."""
        return MeasurementSet.pooled(sets)


_DEPRECATED_NAMES = {
    "TargetMeasurementSet": (
        _TargetMeasurementSet,
        "flexcal.TargetMeasurementSet is deprecated and will be removed in the next release: "
        "MeasurementSet.from_arrays and MeasurementSet.read_csv take targets=",
    ),
    "TargetCalibrationResult": (
        CalibrationResult,
        "flexcal.TargetCalibrationResult is deprecated and will be removed in the next release: "
        "flexcal.calibrate returns a CalibrationResult for either kind of set",
    ),
    "TargetValidationResult": (
        ValidationResult,
        "flexcal.TargetValidationResult is deprecated and will be removed in the next release: "
        "CalibrationResult.validate returns a ValidationResult for either kind of set",
    ),
}


def __getattr__(name):
    """The deprecated names, kept for one release; each access warns."""
    if name in _DEPRECATED_NAMES:
        import warnings

        value, message = _DEPRECATED_NAMES[name]
        warnings.warn(message, DeprecationWarning, stacklevel=2)
        return value
    raise AttributeError(f"module 'flexcal' has no attribute {name!r}")
