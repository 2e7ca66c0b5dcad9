"""The load on an identified arm's tip link (sid_identify --payload-of)."""

from __future__ import annotations

import json
import os
from typing import TYPE_CHECKING, Any, Optional, Sequence, Union

import numpy as np

from . import _sid

if TYPE_CHECKING:
    from ._core import Fit, PathLike, Robot, Run


class Payload:
    """A load fixed to the tip link: mass [kg], centre of mass [m] and inertia about it
    [kg m^2] (ixx, iyy, izz, ixy, ixz, iyz) in the frame of link ``frame`` (the robot's tip link,
    e.g. tool0, unless ``payload_frame`` named another; a DH table: its last link's), each with
    its standard deviation (HAC), always a real body."""

    def __init__(self, d: Any, robot: "Robot") -> None:
        self._robot = robot
        self._json: str = d["json"]
        load = json.loads(self._json)["payload"]
        self.frame: str = load["frame"]
        self.mass: float = float(load["mass"])
        self.mass_std: float = float(load["mass_std"])
        self.com: np.ndarray = np.asarray(load["com"])
        self.com_std: np.ndarray = np.asarray(load["com_std"])
        self.inertia: np.ndarray = np.asarray(load["inertia"])
        self.inertia_std: np.ndarray = np.asarray(load["inertia_std"])
        #: m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz about the frame's origin.
        self.standard_parameters: np.ndarray = np.asarray(d["standard_parameters"])
        self.report: str = d["report"]
        self.warnings: list[str] = list(d["warnings"])

    def to_dict(self) -> dict[str, Any]:
        """Everything ``sid_identify --payload-of --json`` writes, under the same keys."""
        return json.loads(self._json)

    def write_urdf(self, path: "PathLike", force: bool = False) -> None:
        """A copy of the robot's URDF with the load as link ``payload`` fixed to the tip."""
        path = os.fspath(path)
        if os.path.exists(path) and not force:
            raise ValueError(f"{path} exists; pass force=True to overwrite it")
        text = _sid.payload_urdf(self._robot._handle, self.standard_parameters, self.frame)
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)

    def __repr__(self) -> str:
        return (
            f"sid.Payload({self.mass:.4g} kg at ({self.com[0]:.3g}, {self.com[1]:.3g}, "
            f"{self.com[2]:.3g}) m in {self.frame})"
        )


def identify_payload(
    fit: "Fit", runs: Union["Run", Sequence["Run"]], payload_frame: Optional[str] = None
) -> Payload:
    from ._core import Run, _as_run

    runs = [runs] if isinstance(runs, Run) else list(runs)
    data = [_as_run(r, "runs")._data() for r in runs]
    d = _sid.identify_payload(
        fit.robot._handle, json.dumps(fit.to_dict()), "the fit", data, payload_frame or ""
    )
    return Payload(d, fit.robot)
