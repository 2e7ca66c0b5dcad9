"""The parameters of an arm window by window over its logs, and their drift
(sid_identify --robot --window)."""

from __future__ import annotations

import json
from typing import Any, Optional, Sequence, Union

import numpy as np

from . import _sid
from ._core import Robot, Run, _as_robot, _as_run, _identify_options


class Windows:
    """Each window's estimate with its HAC standard deviation, and per parameter a line over
    the operating time (the logs laid end to end): ``parameters`` holds name, combination,
    windows, mean, slope_per_hour, slope_std_dev, birge_ratio and drifts; ``windows`` the
    windows' source, start, end, operating_time_h, cutoff_hz and relative_residual."""

    def __init__(self, report: str, text: str) -> None:
        d = json.loads(text)
        self._json = text
        #: The text sid_identify prints.
        self.report: str = report
        self.parameters: list[dict[str, Any]] = d["parameters"]
        #: What sid_identify says on stderr: windows not fitted, parameters some windows regroup.
        self.warnings: list[str] = d["warnings"]
        self.windows: list[dict[str, Any]] = [
            {k: v for k, v in w.items() if k not in ("theta", "std_dev")} for w in d["windows"]
        ]
        nan = float("nan")
        #: windows x parameters; NaN where a window leaves the parameter undetermined.
        self.value: np.ndarray = np.array(
            [[nan if v is None else v for v in w["theta"]] for w in d["windows"]], dtype=float
        )
        self.std_dev: np.ndarray = np.array(
            [[nan if v is None else v for v in w["std_dev"]] for w in d["windows"]], dtype=float
        )

    def rows(self) -> list[dict[str, Any]]:
        """One record per window and parameter (``pandas.DataFrame(w.rows())``): window
        (its index), source, start, end, operating_time_h, parameter, value, std_dev."""
        out = []
        for k, w in enumerate(self.windows):
            for i, p in enumerate(self.parameters):
                out.append(
                    {
                        "window": k,
                        "source": w["source"],
                        "start": w["start"],
                        "end": w["end"],
                        "operating_time_h": w["operating_time_h"],
                        "parameter": p["name"],
                        "value": float(self.value[k, i]),
                        "std_dev": float(self.std_dev[k, i]),
                    }
                )
        return out

    def drifting(self) -> list[str]:
        """The names of the parameters found to drift."""
        return [p["name"] for p in self.parameters if p["drifts"]]

    def to_dict(self) -> dict[str, Any]:
        """Everything ``sid_identify --robot --window --json`` writes, under the same keys."""
        return json.loads(self._json)


def identify_windows(
    robot: Robot,
    runs: Union[Run, Sequence[Run]],
    window: Union[str, float] = "log",
    estimator: str = "ls",
    effects: Union[None, str, Sequence[str]] = None,
    no_default_effects: bool = False,
    cutoff: Union[None, float, Sequence[float]] = None,
    skip: Optional[float] = None,
    rest_fraction: Optional[float] = None,
    coulomb_epsilon: Optional[float] = None,
    torque_delay: Optional[float] = None,
) -> Windows:
    """Identifies the robot on each window of the runs on its own, as ``sid_identify --robot
    --window`` does, and fits each parameter's drift over the operating time.

    window: seconds (a number), a length with its unit ("10min", "2h", "1d") or "log" (each
    run one window, e.g. one log a day). The other options are identify()'s; the torque is
    fitted as measured (see docs/using-the-arm.md).
    """
    _as_robot(robot)
    runs = [runs] if isinstance(runs, Run) else list(runs)
    options = _identify_options(
        estimator, effects, no_default_effects, cutoff, skip, rest_fraction, coulomb_epsilon,
        torque_delay)
    options.window = repr(float(window)) if isinstance(window, (int, float)) else str(window)
    data = [_as_run(r, "runs")._data() for r in runs]
    report, text = _sid.identify_windows(robot._handle, data, options)
    return Windows(report, text)
