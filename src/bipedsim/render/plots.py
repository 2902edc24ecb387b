"""Plots of a recorded run (matplotlib, PNG): joint angles against the reference, tracking error,
centre of mass and support feet from above, the contact timeline; push windows shaded."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from bipedsim.files import save_figure
from bipedsim.sim.recorder import Trajectory

DEFAULT_JOINTS = ("left_hip_y", "left_knee", "left_ankle", "right_hip_y", "right_knee", "right_ankle")
#: The files :func:`plot_run` writes, in its order.
PLOT_FILES = ("joint_angles.png", "tracking_error.png", "com_top_view.png", "contacts.png")
JOINT_ANGLES, TRACKING_ERROR, COM_TOP_VIEW, CONTACTS = PLOT_FILES


def _shade_pushes(ax, tr: Trajectory) -> None:  # noqa: ANN001
    for s, e, _, _ in tr.pushes():
        ax.axvspan(s, max(e, s + 1e-3), color="tab:red", alpha=0.15, lw=0)


#: a foot is "down" while its vertical contact force exceeds this (N)
CONTACT_N = 30.0
#: colours of the feet in the top view and the contact timeline (left, right, then more legs)
FOOT_COLOURS = ("tab:green", "tab:orange", "tab:blue", "tab:red", "tab:purple", "tab:brown")


def plot_run(tr: Trajectory, hinge_names: list[str], q: np.ndarray, qr: np.ndarray, foot_xy: np.ndarray | None,
             feet: list[str], out_dir: str | os.PathLike[str], joints: tuple[str, ...] = DEFAULT_JOINTS) -> list[Path]:
    """Write the four plots into ``out_dir``; returns their paths. ``hinge_names``, ``q``, ``qr``: the
    joints and their simulated and reference angles (rad), (T, J); ``feet``: the names of
    ``tr.contact_force``'s columns; ``foot_xy``: (T, feet, 2) their positions per sample, or None."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    t = tr.time
    # 1. joint angles vs reference
    shown = [j for j in joints if j in hinge_names] or hinge_names[:6]
    fig, axes = plt.subplots(len(shown), 1, figsize=(9, 1.6 * len(shown) + 0.8), sharex=True)
    axes = np.atleast_1d(axes)
    for ax, j in zip(axes, shown):
        k = hinge_names.index(j)
        ax.plot(t, qr[:, k], color="0.6", lw=1.5, label="reference")
        ax.plot(t, q[:, k], color="tab:blue", lw=1.0, label="simulated")
        ax.set_ylabel(f"{j}\n(rad)", fontsize=8)
        _shade_pushes(ax, tr)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout()
    paths.append(out / JOINT_ANGLES)
    save_figure(fig, paths[-1])
    plt.close(fig)
    # 2. tracking error
    err = np.sqrt(np.mean((q - qr) ** 2, axis=1))
    fig, ax = plt.subplots(figsize=(9, 3))
    ax.plot(t, err, color="tab:purple")
    _shade_pushes(ax, tr)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("tracking RMSE (rad)")
    ax.set_title("joint tracking error against the reference")
    fig.tight_layout()
    paths.append(out / TRACKING_ERROR)
    save_figure(fig, paths[-1])
    plt.close(fig)
    # 3. COM and support feet, top view
    fig, ax = plt.subplots(figsize=(9, 4))
    ax.plot(tr.com[:, 0], tr.com[:, 1], color="k", lw=1.2, label="centre of mass")
    if foot_xy is not None:
        for k, name in enumerate(feet):
            col = FOOT_COLOURS[k % len(FOOT_COLOURS)]
            down = tr.contact_force[:, k] > CONTACT_N
            ax.scatter(foot_xy[down, k, 0], foot_xy[down, k, 1], s=4, color=col, label=f"{name} foot down")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(fontsize=8)
    ax.set_title("top view")
    fig.tight_layout()
    paths.append(out / COM_TOP_VIEW)
    save_figure(fig, paths[-1])
    plt.close(fig)
    # 4. contact timeline
    fig, ax = plt.subplots(figsize=(9, 1.2 + 0.4 * len(feet)))
    for k in range(len(feet)):
        col = FOOT_COLOURS[k % len(FOOT_COLOURS)]
        down = tr.contact_force[:, k] > CONTACT_N
        edges = np.flatnonzero(np.diff(np.concatenate([[0], down.astype(int), [0]])))
        spans = [(t[s], t[min(e, len(t) - 1)] - t[s]) for s, e in zip(edges[::2], edges[1::2])]
        ax.broken_barh(spans, (k - 0.4, 0.8), color=col)
    _shade_pushes(ax, tr)
    ax.set_yticks(list(range(len(feet))), feet)
    ax.set_xlabel("time (s)")
    ax.set_title("foot contact")
    fig.tight_layout()
    paths.append(out / CONTACTS)
    save_figure(fig, paths[-1])
    plt.close(fig)
    return paths
