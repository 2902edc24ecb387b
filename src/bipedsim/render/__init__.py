"""Headless videos and plots of recorded rollouts (everything reads a run folder)."""

from __future__ import annotations

from bipedsim.render.gl import RenderError, choose_backend
from bipedsim.render.video import VideoOptions, render_video

__all__ = ["RenderError", "VideoOptions", "choose_backend", "render_video"]
