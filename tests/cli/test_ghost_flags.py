"""The --ghost and --ghost-offset flags of ``bipedsim run`` and ``bipedsim render``."""

from __future__ import annotations

import pytest

from bipedsim.cli import build_parser
from bipedsim.cli.commands import video_options
from bipedsim.cli.flags import GHOST_OFFSET_M
from bipedsim.errors import ConfigError
from bipedsim.render.video import VideoOptions


def test_the_ghost_offset_default_is_the_packages() -> None:
    assert VideoOptions().ghost_offset == GHOST_OFFSET_M
    args = build_parser().parse_args(["render", "RUN"])
    assert not args.ghost and args.ghost_offset == GHOST_OFFSET_M


@pytest.mark.parametrize("command", [["render", "RUN"], ["run", "--out", "OUT"]])
def test_the_flags_reach_the_video_options(command: list[str]) -> None:
    opts = video_options(build_parser().parse_args([*command, "--ghost", "--ghost-offset", "-1.5"]))
    assert opts.ghost and opts.ghost_offset == -1.5


def test_an_offset_out_of_range_names_its_flag() -> None:
    with pytest.raises(ConfigError, match="--ghost-offset.*-10..10 m, got 50"):
        VideoOptions(ghost=True, ghost_offset=50.0).validate()
