"""The package's shape, checked from its source: the import graph of ``src/bipedsim`` (read from the AST,
nothing imported) has no cycles and no import from a lower layer of the pipeline into a higher one; imports
inside functions are only the listed lazy ones; no module is over :data:`MAX_MODULE_LINES` lines; and no
source, test or the README speaks of numbered issues or sessions (history belongs in CHANGELOG.md and git).
One check imports: the command line, in a fresh interpreter, starts without the heavy packages.
"""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SRC = REPO / "src"
PACKAGE = SRC / "bipedsim"

#: The pipeline a run takes, lowest first: a module may import from its own layer and the layers before
#: it, never from one after it. Each layer lists module-name prefixes; a module belongs to the layer of
#: its longest matching prefix (``bipedsim`` itself matches only the package's ``__init__``).
#: ``sim/outputs.py`` (a run folder's plots
#: and videos) and ``synthesis/world/scene.py`` (the world's video) render, and sit with ``render/``.
LAYERS: list[tuple[str, tuple[str, ...]]] = [
    ("base", ("bipedsim", "bipedsim.errors", "bipedsim.files", "bipedsim.config", "bipedsim.data")),
    ("motion", ("bipedsim.motion",)),
    ("model", ("bipedsim.model",)),
    ("reference", ("bipedsim.reference",)),
    ("control", ("bipedsim.control",)),
    ("sim", ("bipedsim.sim",)),
    ("experiments", ("bipedsim.experiments",)),
    ("synthesis", ("bipedsim.synthesis",)),
    ("envs", ("bipedsim.envs",)),
    ("render", ("bipedsim.render", "bipedsim.sim.outputs", "bipedsim.synthesis.world.scene")),
    ("api", ("bipedsim.api",)),
    ("cli", ("bipedsim.cli",)),
]

#: The only imports inside functions, per module: what each may import there (a third-party package's
#: top-level name, or a bipedsim module) and why. ``*``: anything.
LAZY_IMPORTS: dict[str, tuple[frozenset[str], str]] = {
    "bipedsim.cli.commands": (frozenset({"*"}), "each command imports its package when it runs: --help stays quick"),
    "bipedsim.files.writing": (frozenset({"numpy"}), "the command line imports files at start-up: --help stays quick"),
    "bipedsim.files.progress": (frozenset({"tqdm"}), "the command line imports files at start-up: --help stays quick"),
    "bipedsim.files.provenance": (frozenset({"mujoco", "numpy", "scipy"}),
                                  "the command line imports files at start-up: --help stays quick"),
    "bipedsim.render.plots": (frozenset({"matplotlib"}), "plotting is optional output (--plots)"),
    "bipedsim.render.video": (frozenset({"PIL", "imageio"}), "video writing is optional output"),
    "bipedsim.experiments.backends": (frozenset({"ray"}), "Ray is an optional extra"),
    "bipedsim.experiments.sweep_summary": (frozenset({"matplotlib"}), "the polar plot is optional output"),
    "bipedsim.experiments.tune.results": (frozenset({"matplotlib"}), "the convergence plot is optional output"),
    "bipedsim.synthesis.world.plot": (frozenset({"matplotlib"}), "the paths plot is optional output (--plot)"),
    "bipedsim.render.viewer": (frozenset({"mujoco"}), "mujoco.viewer (GLFW) loads only when a window opens"),
    "bipedsim.envs.track": (frozenset({"bipedsim.render.gl"}), "rgb_array frames (GL) load only when rendered"),
    "bipedsim.synthesis.world.run": (frozenset({"bipedsim.synthesis.world.scene", "bipedsim.synthesis.world.plot"}),
                           "the world video (GL rendering) and the paths plot load only when asked for"),
}

#: Packages the command line does not load at start-up, so that ``bipedsim --help`` stays quick: each
#: command imports its package when it runs.
HEAVY_AT_STARTUP = ("numpy", "scipy", "mujoco", "matplotlib", "yaml", "tqdm")

#: Longest module (lines) that still reads in one sitting.
MAX_MODULE_LINES = 500

#: Numbered issues or sessions in prose: "issue", "issues", "session" or "sessions" then a number, any case.
HISTORY = re.compile(r"\b(issue|session)s? +[0-9]", re.IGNORECASE)
#: Text files the history check reads.
TEXT_SUFFIXES = {".py", ".md", ".txt", ".yaml", ".yml", ".toml", ".cfg", ".ini", ".json"}


@dataclass(frozen=True)
class Import:
    source: str  #: the importing module
    target: str  #: a bipedsim module, or a third-party package's top-level name
    line: int
    in_function: bool


def module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _targets(node: ast.Import | ast.ImportFrom, source: str, is_package: bool, known: set[str]) -> list[str]:
    """The modules an import statement names: ``from a.b import c`` is module ``a.b.c`` when that is one,
    else ``a.b``; relative imports are resolved against ``source``; third-party ones by top-level name."""
    if isinstance(node, ast.Import):
        names = [a.name for a in node.names]
    else:
        base = node.module or ""
        if node.level:
            pkg = source.split(".") if is_package else source.split(".")[:-1]
            pkg = pkg[:len(pkg) - node.level + 1]
            base = ".".join(pkg + ([base] if base else []))
        names = [f"{base}.{a.name}" if f"{base}.{a.name}" in known else base for a in node.names]
    return [n if n.split(".")[0] == "bipedsim" else n.split(".")[0] for n in names]


def imports() -> Iterator[Import]:
    """Every import statement of the package: at module level (with those under ``if TYPE_CHECKING``)
    or inside a function."""
    mods = modules()
    known = set(mods)
    for name, path in mods.items():
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))

        def visit(node: ast.AST, in_function: bool, name: str = name, path: Path = path) -> Iterator[Import]:
            for child in ast.iter_child_nodes(node):
                inside = in_function or isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda)
                if isinstance(child, ast.Import | ast.ImportFrom):
                    if isinstance(child, ast.ImportFrom) and child.module == "__future__":
                        continue
                    for t in _targets(child, name, path.name == "__init__.py", known):
                        yield Import(name, t, child.lineno, in_function)
                yield from visit(child, inside)

        yield from visit(tree, False)


def layer_of(module: str) -> int:
    best, found = -1, None
    for i, (_, prefixes) in enumerate(LAYERS):
        for p in prefixes:
            hit = module == p if p == "bipedsim" else (module == p or module.startswith(p + "."))
            if hit and len(p) > best:
                best, found = len(p), i
    if found is None:
        raise AssertionError(f"{module} is in no layer: add it (or its package) to LAYERS in {Path(__file__).name}")
    return found


def internal(imps: Iterator[Import] | list[Import]) -> list[Import]:
    return [i for i in imps if i.target.split(".")[0] == "bipedsim"]


def _cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan), and modules importing themselves."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def connect(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                connect(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1 or v in edges.get(v, ()):
                out.append(sorted(comp))

    for v in sorted(edges):
        if v not in index:
            connect(v)
    return out


def test_every_module_is_in_a_layer() -> None:
    for name in modules():
        layer_of(name)


def test_the_import_graph_has_no_cycles() -> None:
    """No cycle among the package's modules, counting imports inside functions too: a cycle hidden in a
    function is still one."""
    edges: dict[str, set[str]] = {}
    for i in internal(list(imports())):
        edges.setdefault(i.source, set()).add(i.target)
    assert not _cycles(edges), f"import cycles: {_cycles(edges)}"


def test_no_module_imports_from_a_later_layer() -> None:
    """Module-level imports point down the pipeline (:data:`LAYERS`); an import inside a function may
    point up only where :data:`LAZY_IMPORTS` lists it."""
    upward = []
    for i in internal(list(imports())):
        if layer_of(i.target) <= layer_of(i.source):
            continue
        allowed = LAZY_IMPORTS.get(i.source, (frozenset(), ""))[0]
        if i.in_function and ("*" in allowed or i.target in allowed):
            continue
        upward.append(f"{i.source}:{i.line} ({LAYERS[layer_of(i.source)][0]}) imports {i.target} "
                      f"({LAYERS[layer_of(i.target)][0]})")
    assert not upward, "imports from a later layer:\n" + "\n".join(upward)


def test_imports_inside_functions_are_only_the_listed_lazy_ones() -> None:
    """An import inside a function keeps ``--help`` quick or an optional dependency lazy; any other
    belongs at the top of its module."""
    extra = []
    for i in imports():
        if not i.in_function:
            continue
        allowed = LAZY_IMPORTS.get(i.source, (frozenset(), ""))[0]
        if "*" not in allowed and i.target not in allowed:
            extra.append(f"{i.source}:{i.line} imports {i.target}")
    assert not extra, "imports inside functions (move them to the module's top):\n" + "\n".join(extra)


def test_lazy_import_list_names_only_what_is_there() -> None:
    """Every entry of :data:`LAZY_IMPORTS` is still used: a stale entry would let a new lazy import in."""
    used: dict[str, set[str]] = {}
    for i in imports():
        if i.in_function:
            used.setdefault(i.source, set()).add(i.target)
    stale = [f"{m}: {sorted(names - used.get(m, set()))}" for m, (names, _) in LAZY_IMPORTS.items()
             if "*" not in names and names - used.get(m, set())]
    assert not stale, "LAZY_IMPORTS entries no function imports: " + "; ".join(stale)


def test_the_command_line_starts_without_heavy_packages() -> None:
    """Importing :mod:`bipedsim.cli` (what ``bipedsim --help`` runs) loads none of :data:`HEAVY_AT_STARTUP`."""
    code = f"import sys, bipedsim.cli; print(' '.join(m for m in {HEAVY_AT_STARTUP!r} if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "", f"importing bipedsim.cli loads {out}"


def test_no_module_is_over_500_lines() -> None:
    long = {str(p.relative_to(PACKAGE)): n for p in sorted(PACKAGE.rglob("*.py"))
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_MODULE_LINES}
    assert not long, f"modules over {MAX_MODULE_LINES} lines: {long}"


def _text_files() -> Iterator[Path]:
    yield REPO / "README.md"
    for top in (SRC, REPO / "tests"):
        for p in sorted(top.rglob("*")):
            if p.is_file() and p.suffix in TEXT_SUFFIXES and not any(
                    part == "__pycache__" or part.endswith(".egg-info") for part in p.parts):
                yield p


def test_no_numbered_issue_or_session_in_src_tests_or_readme() -> None:
    """Code, tests and the README say what a value is and why, not when it was decided: issue and
    session numbers belong in CHANGELOG.md and git."""
    hits = []
    for p in _text_files():
        if not p.is_file():
            continue
        for n, line in enumerate(p.read_text(encoding="utf-8", errors="replace").splitlines(), start=1):
            if HISTORY.search(line):
                hits.append(f"{p.relative_to(REPO)}:{n}: {line.strip()[:100]}")
    assert not hits, "numbered issues or sessions:\n" + "\n".join(hits)
