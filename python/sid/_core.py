"""Robots, runs and identification: the Python face of sid_identify --robot."""

from __future__ import annotations

import json
import os
import tempfile
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Iterable, Mapping, Optional, Sequence, Union

import numpy as np

from . import _sid

if TYPE_CHECKING:
    from .payload import Payload

PathLike = Union[str, "os.PathLike[str]"]


class Robot:
    """A serial chain from its URDF or DH table, as ``sid_identify --robot`` reads it."""

    def __init__(self, handle: Any) -> None:
        self._handle = handle

    @classmethod
    def from_urdf(
        cls,
        path: PathLike,
        base: Optional[str] = None,
        tip: Optional[str] = None,
        transmission: Optional[PathLike] = None,
        hold: Optional[Mapping[str, float]] = None,
    ) -> "Robot":
        """The chain of a URDF from ``base`` to ``tip`` (default: the root and its one leaf).

        transmission: a YAML (or URDF) transmission file; the runs are then motor-side.
        hold: joints off the chain held at the given values [rad or m], e.g. {"finger": 0.0}.
        """
        held = ",".join(f"{name}={float(value)!r}" for name, value in (hold or {}).items())
        return cls(
            _sid.load_robot(
                os.fspath(path),
                base or "",
                tip or "",
                os.fspath(transmission) if transmission is not None else "",
                held,
            )
        )

    @classmethod
    def from_dh(cls, path: PathLike, transmission: Optional[PathLike] = None) -> "Robot":
        """A chain from a DH table (the format ``sid_identify --robot`` reads)."""
        robot = cls(
            _sid.load_robot(
                os.fspath(path),
                "",
                "",
                os.fspath(transmission) if transmission is not None else "",
                "",
            )
        )
        if robot._handle.urdf:
            raise ValueError(f"{os.fspath(path)} is a URDF, not a DH table: use Robot.from_urdf")
        return robot

    @property
    def joint_names(self) -> list[str]:
        """The chain's joints from base to tip: the runs' columns, in this order."""
        return list(self._handle.joint_names)

    @property
    def joints(self) -> int:
        return len(self._handle.joint_names)

    @property
    def motor_side(self) -> bool:
        """Whether runs are motor-side (a transmission was given)."""
        return bool(self._handle.motor_side)

    def joint_side(self, run: "Run") -> "Run":
        """The run at the joints: a motor-side run through the transmission (angles, and
        torques or currents as the transmission scales them); else the run itself."""
        t, q, tau = _sid.joint_side(self._handle, _as_run(run, "run")._data())
        return Run(t, q, tau, name=run.name)

    def __repr__(self) -> str:
        return f"sid.Robot({self._handle.path!r}, joints={self.joint_names})"


def _float_array(name: str, value: Any, ndim: int) -> np.ndarray:
    array = np.asarray(value, dtype=np.float64)
    if array.ndim == 1 and ndim == 2:
        array = array.reshape(-1, 1)
    if array.ndim != ndim:
        raise ValueError(f"{name} must be a {ndim}-D array, got shape {array.shape}")
    return np.ascontiguousarray(array)


class Run:
    """A log: times t (N,) [s], angles q (N, n) [rad] and torques tau (N, n) [N m], one column
    per joint in the robot's order."""

    def __init__(self, t: Any, q: Any, tau: Any, name: str = "run") -> None:
        self.t = _float_array("t", t, 1)
        self.q = _float_array("q", q, 2)
        self.tau = _float_array("tau", tau, 2)
        self.name = str(name)
        if self.q.shape[0] != self.t.shape[0] or self.tau.shape[0] != self.t.shape[0]:
            raise ValueError(
                f"{self.name}: t, q and tau must have the same number of rows "
                f"(t: {self.t.shape[0]}, q: {self.q.shape[0]}, tau: {self.tau.shape[0]})"
            )
        if self.q.shape[1] != self.tau.shape[1]:
            raise ValueError(
                f"{self.name}: q and tau must have the same number of joints "
                f"(q: {self.q.shape[1]}, tau: {self.tau.shape[1]})"
            )

    @property
    def joints(self) -> int:
        return int(self.q.shape[1])

    def __len__(self) -> int:
        return int(self.t.shape[0])

    def __repr__(self) -> str:
        return f"sid.Run({self.name!r}, samples={len(self)}, joints={self.joints})"

    @classmethod
    def from_csv(
        cls,
        path: PathLike,
        columns: Optional[Mapping[str, str]] = None,
        joints: Optional[int] = None,
    ) -> "Run":
        """A log from CSV with columns t, q1..qn, tau1..taun (others ignored), as the tools read it.

        columns renames some: {"t": "time", "q1": "pos_1", "tau1": "effort_1", ...}.
        joints: n; by default the number of q1, q2, ... columns (after renaming).
        """
        path = os.fspath(path)
        renames = dict(columns or {})
        if joints is None:
            names = set(_sid.csv_column_names(path))
            joints = 0
            while renames.get(f"q{joints + 1}", f"q{joints + 1}") in names:
                joints += 1
            if joints == 0:
                raise ValueError(f"{path}: no column 'q1' (give columns= or joints=)")
        mapping = ",".join(f"{key}={value}" for key, value in renames.items())
        t, q, tau = _sid.read_chain_csv(path, mapping, int(joints))
        return cls(t, q, tau, name=path)

    @classmethod
    def from_dataframe(
        cls, df: Any, columns: Optional[Mapping[str, str]] = None, joints: Optional[int] = None,
        name: str = "dataframe",
    ) -> "Run":
        """A log from a pandas DataFrame with the columns from_csv takes."""
        renames = dict(columns or {})
        if joints is None:
            joints = 0
            while renames.get(f"q{joints + 1}", f"q{joints + 1}") in df.columns:
                joints += 1
            if joints == 0:
                raise ValueError(f"{name}: no column 'q1' (give columns= or joints=)")

        def column(key: str) -> np.ndarray:
            label = renames.get(key, key)
            if label not in df.columns:
                raise ValueError(
                    f"{name}: no column '{label}'; columns are: {', '.join(map(str, df.columns))}"
                )
            return df[label].to_numpy(dtype=np.float64)

        q = np.column_stack([column(f"q{j + 1}") for j in range(joints)])
        tau = np.column_stack([column(f"tau{j + 1}") for j in range(joints)])
        return cls(column("t"), q, tau, name=name)

    def _data(self) -> Any:
        return _sid._RunData(self.name, self.t, self.q, self.tau)


@dataclass(frozen=True)
class Prediction:
    """How a parameter set predicts a run's torques (the CLI's JSON: validation)."""

    name: str
    residual_rms: np.ndarray  #: per joint, over the fitted equations [N m]
    residual_rms_measured: np.ndarray  #: per joint, every sample as recorded [N m]
    relative_residual: float  #: ||tau - Y theta|| / ||tau|| over the fitted equations
    relative_residual_measured: float  #: the same over the log as recorded

    @classmethod
    def _from(cls, d: Mapping[str, Any]) -> "Prediction":
        return cls(
            name=d["name"],
            residual_rms=np.asarray(d["residual_rms"]),
            residual_rms_measured=np.asarray(d["residual_rms_measured"]),
            relative_residual=float(d["relative_residual"]),
            relative_residual_measured=float(d["relative_residual_measured"]),
        )


class Fit:
    """An identification: the base parameters, their uncertainty and how well they predict."""

    def __init__(self, handle: Any, robot: Robot) -> None:
        self._handle = handle
        self._robot = robot
        fitted = handle.fitted
        self.parameter_names: list[str] = list(handle.parameter_names)
        self.theta: np.ndarray = np.asarray(handle.theta)
        #: HAC standard deviations (residuals on smoothed data are correlated).
        self.std_dev: np.ndarray = np.asarray(handle.std_dev)
        self.residual_rms: np.ndarray = np.asarray(fitted["residual_rms"])
        self.residual_rms_measured: np.ndarray = np.asarray(fitted["residual_rms_measured"])
        self.relative_residual: float = float(fitted["relative_residual"])
        self.validation: list[Prediction] = [Prediction._from(v) for v in handle.validation]
        #: The text sid_identify prints, and the warnings it says on stderr.
        self.report: str = handle.report
        self.warnings: list[str] = list(handle.warnings)

    @property
    def robot(self) -> Robot:
        return self._robot

    def to_dict(self) -> dict[str, Any]:
        """Everything ``sid_identify --robot --json`` writes, under the same keys."""
        return json.loads(self._handle.json())

    def predict(self, run: Run) -> np.ndarray:
        """The model's torques (N, n) at the joints, on the run's spline-smoothed motion at the
        fit's cutoffs (a motor-side run goes through the transmission first)."""
        return np.asarray(self._handle.predict(_as_run(run, "run")._data()))

    def write_urdf(self, path: PathLike, force: bool = False) -> None:
        """A copy of the robot's URDF with the physically consistent links of this fit.

        Refuses (ValueError) where the consistent fit did not converge or real bodies do not
        reproduce the estimate, and an existing file unless force.
        """
        path = os.fspath(path)
        if os.path.exists(path) and not force:
            raise ValueError(f"{path} exists; pass force=True to overwrite it")
        text = self._handle.consistent_urdf()
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)

    def write_mjcf(self, path: PathLike, force: bool = False) -> None:
        """A MuJoCo model (MJCF) of the robot's URDF with the physically consistent links of this
        fit, each joint's damping, frictionloss, armature and stiffness, the description's
        shapes and a motor per joint of the chain (as ``sid_identify --write-mjcf``).

        Meshes MuJoCo cannot read, or that are not found, are left out and listed in the file's
        first comment. Refuses (ValueError) as write_urdf does, and an existing file unless force.
        """
        path = os.fspath(path)
        if os.path.exists(path) and not force:
            raise ValueError(f"{path} exists; pass force=True to overwrite it")
        text = self._handle.consistent_mjcf(os.path.dirname(os.path.abspath(path)))
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)

    def report_html(self) -> str:
        """This fit as one self-contained HTML page (as ``sid_identify --report``): parameters
        and std, torque errors, held-out prediction, the consistent model, plots per joint."""
        return self._handle.report_html()

    def identify_payload(
        self, runs: Union["Run", Sequence["Run"]], payload_frame: Optional[str] = None
    ) -> "Payload":
        """The load fixed to the tip link in runs that carry it, this fit's arm held (as
        ``sid_identify --payload-of``): a sid.Payload in the frame of link ``payload_frame``
        (``--payload-frame``; default the robot's tip link, e.g. tool0), any link fixed to the
        chain's last moving link. Refuses (ValueError) a motion that does not show every
        parameter of the load, naming them, and a frame that is not such a link."""
        from .payload import identify_payload

        return identify_payload(self, runs, payload_frame)

    def plot(self, run: int = 0) -> Any:
        """Measured and predicted torque per joint over fitted run `run`, and the residuals
        (a matplotlib figure)."""
        from .plots import plot_fit

        return plot_fit(self, run)

    def __repr__(self) -> str:
        return (
            f"sid.Fit({len(self.theta)} base parameters, relative residual "
            f"{self.relative_residual:.4g})"
        )


def _as_robot(robot: Any) -> Robot:
    if not isinstance(robot, Robot):
        raise ValueError(f"robot must be a sid.Robot, not {type(robot).__name__}")
    return robot


def _as_run(run: Any, what: str) -> Run:
    if not isinstance(run, Run):
        raise ValueError(f"{what} must be a sid.Run, not {type(run).__name__}")
    return run


def _join(value: Union[None, str, Iterable[Any]]) -> str:
    if value is None:
        return ""
    if isinstance(value, str):
        return value
    return ",".join(str(v) for v in value)


def _per_joint(value: Union[None, float, Sequence[float]]) -> str:
    if value is None:
        return ""
    return _join([value] if isinstance(value, (int, float)) else value)


def _set_sensors(options: Any, encoder_bits: Any, encoder_ratio: Any, torque_delay: float) -> None:
    options.encoder_bits = _per_joint(encoder_bits)
    options.encoder_ratio = _per_joint(encoder_ratio)
    options.torque_delay = float(torque_delay)


def _identify_options(
    estimator: str,
    effects: Union[None, str, Sequence[str]],
    no_default_effects: bool,
    cutoff: Union[None, float, Sequence[float]],
    skip: Optional[float],
    rest_fraction: Optional[float],
    coulomb_epsilon: Optional[float],
    torque_delay: Optional[float],
) -> Any:
    """The options identify() and identify_windows() share, as sid_identify's."""
    options = _sid._IdentifyOptions()
    options.estimator = estimator
    options.effects = _join(effects)
    options.no_default_effects = bool(no_default_effects)
    options.cutoff = _join([cutoff] if isinstance(cutoff, (int, float)) else cutoff)
    options.skip = skip
    options.rest_fraction = rest_fraction
    options.coulomb_epsilon = coulomb_epsilon
    options.torque_delay = torque_delay
    return options


def identify(
    robot: Robot,
    runs: Union[Run, Sequence[Run]],
    validate: Union[Run, Sequence[Run]] = (),
    estimator: str = "ls",
    effects: Union[None, str, Sequence[str]] = None,
    no_default_effects: bool = False,
    cutoff: Union[None, float, Sequence[float]] = None,
    skip: Optional[float] = None,
    rest_fraction: Optional[float] = None,
    coulomb_epsilon: Optional[float] = None,
    validate_fraction: Optional[float] = None,
    consistency_folds: Optional[int] = None,
    torque_delay: Optional[float] = None,
    estimate_torque_delay: Optional[float] = None,
) -> Fit:
    """Identifies the robot's base parameters from runs, as ``sid_identify --robot`` does.

    validate: held-out runs to predict. estimator: "ls", "wls" or "iv". effects: drive term
    kinds added to viscous friction and armature (default coulomb and offset; "none": rigid
    bodies only; with no_default_effects they are the whole list). cutoff: the smoothing [Hz],
    one or one per joint (default: chosen by held-out prediction). The other options are the
    tool's --skip, --rest-fraction, --coulomb-epsilon, --validate-fraction,
    --consistency-folds, --torque-delay [s] and --estimate-torque-delay [s] (the largest lag
    searched; the estimate is to_dict()["torque_delay"], its standard deviation
    "torque_delay_std_dev").
    """
    _as_robot(robot)
    runs = [runs] if isinstance(runs, Run) else list(runs)
    validate = [validate] if isinstance(validate, Run) else list(validate)
    options = _identify_options(
        estimator, effects, no_default_effects, cutoff, skip, rest_fraction, coulomb_epsilon,
        torque_delay)
    options.validate_fraction = validate_fraction
    options.consistency_folds = consistency_folds
    options.estimate_torque_delay = estimate_torque_delay
    data = [_as_run(r, "runs")._data() for r in runs]
    held = [_as_run(r, "validate")._data() for r in validate]
    return Fit(_sid.identify(robot._handle, data, held, options), robot)


def smooth(
    x: Any,
    y: Any,
    lam: Optional[float] = None,
    weights: Any = None,
    smoothing: str = "gcv",
) -> "Spline":
    """The cubic smoothing spline of (x, y): x sorted (not decreasing).

    At a given lam it minimises sum w (y - f)^2 + lam * integral f''^2 (SciPy's
    make_smoothing_spline(x, y, w, lam); csaps' smooth = 1 / (1 + lam)); without lam, lam
    minimises the generalized ("gcv") or leave-one-out ("cv") cross-validation score. Returns a
    spline s callable as s(x, nu=0) for the value (nu = 0), slope (1) or curvature (2); s.lam
    is the lam used. Samples at one x are merged into their weighted mean (weights summed); so
    are samples so close that the fit's banded system loses its digits (s.merge_tolerance),
    as R's smooth.spline does.
    """
    xs = _float_array("x", x, 1)
    ys = _float_array("y", y, 1)
    w = None if weights is None else _float_array("weights", weights, 1)
    return Spline(_sid.smooth(xs, ys, lam, w, smoothing))


class Spline:
    """A cubic spline from smooth(): s(x, nu=0) evaluates it (nu = 0, 1, 2) at x, a number or an
    array; outside the data it continues as a straight line (a natural spline)."""

    def __init__(self, handle: Any) -> None:
        self._handle = handle

    def __call__(self, x: Any, nu: int = 0) -> Any:
        array = np.asarray(x, dtype=np.float64)
        values = np.asarray(self._handle(np.ascontiguousarray(array.reshape(-1)), int(nu)))
        return float(values[0]) if array.ndim == 0 else values.reshape(array.shape)

    @property
    def lam(self) -> float:
        """The penalty weight used (given, or chosen by cross-validation)."""
        return float(self._handle.lam)

    @property
    def knots(self) -> np.ndarray:
        """The abscissae the spline has its knots at: x, with samples closer than
        merge_tolerance merged."""
        return np.asarray(self._handle.knots)

    @property
    def merge_tolerance(self) -> float:
        """The largest gap between samples merged into one: 0 (exact ties only) unless the
        fit's banded system needed it (near-duplicate abscissae)."""
        return float(self._handle.merge_tolerance)

    @property
    def dof(self) -> float:
        """tr A, the fit's equivalent degrees of freedom (NaN at a given lam)."""
        return float(self._handle.trace)

    @property
    def sigma(self) -> float:
        """The noise level the cross-validated fit implies (NaN at a given lam)."""
        return float(self._handle.sigma)

    def __repr__(self) -> str:
        return f"sid.Spline(knots={len(self.knots)}, lam={self.lam:.6g})"


@dataclass(frozen=True)
class Truth:
    """What a simulated log hides: the true motion and torque, and the model's parameters."""

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    theta: np.ndarray  #: the simulated model's parameters, named by parameter_names
    parameter_names: list[str]


def simulate(
    robot: Robot,
    duration: float = 10.0,
    sample_time: float = 0.0025,
    sigma_q2: float = 1e-6,
    sigma_tau2: float = 1e-2,
    seed: int = 1,
    effects: Union[str, Sequence[str]] = (),
    harmonics: int = 5,
    base_frequency: float = 0.1,
    q_range: float = 1.0,
    qd_max: float = 1.5,
    trajectory: Union[None, PathLike, "Excitation"] = None,
    truth: bool = False,
    rtol: float = 1e-10,
    atol: float = 1e-10,
    encoder_bits: Union[None, int, Sequence[int]] = None,
    encoder_ratio: Union[None, float, Sequence[float]] = None,
    torque_delay: float = 0.0,
) -> Any:
    """A log of the robot's URDF simulated with CVODE, as ``sid_simulate --robot``: computed
    torque tracking a random Fourier excitation (or trajectory: a sid.excite result or the
    file sid_excite writes), the
    description's links with viscous friction, Coulomb friction and armature, and the effects
    hidden, e.g. ["coulomb_j2:0.5", "spring_j3:2", "angle_offset_q4:0.05"]; white noise of
    variance sigma_q2 on the angles and sigma_tau2 on the torques, drawn from seed; CVODE at
    tolerances rtol and atol. A cheap arm's sensors: encoder_bits per turn (one, or one per
    joint) round the noisy angles, on the motor through encoder_ratio turns per joint turn; the
    torque is logged torque_delay [s] behind the angles.

    Returns the Run; with truth=True, (run, Truth).
    """
    _as_robot(robot)
    options = _sid._SimulateOptions()
    options.duration = float(duration)
    options.sample_time = float(sample_time)
    options.sigma_q2 = float(sigma_q2)
    options.sigma_tau2 = float(sigma_tau2)
    if int(seed) < 0:
        raise ValueError("seed must be >= 0")
    options.seed = int(seed)
    options.effects = [effects] if isinstance(effects, str) else [str(e) for e in effects]
    options.harmonics = int(harmonics)
    options.base_frequency = float(base_frequency)
    options.q_range = float(q_range)
    options.qd_max = float(qd_max)
    options.rtol = float(rtol)
    options.atol = float(atol)
    _set_sensors(options, encoder_bits, encoder_ratio, torque_delay)
    with tempfile.TemporaryDirectory() as folder:
        if isinstance(trajectory, Excitation):
            path = os.path.join(folder, "excitation.csv")
            trajectory.write(path)
            trajectory = path
        options.trajectory = os.fspath(trajectory) if trajectory is not None else ""
        d = _sid.simulate(robot._handle, options)
    for warning in d["warnings"]:
        warnings.warn(warning, stacklevel=2)
    run = Run(d["t"], d["q"], d["tau"], name=f"simulated (seed {seed})")
    if not truth:
        return run
    return run, Truth(
        q=np.asarray(d["q_true"]), qd=np.asarray(d["qd_true"]), qdd=np.asarray(d["qdd_true"]),
        tau=np.asarray(d["tau_true"]), theta=np.asarray(d["theta"]),
        parameter_names=list(d["parameter_names"]),
    )


class Excitation:
    """An excitation as ``sid_excite --robot`` designs it: a Fourier trajectory
    q_j(t) = q0_j + sum_l a_jl / (l w) sin(l w t) - b_jl / (l w) cos(l w t), w = 2 pi f,
    at rest at t = k / f."""

    def __init__(self, handle: Any) -> None:
        self._handle = handle
        self.condition_number: float = handle.condition_number
        #: the random start's, from the seed
        self.random_condition_number: float = handle.random_condition_number
        self.base_frequency: float = handle.base_frequency
        self.q0: np.ndarray = np.asarray(handle.q0)
        self.a: np.ndarray = np.asarray(handle.a)
        self.b: np.ndarray = np.asarray(handle.b)
        self.report: str = handle.report

    def write(self, path: PathLike, force: bool = False) -> None:
        """The coefficients file sid_simulate --trajectory and sid.simulate(trajectory=) read."""
        path = os.fspath(path)
        if os.path.exists(path) and not force:
            raise ValueError(f"{path} exists; pass force=True to overwrite it")
        self._handle.write(path, True)

    def __repr__(self) -> str:
        return (
            f"sid.Excitation(condition number {self.condition_number:.4g}, "
            f"random {self.random_condition_number:.4g})"
        )


def excite(
    robot: Robot,
    harmonics: int = 5,
    base_frequency: float = 0.1,
    q_range: float = 1.0,
    qd_max: float = 1.5,
    qdd_max: float = 10.0,
    torque_fraction: float = 0.8,
    rate: float = 20.0,
    max_evaluations: int = 300,
    algorithm: str = "slsqp",
    separate: Union[None, str, Sequence[str]] = None,
    seed: int = 1,
    random_only: bool = False,
) -> Excitation:
    """The excitation that makes the robot's base regressor well conditioned within its joint,
    rate, acceleration and torque limits, as ``sid_excite --robot`` (NLopt from a random start
    drawn from seed). separate: candidate ids of sid.diagnose (e.g. ["spring_j2", "offset_j2"])
    whose columns join the conditioned regressor, for a motion on which they are told apart.
    """
    _as_robot(robot)
    if int(seed) < 0:
        raise ValueError("seed must be >= 0")
    options = _sid._ExciteOptions()
    options.harmonics = int(harmonics)
    options.base_frequency = float(base_frequency)
    options.q_range = float(q_range)
    options.qd_max = float(qd_max)
    options.qdd_max = float(qdd_max)
    options.torque_fraction = float(torque_fraction)
    options.rate = float(rate)
    options.max_evaluations = int(max_evaluations)
    options.algorithm = str(algorithm)
    options.separate = _join(separate)
    options.seed = int(seed)
    options.random_only = bool(random_only)
    return Excitation(_sid.excite(robot._handle, options))


def montecarlo(
    runs: int = 30,
    levels: Sequence[float] = (1e-8, 1e-6, 1e-4),
    sigma_tau2: float = 1e-2,
    methods: Union[str, Sequence[str]] = ("raw", "filtered", "css", "oracle"),
    seed: int = 20240601,
    threads: int = 0,
    robot: Optional[Robot] = None,
    duration: float = 10.0,
    rate: float = 400.0,
    harmonics: int = 5,
    base_frequency: float = 0.1,
    q_range: float = 1.0,
    qd_max: float = 1.5,
    encoder_bits: Union[None, int, Sequence[int]] = None,
    encoder_ratio: Union[None, float, Sequence[float]] = None,
    torque_delay: float = 0.0,
    estimate_torque_delay: Optional[float] = None,
) -> dict[str, Any]:
    """The Monte Carlo study of ``sid_montecarlo``: runs noisy data sets per angle-noise
    variance in levels [rad^2], each method's estimates, their mean, variance, bias and RMS
    relative error. Without robot, the paper's two-link arm (seven parameters); with a robot
    (a URDF), its arm under a random Fourier excitation of duration [s] at rate [Hz] (the
    harmonics, base_frequency, q_range and qd_max of sid.simulate), its base parameters, each
    run logged through the sensors of sid.simulate (encoder_bits, encoder_ratio,
    torque_delay); with estimate_torque_delay [s], css_tcv estimates the torque's delay within
    that bound and fits paired at it. Returns the tool's JSON summary (``--json``) as a dict, the same for any threads (0: every
    core).
    """
    options = _sid._PaperStudyOptions()
    options.runs = int(runs)
    options.levels = _join([repr(float(v)) for v in levels])
    options.sigma_tau2 = float(sigma_tau2)
    options.methods = _join(methods)
    if int(seed) < 0:
        raise ValueError("seed must be >= 0")
    options.seed = str(int(seed))
    options.threads = int(threads)
    if robot is None:
        if encoder_bits is not None or encoder_ratio is not None or torque_delay != 0.0 or (
            estimate_torque_delay is not None
        ):
            raise ValueError("the sensors and the delay's estimate are the study of a robot's")
        return json.loads(_sid.montecarlo(options))
    _as_robot(robot)
    chain = _sid._ChainStudyOptions()
    chain.duration = float(duration)
    chain.rate = float(rate)
    chain.harmonics = int(harmonics)
    chain.base_frequency = float(base_frequency)
    chain.q_range = float(q_range)
    chain.qd_max = float(qd_max)
    _set_sensors(chain, encoder_bits, encoder_ratio, torque_delay)
    if estimate_torque_delay is not None:
        chain.estimate_torque_delay = float(estimate_torque_delay)
    return json.loads(_sid.chain_montecarlo(robot._handle, options, chain))
