"""Motion Script: a tiny language that steers a multi-layered motion graph.

One command per line (``#`` starts a comment)::

    command  := clause ("for" NUMBER ("sec" | "s"))?
    clause   := target (("with" | "and") target)?
    target   := WORD | LAYER WORD        e.g. WALK, Upper-Body TALK

``X with Y``: X plays on the full body while Y plays on a child layer (the layer named in Y, or the
nearest child layer that has a Y motion). ``X and Y``: one motion tagged with both, else split across
layers like ``with``. Syntax errors name the line and column.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from bipedsim.errors import BipedsimError
from bipedsim.synthesis.graph.build import FULL


class ScriptError(BipedsimError):
    def __init__(self, message: str, line: int, column: int, source: str = "<script>") -> None:
        self.line, self.column = line, column
        super().__init__(f"{source}:{line}:{column}: {message}")


@dataclass(frozen=True)
class Target:
    tag: str
    layer: str | None = None


@dataclass(frozen=True)
class Command:
    main: Target
    extra: Target | None = None
    mode: str | None = None  #: "with" | "and"
    seconds: float | None = None
    line: int = 0


#: Most commands a script may hold: a script is written by hand, a command a line (a thousand lines
#: play for an hour or more).
MAX_SCRIPT_COMMANDS = 10_000
#: Longest total of the ``for N sec`` durations (s): a day of motion. What a script may really play is
#: bounded in frames by the player (:data:`bipedsim.synthesis.graph.player.MAX_PLAY_FRAMES`).
MAX_SCRIPT_SECONDS = 86_400.0

_TOKEN = re.compile(r"\s*(?:(?P<num>\d+(?:\.\d+)?)|(?P<word>[A-Za-z_][A-Za-z0-9_\-]*))")
KEYWORDS = {"with", "and", "for", "sec", "s", "secs", "seconds"}


def parse(text: str, source: str = "<script>", layers: tuple[str, ...] = ()) -> list[Command]:
    """Parse a script. ``layers``: known layer names (so ``Upper-Body TALK`` targets a layer; a
    second target ``with|and WORD TAG`` whose WORD is none of them is refused naming the parts)."""
    known = {name.lower(): name for name in layers}
    out: list[Command] = []
    total_s = 0.0
    # lines end at a newline (a carriage return before it dropped), as an editor counts them
    for ln, raw in enumerate(text.split("\n"), 1):
        line = raw.removesuffix("\r").split("#", 1)[0]
        if not line.strip():
            continue
        if len(out) >= MAX_SCRIPT_COMMANDS:
            raise ScriptError(f"more than {MAX_SCRIPT_COMMANDS} commands; split the script", ln, 1, source)
        toks: list[tuple[str, str, int]] = []
        pos = 0
        while pos < len(line):
            if line[pos:].strip() == "":
                break
            m = _TOKEN.match(line, pos)
            if not m or m.end() == pos:
                col = pos + (len(line[pos:]) - len(line[pos:].lstrip())) + 1
                raise ScriptError(f"unexpected character {line[col - 1]!r}", ln, col, source)
            kind = "num" if m.group("num") else "word"
            text_ = m.group(kind)
            toks.append((kind, text_, m.start(kind) + 1))
            pos = m.end()
        cmd = _command(toks, ln, source, known, len(line))
        total_s += cmd.seconds or 0.0
        if total_s > MAX_SCRIPT_SECONDS:
            col = next((c for kind, _, c in toks if kind == "num"), 1)
            raise ScriptError(f"the durations add up to {total_s:.6g} s by this line, more than "
                              f"{MAX_SCRIPT_SECONDS:g} s (a day)", ln, col, source)
        out.append(cmd)
    if not out:
        raise ScriptError("the script has no commands", 1, 1, source)
    return out


def _command(toks: list[tuple[str, str, int]], ln: int, source: str, known: dict[str, str], width: int) -> Command:
    i = 0

    def err(msg: str, col: int | None = None) -> ScriptError:
        return ScriptError(msg, ln, col if col is not None else (toks[i][2] if i < len(toks) else width + 1), source)

    def no_part(word: str) -> str:
        parts = [name for name in known.values() if name != FULL]
        if not known:
            return f"no part {word!r}; no layers are known"
        return (f"no part {word!r}; the graph's parts: {', '.join(parts)}" if parts
                else f"no part {word!r}; the graph has no part layers")

    def target(second: bool = False) -> Target:
        nonlocal i
        if i >= len(toks):
            raise err("expected a motion name or tag")
        kind, word, _ = toks[i]
        if kind != "word" or word.lower() in KEYWORDS:
            raise err(f"expected a motion name or tag, got {word!r}")
        i += 1
        if word.lower() in known:
            if i >= len(toks) or toks[i][0] != "word" or toks[i][1].lower() in KEYWORDS:
                raise err(f"expected a tag after layer {known[word.lower()]!r}")
            tag = toks[i][1]
            i += 1
            return Target(tag=tag.upper(), layer=known[word.lower()])
        if second and i < len(toks) and toks[i][0] == "word" and toks[i][1].lower() not in KEYWORDS:
            raise err(no_part(word), toks[i - 1][2])  # `with Lower-Body WAVE_HAND`: a part name mistyped
        return Target(tag=word.upper())

    main = target()
    extra, mode, seconds = None, None, None
    if i < len(toks) and toks[i][1].lower() in ("with", "and"):
        mode = toks[i][1].lower()
        i += 1
        extra = target(second=True)
    if i < len(toks) and toks[i][1].lower() == "for":
        i += 1
        if i >= len(toks) or toks[i][0] != "num":
            raise err("expected a number of seconds after 'for'")
        seconds = float(toks[i][1])
        if seconds <= 0:
            raise err("duration must be positive")
        if seconds > MAX_SCRIPT_SECONDS:
            raise err(f"duration {toks[i][1][:20]} s is longer than {MAX_SCRIPT_SECONDS:g} s (a day)")
        i += 1
        if i < len(toks) and toks[i][1].lower() in ("sec", "s", "secs", "seconds"):
            i += 1
        else:
            raise err("expected 'sec' after the number")
    if i < len(toks):
        hint = ""
        if i == 1 and toks[i][0] == "word":  # `Lower-Body WAVE_HAND`: a part name mistyped?
            hint = f" ({no_part(toks[0][1])})"
        raise err(f"unexpected {toks[i][1]!r}: a command is TARGET [with|and TARGET] [for N sec]{hint}")
    return Command(main=main, extra=extra, mode=mode, seconds=seconds, line=ln)
