"""The chain diagnosis, as ``sid_diagnose --robot`` makes it: which drive terms a robot's logs
support beyond its nominal model."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any, Optional, Sequence, Union

import numpy as np

from . import _sid
from ._core import Robot, Run, _as_robot, _as_run, _join


@dataclass(frozen=True)
class Term:
    """A candidate term: named (value and std from the final fit) or not (the reason, and the
    size from which the log would show it)."""

    id: str  #: e.g. coulomb_j3, armature_j5, angle_offset_q2
    value: float
    std: float
    unit: str
    p_value: float  #: HAC Wald test, Holm-adjusted
    reason: str = ""  #: why it was not named ("" for a named term)
    detection_limit: float = float("nan")  #: for a tested, unnamed term [unit]
    caveat: str = ""  #: for a named term: the inseparable candidates that may stand behind it
    look_alikes: list[str] = field(default_factory=list)

    @classmethod
    def _from(cls, d: dict[str, Any]) -> "Term":
        return cls(**{k: d[k] for k in cls.__dataclass_fields__})


class Diagnosis:
    """What the diagnosis found: the named terms, the others with the reason, the residuals per
    joint and the free simulations' verdict."""

    def __init__(self, handle: Any, robot: Robot) -> None:
        self._handle = handle
        self.robot = robot
        self.named: list[Term] = [Term._from(d) for d in handle.named]
        self.not_named: list[Term] = [Term._from(d) for d in handle.not_named]
        #: per joint [N m]: the torque noise, the nominal and final models' residual RMS, and
        #: what the final model leaves above the noise.
        self.noise_floor: np.ndarray = np.asarray(handle.noise_floor)
        self.nominal_residual_rms: np.ndarray = np.asarray(handle.nominal_residual_rms)
        self.final_residual_rms: np.ndarray = np.asarray(handle.final_residual_rms)
        self.unexplained_rms: np.ndarray = np.asarray(handle.unexplained_rms)
        #: the smoothing cutoffs per joint [Hz], and how they were chosen, in words
        self.cutoff_hz: np.ndarray = np.asarray(handle.cutoff_hz)
        self.smoothing: str = handle.smoothing
        #: the joints (names) whose free simulation the final model does not explain
        self.motion_not_explained: list[str] = [robot.joint_names[j] for j in handle.beyond]
        self.report: str = handle.report

    def to_dict(self) -> dict[str, Any]:
        """Everything ``sid_diagnose --robot --json`` writes, under the same keys."""
        return json.loads(self._handle.json())

    def report_html(self) -> str:
        """What ``sid_diagnose --robot --report`` writes: one self-contained HTML page (the
        residual against the noise per joint, the named terms and their tests, the others and
        why, the free simulations)."""
        return self._handle.report_html()

    def plot(self, ax: Any = None) -> Any:
        """Per joint: the torque residual of the nominal and the final model against the noise
        floor, with the named terms (matplotlib)."""
        from .plots import plot_diagnosis

        return plot_diagnosis(self, ax)

    def __repr__(self) -> str:
        return f"sid.Diagnosis(named={[t.id for t in self.named]})"


def diagnose(
    robot: Robot,
    runs: Union[Run, Sequence[Run]],
    drives: Union[None, str, Sequence[str]] = None,
    candidates: Union[None, str, Sequence[str]] = None,
    cutoff: Union[None, float, Sequence[float]] = None,
    rest_fraction: Optional[float] = None,
    negligible_size: Optional[float] = None,
    measured: bool = False,
) -> Diagnosis:
    """Which drive terms the runs support beyond the nominal model (rigid bodies and drives,
    default viscous friction and armature), as ``sid_diagnose --robot``.

    candidates: the kinds tried (default coulomb, offset, armature, spring, viscous, stribeck and
    angle_offset). Several runs are judged by the runs each fit has not seen. measured: smooth
    as sid_identify does (held-out torque prediction), as two runs or more, or angles GCV cannot
    smooth (an encoder's staircase, or GCV at its ceiling), imply; else by GCV of the angles.
    """
    _as_robot(robot)
    runs = [runs] if isinstance(runs, Run) else list(runs)
    options = _sid._DiagnoseOptions()
    options.drives = _join(drives)
    options.candidates = _join(candidates)
    options.cutoff = _join([cutoff] if isinstance(cutoff, (int, float)) else cutoff)
    options.rest_fraction = rest_fraction
    options.negligible_size = negligible_size
    options.measured = measured
    data = [_as_run(r, "runs")._data() for r in runs]
    return Diagnosis(_sid.diagnose(robot._handle, data, options), robot)
