"""Type stubs of flexcal's extension module. Units: SI in every array
(m for lengths and positions, rad for angles, joint coordinates in rad for
revolute and m for prismatic or screw joints); mm and deg only in files and
the JSON report."""

from os import PathLike
from typing import Literal, Optional, Sequence, Union, overload

import numpy as np
import numpy.typing as npt

ArrayLike = npt.ArrayLike
FloatArray = npt.NDArray[np.float64]
StrPath = Union[str, PathLike[str]]

__version__: str

class FlexcalError(Exception):
    """Base class of every error flexcal raises (the library's one-line message)."""

class InputError(FlexcalError):
    """An argument is invalid before any computation (shape, value, option)."""

class ShapeError(InputError):
    """An array has the wrong shape for the robot or the call."""

class NotFiniteError(InputError):
    """An input value is NaN or infinite (the message names the index)."""

class ArrayTypeError(InputError, TypeError):
    """An array argument holds strings or complex numbers where real numbers
    are expected; the argument's name is in the exception's note
    (``while processing 'q'``)."""

class UnknownRobotError(InputError):
    """No built-in robot has this name."""

class UnknownParameterError(InputError):
    """A parameter name (fix, defer) is not one of the model's unknowns."""

class FileError(FlexcalError):
    """A file could not be read or written, or its content is malformed."""

class KinematicsError(FlexcalError):
    """An invalid robot description or a failure of one of its algorithms."""

class UnreachableError(KinematicsError):
    """The inverse model reaches no configuration within the joint limits."""

class MeasurementError(FlexcalError):
    """A measurement set is invalid or does not match the robot."""

class CalibrationError(FlexcalError):
    """The identification failed (too few poses, degenerate registration, solver)."""

class RankDeficientError(CalibrationError):
    """The poses do not identify every free unknown (strict=True)."""

class FuzzyModelError(FlexcalError):
    """A fuzzy model could not be fitted or evaluated."""

class StructureError(FlexcalError):
    """A frame structure is invalid or could not be solved."""

class InternalError(FlexcalError):
    """A defect inside flexcal (a caught panic)."""

class Parameter:
    """One entry of the parameter vector xi."""

    name: str
    """Name: quantity + frame (`d3`, `alpha2`, `beta3`, `theta1`, ...)."""
    unit: Literal["m", "rad"]
    """SI unit of `nominal`."""
    nominal: float
    """Nominal value (m or rad)."""
    frame: str
    """The frame owning the parameter."""
    index: int
    """Position in xi."""

class Robot:
    """A validated, frozen robot model."""

    @staticmethod
    def builtin(name: str) -> Robot:
        """A built-in robot (`ur10`, `ir663`, `puma560`); UnknownRobotError otherwise."""
    @staticmethod
    def load(
        spec: str,
        tip: str | None = None,
        root: str | None = None,
        values: StrPath | None = None,
    ) -> Robot:
        """The command line's rule: a built-in name, else a description file by its extension.

        tip: a URDF's tip link, or the frame or link a TOML or built-in robot's TCP moves to;
        root: a URDF's root link (refused for other robots); values: a .par file's symbols (TOML, SI)."""
    @staticmethod
    def from_urdf_string(
        text: str, tip: str | None = None, root: str | None = None, source: str = "<string>"
    ) -> Robot:
        """A robot from URDF text; malformed text raises FileError with its line."""
    @staticmethod
    def from_urdf(path: StrPath, tip: str | None = None, root: str | None = None) -> Robot:
        """A robot from a URDF file: the root-to-tip path as a Khalil-Kleinfinger model (SI)."""
    @staticmethod
    def from_par(path: StrPath, values: StrPath | None = None) -> Robot:
        """A robot from a SYMORO .par file, its symbols' values from a TOML file (SI)."""
    @staticmethod
    def builtin_names() -> list[str]:
        """Names of the built-in robots."""
    @staticmethod
    def from_toml(path: StrPath) -> Robot:
        """A robot from a description file (TOML; mm and deg in fields named with their unit)."""
    @staticmethod
    def from_toml_string(text: str, source: str = "<string>") -> Robot:
        """A robot from description text (TOML, mm and deg)."""
    def to_toml(self) -> str:
        """The description (mm, deg) with the current nominal values."""
    @property
    def name(self) -> str: ...
    @property
    def dof(self) -> int:
        """Number of actuated coordinates (length of q)."""
    @property
    def joint_names(self) -> list[str]:
        """Names of the actuated coordinates in the order of q."""
    @property
    def frame_names(self) -> list[str]:
        """Every name fk(frame=...) takes: "0" (base), the frames, then the links (a URDF's link names)."""
    @property
    def joint_limits(self) -> FloatArray:
        """(dof, 2) [lower, upper] in rad or m."""
    @property
    def parameters(self) -> list[Parameter]:
        """The parameters of xi with SI units and nominal values."""
    @property
    def parameter_names(self) -> list[str]: ...
    @property
    def nominal(self) -> FloatArray:
        """The nominal parameter vector xi (n_params,), m and rad."""
    @overload
    def fk(
        self,
        q: ArrayLike,
        xi: Optional[ArrayLike] = None,
        output: Literal["matrix"] = "matrix",
        threads: Optional[int] = None,
        frame: Optional[str] = None,
        quaternion: Literal["xyzw", "wxyz"] = "xyzw",
    ) -> FloatArray:
        """TCP pose in the base frame: (4, 4) for q (dof,), (n, 4, 4) for q (n, dof); m.

        frame: the pose of that frame or link of the robot instead (any of frame_names; no tool transform)."""
    @overload
    def fk(
        self,
        q: ArrayLike,
        xi: Optional[ArrayLike] = None,
        output: Literal["pose"] = ...,
        threads: Optional[int] = None,
        frame: Optional[str] = None,
        quaternion: Literal["xyzw", "wxyz"] = "xyzw",
    ) -> tuple[FloatArray, FloatArray]:
        """(positions (n, 3) in m, quaternions (n, 4)): [x, y, z, w] by default (SciPy's
        order), [w, x, y, z] with quaternion="wxyz" (flexcal's files and reports)."""
    def jacobian(
        self, q: ArrayLike, xi: Optional[ArrayLike] = None, threads: Optional[int] = None
    ) -> FloatArray:
        """Joint Jacobian d[p_tcp; phi]/dq, (6, dof) or (n, 6, dof); rows [linear (m); angular (rad)] per unit of q, base frame."""
    def parameter_jacobian(
        self, q: ArrayLike, xi: Optional[ArrayLike] = None, threads: Optional[int] = None
    ) -> FloatArray:
        """Parameter Jacobian d[p_tcp; phi]/dxi (eqs. (49)-(52)), (6, n_params) or (n, 6, n_params)."""
    def ik(
        self,
        pose: ArrayLike,
        seed: ArrayLike,
        xi: Optional[ArrayLike] = None,
        target: Literal["pose", "position-and-tool-axis"] = "pose",
        max_iterations: int = 200,
        position_tolerance: float = 1e-11,
        orientation_tolerance: float = 1e-11,
    ) -> FloatArray:
        """q (dof,) reaching `pose` (4 x 4, m) nearest `seed`; UnreachableError if none within limits. Tolerances in m and rad."""

class MeasurementSet:
    """Measured poses: q (rad, m), target positions (m) in the measurement frame,
    optionally orientations (rotation vectors, rad) and standard deviations; with a
    targets description, each of several targets' position (NaN where not seen)."""

    @staticmethod
    def from_arrays(
        q: ArrayLike,
        positions: ArrayLike,
        orientations: Optional[ArrayLike] = None,
        std: Optional[ArrayLike] = None,
        orientation_std: Optional[ArrayLike] = None,
        pose_ids: Optional[Sequence[str]] = None,
        source: str = "arrays",
        targets: Optional[Sequence[tuple[str, str, ArrayLike]]] = None,
        fixed: Sequence[str] = (),
    ) -> MeasurementSet:
        """q (n, dof) rad/m, positions (n, 3) m, orientations (n, 3) rad, std (n, 3) m, orientation_std (n, 3) rad.
        With targets (name, frame, nominal offset (3,) m in that frame): positions and orientations
        (n, n_targets, 3), NaN for a target not seen (orientations all NaN for a target: positions only);
        fixed: targets whose offset is known; std and orientation_std refused."""
    @staticmethod
    def read_csv(
        path: StrPath, format: Literal["own", "ipa"] = "own", targets: Optional[StrPath] = None
    ) -> MeasurementSet:
        """flexcal's CSV (mm, deg columns) or the IPA laser-tracker export; with targets (a TOML
        description), flexcal's CSV with per-target columns."""
    def write_csv(self, path: StrPath) -> None:
        """Writes flexcal's CSV (mm, deg)."""
    @staticmethod
    def pooled(sets: Sequence[MeasurementSet]) -> MeasurementSet:
        """The sets as the stations of one calibration (one measurement frame each)."""
    @property
    def station_names(self) -> list[str]: ...
    @property
    def station_of(self) -> list[int]:
        """Index into station_names, per pose."""
    def subset(self, indices: Sequence[int]) -> MeasurementSet: ...
    def excluding(self, labels: Sequence[str]) -> MeasurementSet:
        """Without the poses of these labels (pose_id, `#k`, `line N`)."""
    @property
    def source(self) -> str: ...
    @property
    def format(self) -> Literal["own", "ipa", "targets"]: ...
    @property
    def target_names(self) -> list[str]:
        """The targets, in the order of positions with several (["tcp"] for one)."""
    @property
    def target_frames(self) -> list[str]: ...
    @property
    def n_observations(self) -> int:
        """(pose, target) observations."""
    @property
    def q(self) -> FloatArray:
        """(n, dof), rad or m."""
    @property
    def positions(self) -> FloatArray:
        """(n, 3), m; with targets (n, n_targets, 3), NaN where a target was not seen."""
    @property
    def orientations(self) -> Optional[FloatArray]:
        """(n, 3) rotation vectors, rad, or None; with targets (n, n_targets, 3), NaN where none."""
    @property
    def labels(self) -> list[str]: ...
    @property
    def dof(self) -> int: ...
    @property
    def has_orientation(self) -> bool: ...
    @property
    def nominal_target(self) -> Optional[FloatArray]:
        """(4, 4) target in the TCP frame (m) when the format knows it (IPA probe)."""
    def __len__(self) -> int: ...

class ErrorStatistics:
    """Mean, RMS and maximum pose errors (m, rad)."""

    n_poses: int
    position_mean: float
    position_rms: float
    position_max: float
    orientation_mean: Optional[float]
    orientation_rms: Optional[float]
    orientation_max: Optional[float]

class UnknownEstimate:
    """One unknown of an identification, SI units."""

    name: str
    unit: str
    """m, rad, rad/N.m (m/N for a linear joint), kg or kg.m."""
    nominal: float
    identified: float
    delta: float
    standard_error: Optional[float]
    spread_ratio: Optional[float]
    status: Literal[
        "identified",
        "fixed",
        "non-identifiable",
        "poorly-identifiable",
        "no-influence",
        "at-bound",
    ]

class ValidationResult:
    """Errors of a calibrated robot on another set."""

    @property
    def before(self) -> ErrorStatistics: ...
    @property
    def after(self) -> ErrorStatistics: ...
    @property
    def position_errors(self) -> FloatArray:
        """(n,) position error per pose after calibration, m."""
    @property
    def error_vectors(self) -> FloatArray:
        """(n, 3) measured - predicted position, measurement frame, m."""
    @property
    def measurement_frame(self) -> FloatArray:
        """(4, 4) x_meas_base, m."""
    @property
    def note(self) -> str: ...
    @property
    def data_checks(self) -> list[str]:
        """Repeated readings and suspect poses (error above 4x the RMS after calibration), in sentences."""
    @property
    def extrapolated_coordinates(self) -> list[tuple[str, float]]:
        """(coordinate, fraction of the poses outside the identification poses' range)."""
    @property
    def per_target_before(self) -> dict[str, ErrorStatistics]:
        """Per target before (`tcp` for one target per pose)."""
    @property
    def per_target_after(self) -> dict[str, ErrorStatistics]: ...
    @property
    def frame_refitted(self) -> bool: ...
    @property
    def observation_errors(self) -> tuple[list[tuple[str, str]], FloatArray]:
        """([(pose, target)], (n_observations, 3) measured minus predicted, m)."""

class AccuracyResult:
    """Predicted 95 % bounds of the position error (SI units)."""

    @property
    def bound_95(self) -> FloatArray:
        """(n,) 95 % bound on the position error at each pose, m."""
    @property
    def model_uncertainty(self) -> FloatArray:
        """(n,) the identification's own uncertainty, sqrt(tr Sigma_pred), m."""
    @property
    def actual_error(self) -> FloatArray:
        """(n,) measured position error after calibration, m (NaN without a measurement)."""
    @property
    def positions(self) -> FloatArray:
        """(n, 3) calibrated target position in the robot base frame, m."""
    @property
    def outside_training_range(self) -> list[list[str]]:
        """Per pose, the coordinates outside the identification poses' range."""
    @property
    def extrapolated_poses(self) -> int: ...
    @property
    def coverage(self) -> Optional[float]:
        """Share of measured poses within their bound (None without measurements)."""
    @property
    def residual_scatter(self) -> float:
        """Per-axis scatter of the training residuals, m."""
    @property
    def inflation(self) -> float:
        """Factor on every standard deviation from the split-half check (1: none)."""
    @property
    def targets(self) -> Optional[list[str]]:
        """The target of each entry with several targets (one entry per pose and target); None for one target."""
    def to_csv(self) -> str:
        """The CSV of `flexcal calibrate --accuracy-map` (mm)."""

class SelectionCandidate:
    """One candidate model scored by the model selection (SI units)."""

    groups: list[str]
    """Optional groups identified: offsets, tilts, compliances, joint law, cyclic."""
    label: str
    """`offsets + tilts`, or `base`."""
    cv_mean_error: Optional[float]
    """Cross-validated mean held-out position error, m."""
    cv_standard_error: Optional[float]
    """m."""
    cv_fold_errors: list[float]
    """Mean held-out position error of each fold, m."""
    bic: Optional[float]
    identified: float
    """Identified unknowns (full fit, or mean over the folds)."""
    failure: Optional[str]

class SelectionResult:
    """What `calibrate(..., select="cv"|"bic")` scored and chose."""

    @property
    def method(self) -> Literal["cv", "bic"]: ...
    @property
    def folds(self) -> int: ...
    @property
    def fold_sizes(self) -> list[int]: ...
    @property
    def candidates(self) -> list[SelectionCandidate]: ...
    @property
    def chosen(self) -> list[str]:
        """Optional groups of the chosen model (empty: the base model)."""
    @property
    def why(self) -> list[str]:
        """Why the chosen model won, one sentence per search step."""
    def lines(self) -> list[str]:
        """The report `flexcal calibrate --select` prints."""

class SplitCheckResult:
    """The split-half check (`split_check=True`), SI units."""

    @property
    def prediction_ratio(self) -> Optional[float]:
        """Halves' predicted positions against the covariance: ~1 when the standard errors hold."""
    @property
    def split_errors(self) -> dict[str, float]:
        """Name -> split error (SI units of the unknown)."""
    @property
    def standard_errors(self) -> dict[str, float]:
        """Name -> standard error of the full identification (SI units)."""
    @property
    def ratios(self) -> dict[str, float]:
        """Name -> split error / standard error (above 2.5: understated)."""
    @property
    def notes(self) -> list[str]: ...

class CrossCheckResult:
    """The cross-series check (`result.cross_check(other)`), SI units."""

    @property
    def values(self) -> dict[str, float]:
        """Name -> value identified on the identification set."""
    @property
    def other_values(self) -> dict[str, float]:
        """Name -> value identified on the other set (where it identifies it)."""
    @property
    def z(self) -> dict[str, float]:
        """Name -> (other - value) / sqrt(se^2 + se_other^2)."""
    @property
    def z_split(self) -> dict[str, float]:
        """Name -> z with each standard error raised to its split error (with the split check)."""
    @property
    def disagreeing(self) -> list[str]:
        """Unknowns whose judged |z| exceeds 3: values that do not transfer."""
    @property
    def other_poses(self) -> int: ...
    @property
    def notes(self) -> list[str]: ...

class CalibrationResult:
    """The result of `calibrate` for either kind of set: the JSON report's fields in SI units.
    Its checks take another set of the kind it was identified from."""

    def cross_check(self, other: MeasurementSet) -> CrossCheckResult:
        """Identify the same unknowns again on `other` and compare (z, z_split with the split check)."""

    @property
    def selection(self) -> Optional[SelectionResult]:
        """The model selection (select="cv" or "bic"), else None."""
    @property
    def split_check(self) -> Optional[SplitCheckResult]:
        """The split-half check (split_check=True); raises the predicted bounds."""

    @property
    def robot(self) -> Robot:
        """The calibrated robot (nominal values = identified values)."""
    @property
    def model(self) -> Literal["geometric", "elasto-geometric"]: ...
    @property
    def parameters(self) -> list[UnknownEstimate]: ...
    @property
    def identified(self) -> dict[str, float]:
        """Every unknown's value by name (SI)."""
    @property
    def standard_errors(self) -> dict[str, float]:
        """Standard error of each identified unknown (SI)."""
    @property
    def actuated_ranges(self) -> dict[str, tuple[float, float]]:
        """What the identification poses cover of each actuated coordinate
        (rad or m): for a revolute one the arc from lo to hi of the circle."""
    @property
    def torque_ranges(self) -> dict[str, tuple[float, float]]:
        """Span of each coordinate's gravity torque over the identification
        poses (N.m or N); empty for the geometric model."""
    @property
    def rank(self) -> int: ...
    @property
    def n_unknowns(self) -> int: ...
    @property
    def n_free(self) -> int: ...
    @property
    def non_identifiable(self) -> list[str]: ...
    @property
    def poorly_identifiable(self) -> list[str]: ...
    @property
    def combinations(self) -> list[str]:
        """`d4_id = d4 + 0.82 d9 - r8p`: what identified unknowns stand for (like (C.1))."""
    @property
    def combination_terms(self) -> dict[str, list[tuple[str, float]]]:
        """Identified name -> [(absorbed name, coefficient (SI))]."""
    @property
    def notes(self) -> list[str]: ...
    @property
    def data_checks(self) -> list[str]:
        """Repeated readings and suspect poses of the identification set, in sentences."""
    @property
    def condition_number(self) -> float: ...
    @property
    def singular_values(self) -> FloatArray: ...
    @property
    def termination(self) -> str: ...
    @property
    def converged(self) -> bool: ...
    @property
    def iterations(self) -> int: ...
    @property
    def refused_trials(self) -> int:
        """Trial points of the final solve the model could not evaluate, refused as steps."""
    @property
    def last_refusal(self) -> Optional[str]:
        """The model's error at the last refused trial point, or None."""
    @property
    def cost_history(self) -> FloatArray: ...
    @property
    def position_rms_history(self) -> FloatArray:
        """RMS position error (m) at each iterate."""
    @property
    def before(self) -> ErrorStatistics: ...
    @property
    def after(self) -> ErrorStatistics: ...
    @property
    def per_target_before(self) -> dict[str, ErrorStatistics]:
        """Errors per target before identification (one entry, "tcp", for one target per pose)."""
    @property
    def per_target_after(self) -> dict[str, ErrorStatistics]: ...
    @property
    def position_errors(self) -> FloatArray:
        """(n_observations,) identification-set position error norms after identification, m."""
    @property
    def observation_errors(self) -> tuple[list[tuple[str, str]], FloatArray]:
        """([(pose, target)], (n_observations, 3) measured minus predicted, m), identification set."""
    @property
    def target_offsets(self) -> dict[str, FloatArray]:
        """(3,) per target, m, in its frame."""
    @property
    def extrapolation_growth(self) -> Optional[dict[str, float]]:
        """extrapolation=True: the error growth outside each joint's training range (m/rad or m/m)."""
    @property
    def extrapolation_notes(self) -> list[str]: ...
    @property
    def measurement_frame(self) -> FloatArray:
        """(4, 4) identified x_meas_base, m (of the first station)."""
    @property
    def station_frames(self) -> list[tuple[str, FloatArray]]:
        """(station name, (4, 4) x_meas_base in m) of every station."""
    @property
    def station_errors(self) -> list[tuple[str, ErrorStatistics]]:
        """(station name, errors of its poses after identification)."""
    @property
    def station_hold_out(
        self,
    ) -> list[tuple[str, Optional[list[str]], ErrorStatistics, ErrorStatistics]]:
        """(station, chosen groups or None, before, after) per station held out; [] unless asked."""
    @property
    def target(self) -> FloatArray:
        """(4, 4) identified x_tcp_target, m."""
    def validate(
        self,
        other: MeasurementSet,
        refit_target: bool = False,
        refit_frame: bool = True,
    ) -> ValidationResult:
        """Errors on another set of the same kind, overall and per target."""
    def predicted_accuracy(self, q: ArrayLike) -> AccuracyResult:
        """95 % bounds at the configurations q ((dof,) or (n, dof), rad or m), one entry per configuration and target."""
    def accuracy_coverage(self, other: MeasurementSet) -> AccuracyResult:
        """95 % bounds at the poses of `other` with their measured errors."""
    def to_json(
        self, validation: Optional[ValidationResult] = None
    ) -> str:
        """The JSON report of `flexcal calibrate --report` (mm, deg), with several targets that of `--targets`."""

def calibrate(
    robot: Robot,
    data: MeasurementSet,
    model: Literal["geometric", "elasto-geometric"] = "geometric",
    fix: Sequence[str] = (),
    defer: Optional[Sequence[str]] = None,
    method: Literal["lm", "gn"] = "lm",
    weights: Optional[Literal["file", "uniform"]] = None,
    use_orientation: Optional[bool] = None,
    fixed_frame: bool = False,
    fixed_target: bool = False,
    target: Optional[ArrayLike] = None,
    max_se_length: Optional[float] = None,
    max_se_angle: Optional[float] = None,
    strict: bool = False,
    masses: Optional[StrPath] = None,
    max_iterations: Optional[int] = None,
    select: Literal["cv", "bic", "none"] | None = None,
    hold_out_stations: bool = False,
    split_check: bool = False,
    max_se_compliance: Optional[float] = None,
    min_compliance_z: Optional[float] = None,
    noise: Optional[float] = None,
    select_on: Optional[Literal["interpolation", "extrapolation", "auto"]] = None,
    region: Optional[Sequence[Sequence[float]]] = None,
    extrapolation: bool = False,
    deflection: Optional[Literal["one-step", "equilibrium", "auto"]] = None,
    every_extrapolation_score: bool = False,
) -> CalibrationResult:
    """Identifies the robot (eqs. (7)-(12), (49)-(53)) from one target per pose or several.
    target (3,) in m (one target per pose only, as fixed_target); max_se_length in m; max_se_angle in rad.

    select: model selection as `flexcal calibrate --select` (report in `.selection`);
    default as on the command line: "cv" from 100 poses, else "none".
    hold_out_stations: with several stations, each held out in turn (`.station_hold_out`).
    split_check: identify again on halves of the poses (`.split_check`); raises the predicted bounds.
    max_se_compliance: absolute standard-error limit of the compliances (rad/N.m, default 1e-3).
    min_compliance_z: a compliance is kept when its value is at least this many standard errors (default 2).
    noise: the instrument's noise per position axis (m); default from the file or the fit.
    select_on / region: which cross-validated score chooses, and where the robot is to be used (rad or m).
    extrapolation: the error growth outside the training ranges, added to every predicted bound.
    deflection: the elastic deflection: one linear step, the static equilibrium, or auto (default: the mass table's, else one step).
    every_extrapolation_score: every candidate scored on the extrapolating folds, also when the
    ordinary ones choose (default: the models the search moved through)."""

class Campaign:
    """A calibration campaign: everything one `flexcal calibrate` run takes
    (robot, measurement files per station, model, checks, validation set,
    outputs), read from a campaign file (docs/file-formats.md) or from the
    `config` section of a JSON report."""

    @staticmethod
    def read(path: StrPath) -> Campaign:
        """Reads a campaign file (TOML), paths relative to its folder; raises
        FileError naming the file and the key (unknown key, wrong type, an
        input file that does not exist)."""
    @staticmethod
    def from_report(path: StrPath) -> Campaign:
        """Reads the campaign a JSON report carries (`config`), paths relative to the report."""
    @property
    def data(self) -> list[str]:
        """The measurement files, one per station, as the program opens them."""
    def to_toml(self, folder: Optional[StrPath] = None) -> str:
        """The campaign file's text, paths relative to `folder` (default: the working directory)."""
    def write(self, path: StrPath) -> None:
        """Writes the campaign file (atomically), paths relative to its folder."""
    def run(self, write_outputs: bool = True) -> CalibrationResult:
        """Runs the campaign as `flexcal calibrate --config` does and returns what
        `calibrate` returns; with `write_outputs` the files of its [outputs]
        table are written too (one target per pose or, with [data] targets, several)."""

class FuzzyModel:
    """A zero-order Takagi-Sugeno model (eqs. (33)-(37))."""

    @staticmethod
    def fit(
        x: ArrayLike,
        y: ArrayLike,
        input_names: Optional[Sequence[str]] = None,
        output_name: str = "y",
        test_fraction: float = 0.25,
        seed: int = 0,
        max_rules: Optional[int] = None,
        ridge: Optional[float] = None,
    ) -> FuzzyModel:
        """Fits on x (n, k), y (n,) (any units, kept by the model)."""
    def predict(self, x: ArrayLike) -> FloatArray:
        """(n,) for x (n, k), or a 0-d array for x (k,)."""
    def to_fis(self, name: str = "flexcal") -> str: ...
    @property
    def input_names(self) -> list[str]: ...
    @property
    def n_rules(self) -> int: ...
    @property
    def conclusions(self) -> FloatArray: ...
    @property
    def training_rmse(self) -> float: ...
    @property
    def test_rmse(self) -> float: ...

class Structure:
    """A frame finite-element structure with its load cases."""

    @staticmethod
    def from_file(path: StrPath) -> Structure: ...
    @property
    def node_names(self) -> list[str]: ...
    @property
    def load_cases(self) -> list[str]: ...
    def solve(self) -> dict[str, FloatArray]:
        """Case name -> (n_nodes, 6) [ux, uy, uz (m), rx, ry, rz (rad)]."""
    def condense(self, node: str) -> dict[str, object]:
        """{"k_eq": (6, 6), "c_eq": (6, 6), "f_eq": {case: (6,)}} in N, m, rad."""

class CommandedPath:
    """The commanded path of `compensate_path`: one point per target (SI)."""

    @property
    def q(self) -> FloatArray:
        """(n, dof) commanded actuated coordinates, rad or m."""
    @property
    def poses(self) -> FloatArray:
        """(n, 4, 4) commanded TCP poses in the base frame, m."""
    @property
    def predicted_error(self) -> FloatArray:
        """(n, 6) predicted error without compensation, [m; rad], base frame."""
    @property
    def residual(self) -> FloatArray:
        """(n, 6) remaining error after compensation, [m; rad]."""
    @property
    def iterations(self) -> list[int]: ...
    @property
    def max_predicted_deviation(self) -> float:
        """m."""
    @property
    def max_residual(self) -> float:
        """m."""
    @property
    def models(self) -> tuple[str, str]:
        """(elastic model, process model) in words."""
    def to_csv(self) -> str:
        """As `flexcal compensate` writes it (mm)."""
    def to_krl(self) -> str: ...
    def __len__(self) -> int: ...

def compensate_path(
    robot: Robot,
    points: ArrayLike,
    x_base_part: ArrayLike,
    elastic: str,
    process: str,
    payload: Optional[ArrayLike] = None,
    start_joints: Optional[ArrayLike] = None,
    xi: Optional[ArrayLike] = None,
) -> CommandedPath:
    """Compensates a path: points (n, 3) in the part frame (m), x_base_part (4, 4) m,
    elastic `fe:NAME|FILE` or `fuzzy:FILE`, process `cantilever:...` (the CLI's text, mm),
    payload (6,) [N; N.m] in the base frame (eqs. (39)-(41))."""

def plan(
    robot: Robot,
    noise_mm: Sequence[float],
    candidates: Optional[ArrayLike] = None,
    region: Optional[ArrayLike] = None,
    joint_box: Optional[ArrayLike] = None,
    candidate_count: int = 200,
    region_count: int = 200,
    seed: int = 1,
    poses: Optional[int] = None,
    max_poses: Optional[int] = None,
    model: Optional[Literal["geometric", "elasto-geometric"]] = None,
    masses: Optional[str] = None,
    fix: Sequence[str] = (),
    fixed_frame: bool = False,
    fixed_target: bool = False,
    knee_tolerance: float = 0.05,
    orientation_noise_deg: Optional[Sequence[float]] = None,
    reach_box_mm: Optional[Sequence[Sequence[float]]] = None,
    sight_from_mm: Optional[Sequence[float]] = None,
    max_incidence_deg: Optional[float] = None,
    targets: Optional[str] = None,
    frame_uncertainty: Literal["registered", "as-identified"] = "registered",
    prior: Optional[str] = None,
) -> dict:
    """Plans a campaign before measuring: noise per axis in mm (orientation_noise_deg: deg per
    axis, full poses), candidates (n, dof) and
    region (m, dof) in rad or m (else drawn in joint_box (dof, 2), default the joint
    limits); returns the plan (configurations, selected, curve, knee, prediction).
    frame_uncertainty: "as-identified" counts the measurement frame's uncertainty in the
    bounds (the region measured from the campaign's instrument placement).
    prior: an earlier calibration's report (calibrate --report --split-check [--extrapolation]):
    its model (model's default), noise floor, inflation and growth, as plan --prior."""
