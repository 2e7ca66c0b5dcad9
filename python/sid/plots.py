"""Figures of a fit and a diagnosis (matplotlib, an optional dependency: pip install matplotlib)."""

from __future__ import annotations

from typing import Any

import numpy as np


def _pyplot() -> Any:
    try:
        import matplotlib.pyplot as plt
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("plots need matplotlib: pip install matplotlib") from e
    return plt


def plot_fit(fit: Any, run: int = 0) -> Any:
    """Measured and predicted torque of each joint over a fitted run, and their difference."""
    plt = _pyplot()
    runs = fit._handle.fitted_runs()
    if not 0 <= run < len(runs):
        raise ValueError(f"run must be in [0, {len(runs)}), not {run}")
    name, t, measured, model = runs[run]
    names = list(fit._handle.joint_names)
    n = len(names)
    figure, axes = plt.subplots(n, 2, sharex=True, figsize=(11, 1.9 * n + 1), squeeze=False)
    for j in range(n):
        axes[j, 0].plot(t, measured[:, j], lw=0.6, color="0.55", label="measured")
        axes[j, 0].plot(t, model[:, j], lw=0.9, color="C0", label="model")
        axes[j, 0].set_ylabel(f"{names[j]}\n[N m]")
        axes[j, 1].plot(t, measured[:, j] - model[:, j], lw=0.6, color="C3")
        rms = float(np.sqrt(np.mean((measured[:, j] - model[:, j]) ** 2)))
        axes[j, 1].set_title(f"residual, RMS {rms:.3g} N m", fontsize=8, loc="right")
    axes[0, 0].legend(loc="upper right", fontsize=8)
    axes[0, 0].set_title(f"{name}: torque at the joints", fontsize=9, loc="left")
    axes[-1, 0].set_xlabel("t [s]")
    axes[-1, 1].set_xlabel("t [s]")
    figure.tight_layout()
    return figure


def plot_diagnosis(diagnosis: Any, ax: Any = None) -> Any:
    """Per joint: the nominal and final models' residual RMS against the torque noise, with the
    named terms written over their joints."""
    plt = _pyplot()
    names = diagnosis.robot.joint_names
    x = np.arange(len(names))
    if ax is None:
        _, ax = plt.subplots(figsize=(1.2 * len(names) + 3, 3.8))
    ax.bar(x - 0.2, diagnosis.nominal_residual_rms, 0.4, label="nominal model", color="0.6")
    ax.bar(x + 0.2, diagnosis.final_residual_rms, 0.4, label="with the named terms", color="C0")
    ax.plot(x, diagnosis.noise_floor, "k_", markersize=22, label="torque noise")
    for term in diagnosis.named:
        joint = _joint_of(term.id)
        if joint is not None and joint < len(names):
            ax.annotate(
                f"{term.id}\n{term.value:.3g} {term.unit}",
                (joint, diagnosis.nominal_residual_rms[joint]),
                textcoords="offset points", xytext=(0, 4), ha="center", fontsize=7,
            )
    ax.set_xticks(x, names, rotation=20, fontsize=8)
    ax.set_ylabel("torque residual RMS [N m]")
    ax.legend(fontsize=8)
    return ax


def _joint_of(term_id: str) -> Any:
    """The 0-based joint of an id such as coulomb_j3, armature_m2 or angle_offset_q5."""
    tail = term_id.rsplit("_", 1)[-1]
    return int(tail[1:]) - 1 if tail[:1] in {"j", "m", "q"} and tail[1:].isdigit() else None
