"""sid: dynamic parameters of robot arms from measured joint angles and torques.

Each measured angle is smoothed with a cubic smoothing spline, its rates and accelerations are
taken from the spline, and the linear model tau = Y(q, qd, qdd) theta is solved by least squares.
The package calls the same compiled code as the command-line tools (sid_identify, ...), so it
gives their numbers and their messages: bad input raises ValueError.

    import sid
    robot = sid.Robot.from_urdf("arm.urdf", tip="tool0")
    run = sid.Run.from_csv("run.csv")
    fit = sid.identify(robot, [run], validate=[sid.Run.from_csv("other.csv")])
    print(fit.parameter_names, fit.theta, fit.std_dev, fit.validation[0].relative_residual)
"""

from __future__ import annotations

from ._core import (
    Excitation,
    Fit,
    Prediction,
    Robot,
    Run,
    Spline,
    Truth,
    excite,
    identify,
    montecarlo,
    simulate,
    smooth,
)
from .bag import read_bag
from .diagnosis import Diagnosis, Term, diagnose
from .external import Contact, External, external_torque
from .payload import Payload
from .windows import Windows, identify_windows

__all__ = [
    "Contact",
    "Diagnosis",
    "External",
    "Excitation",
    "Fit",
    "Payload",
    "Prediction",
    "Robot",
    "Run",
    "Spline",
    "Term",
    "Truth",
    "Windows",
    "diagnose",
    "excite",
    "external_torque",
    "identify",
    "identify_windows",
    "montecarlo",
    "read_bag",
    "simulate",
    "smooth",
]
__version__ = "0.1.0"
