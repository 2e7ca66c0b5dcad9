"""The torque the outside applies to an identified arm, and its contacts (sid_external)."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from typing import Any, Optional, Sequence, Union

import numpy as np

from . import _sid
from ._core import Fit, PathLike, Robot, Run, _as_robot, _as_run, _join


@dataclass
class Contact:
    """One contact: from the first to the last sample above threshold [s], the joints above
    their threshold during it, and each joint's largest external torque then (signed)."""

    start: float
    end: float
    joints: list[str]
    peak: np.ndarray


class External:
    """What ``sid_external`` finds on a log: tau_ext (N, n) at the times t, the contact flag per
    sample, each joint's threshold, the contacts and the excursions beyond an effort limit."""

    def __init__(self, d: Any) -> None:
        self.t: np.ndarray = np.asarray(d["t"])
        self.tau_ext: np.ndarray = np.asarray(d["tau_ext"])
        self.contact: np.ndarray = np.asarray(d["contact"]).astype(bool)
        self.thresholds: np.ndarray = np.asarray(d["thresholds"])
        self.method: str = d["method"]
        #: The observer's rate K [1/s] (0 for the residual).
        self.gain: float = float(d["gain"])
        self.report: str = d["report"]
        self.warnings: list[str] = list(d["warnings"])
        self._json: str = d["json"]
        found = json.loads(self._json)

        def excursions(key: str) -> list[Contact]:
            return [
                Contact(
                    float(c["start"]), float(c["end"]), list(c["joints"]), np.asarray(c["peak"])
                )
                for c in found[key]
            ]

        self.contacts: list[Contact] = excursions("contacts")
        #: Excursions beyond a joint's effort limit (the URDF's): the model's failure, not
        #: contacts.
        self.beyond_effort_limit: list[Contact] = excursions("beyond_effort_limit")

    def to_dict(self) -> dict[str, Any]:
        """Everything ``sid_external --json`` writes, under the same keys."""
        return json.loads(self._json)

    def __repr__(self) -> str:
        return f"sid.External({len(self.contacts)} contacts, {self.method})"


def external_torque(
    robot: Robot,
    fit: Union[Fit, PathLike],
    run: Run,
    method: str = "observer",
    gain: Optional[float] = None,
    cutoff: Union[None, str, float, Sequence[float]] = None,
    threshold: float = 5.0,
    min_duration: float = 0.01,
    merge_gap: float = 0.05,
    skip: float = 0.1,
) -> External:
    """The external torque on run and its contacts, as ``sid_external`` finds them.

    fit: the arm, a sid.Fit of the robot on logs without contact or the path of
    ``sid_identify --robot --json``'s file. method: "observer" (the generalized-momentum
    observer, default) or "residual". The other options are the tool's --gain [1/s], --cutoff
    [Hz] (or "fit"), --threshold, --min-duration, --merge-gap and --skip [s].
    """
    _as_robot(robot)
    if isinstance(fit, Fit):
        text, source = json.dumps(fit.to_dict()), "the fit"
    else:
        source = os.fspath(fit)
        try:
            with open(source, encoding="utf-8") as f:
                text = f.read()
        except OSError as e:
            raise ValueError(f"cannot read '{source}': {e.strerror}") from None
    options = _sid._ExternalOptions()
    options.method = method
    options.gain = gain
    options.cutoff = _join([cutoff] if isinstance(cutoff, (int, float)) else cutoff)
    options.threshold = float(threshold)
    options.min_duration = float(min_duration)
    options.merge_gap = float(merge_gap)
    options.skip = float(skip)
    return External(
        _sid.external_torque(robot._handle, text, source, _as_run(run, "run")._data(), options)
    )
