"""Issue 41's figures: where the rules of src/odolab live, printed as one table.

Run ``python tests/arch/figures.py`` (``--list`` adds each finding's place). It reads the source as
text and syntax trees; it imports nothing of odolab except for the import graph, which grimp
(import-linter's graph library) builds. Each figure, what it counts and its goal:

- ``motion-kind string tests``: comparisons (``==``, ``!=``, ``in``) of a motion-kind word
  ("rotation", "pivot", "straight", "translation", "square", "x", "y") with a name that holds a
  motion, outside the motion-kind module (a file named ``motion.py``). Goal 0.
- ``model-kind branches``: ``isinstance(..., <a class of models/>)`` and ``<...>.model.kind ==`` tests
  outside ``models/``. Goal 0.
- ``flag strings outside faces``: string constants (docstrings left out) that spell a command-line
  flag (``--word``) outside ``cli/`` and ``serve/``. Goal 0.
- ``wrap / unwrap / step copies``: definitions of an angle wrap, a counter unwrap and an odometry
  step, and inline copies of the wrap (``atan2(sin(a), cos(a))``, ``math.remainder(a, 2 pi)``).
  Goal 1 each (compiled twins are counted apart).
- ``import circles``: strongly connected groups of modules in the import graph (type-checking
  imports left out). Goal 0.
- ``functions over 80 lines``: goal at most 10, each with its reason in a ``# long: ...``
  comment just above its ``def`` (tests/arch/test_figures.py requires one).
- ``Any``: the name ``Any`` in code and quoted annotations (read from the syntax tree: imports
  and prose left out). Goal at most 150.
- ``duplicate pairs``: from the ``duplicates`` tool when it is on PATH (a developer's tool; CI
  prints "not measured"). Goal at most 50.
- ``public functions whose docstring says what they raise``: a figure to watch, no goal.
"""

from __future__ import annotations

import ast
import re
import shutil
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SRC = ROOT / "src" / "odolab"

MOTION_WORDS = {"rotation", "pivot", "straight", "translation", "square", "x", "y"}
# names that hold a motion kind (a variable, an attribute, or the .value of an enum member)
MOTION_NAMES = re.compile(r"(^|_)(motion|kind)$")
FLAG = re.compile(r"(?<![\w-])--[a-z][a-z0-9]+(-[a-z0-9]+)*")
WRAP_DEF = re.compile(r"^_?wrap(_angle|_pi|_to_pi)?s?$")
UNWRAP_DEF = re.compile(r"^_?unwrap(_counter|_counts|_ticks|_encoder)?s?$")
STEP_DEF = re.compile(r"^_?(odometry_step|step_pose|arc_step|integrate_step|chord_step)$")


@dataclass
class Figure:
    name: str
    goal: str
    places: list[str] = field(default_factory=list)
    value: int | None = None

    @property
    def count(self) -> int:
        return len(self.places) if self.value is None else self.value


def _files() -> Iterator[tuple[Path, ast.Module, str]]:
    for path in sorted(SRC.rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        yield path.relative_to(SRC), ast.parse(text), text


def _name_of(node: ast.AST) -> str:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        if node.attr == "value":
            return _name_of(node.value)
        return node.attr
    return ""


def _strings(node: ast.AST) -> list[str]:
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return [node.value]
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return [s for e in node.elts for s in _strings(e)]
    return []


def _docstring_nodes(tree: ast.Module) -> set[int]:
    out: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                out.add(id(body[0].value))
    return out


def _long_reason(text: str, node: ast.FunctionDef | ast.AsyncFunctionDef) -> str:
    """The reason a function over 80 lines gives: a ``# long: ...`` comment on the lines just
    above its ``def`` (or its decorators)."""
    lines = text.splitlines()
    first = min([node.lineno, *(d.lineno for d in node.decorator_list)]) - 1
    said: list[str] = []
    i = first - 1
    while i >= 0 and lines[i].strip().startswith("#"):
        said.insert(0, lines[i].strip().lstrip("#").strip())
        i -= 1
    joined = " ".join(said)
    return joined.split("long:", 1)[1].strip() if "long:" in joined else ""


def _is_wrap_inline(node: ast.Call) -> bool:
    f = _name_of(node.func)
    if f in ("atan2", "arctan2") and len(node.args) == 2:
        a, b = node.args
        return (
            isinstance(a, ast.Call)
            and isinstance(b, ast.Call)
            and _name_of(a.func) == "sin"
            and _name_of(b.func) == "cos"
            and ast.dump(a.args[0]) == ast.dump(b.args[0])
        )
    if f == "remainder" and len(node.args) == 2:
        return "pi" in ast.unparse(node.args[1])
    return False


def measure(*, with_duplicates: bool = True) -> list[Figure]:
    motion = Figure("motion-kind string tests", "0")
    model = Figure("model-kind branches outside models/", "0")
    flags = Figure("flag strings outside cli/ and serve/", "0")
    wrap = Figure("angle wrap copies", "1")
    unwrap = Figure("counter unwrap copies", "1")
    step = Figure("odometry step copies", "1")
    long_fns = Figure("functions over 80 lines", "<= 10")
    anys = Figure("Any in code", "<= 150")
    raises = Figure("public functions saying what they raise", "(watch)")
    model_classes = _model_classes()
    for rel, tree, text in _files():
        where = str(rel)
        in_face = rel.parts[0] in ("cli", "serve")
        jit = rel.name.endswith("_jit.py") or "kernels" in rel.name
        docs = _docstring_nodes(tree)
        for node in ast.walk(tree):
            line = getattr(node, "lineno", 0)
            if isinstance(node, ast.Compare) and rel.name != "motion.py":
                sides = [node.left, *node.comparators]
                words = {s for side in sides for s in _strings(side)}
                names = [_name_of(side) for side in sides]
                # a model's kind or a command's own kind is not a motion
                if (
                    words & MOTION_WORDS
                    and any(MOTION_NAMES.search(n) for n in names if n)
                    and not any(n.endswith("model") for n in names)
                    and not (words <= {"x", "y"} and not any("motion" in n for n in names))
                ):
                    motion.places.append(f"{where}:{line}")
            if (
                isinstance(node, ast.Call)
                and "models" not in rel.parts[:2]
                and _name_of(node.func) == "isinstance"
                and len(node.args) == 2
                and any(n in model_classes for n in _class_names(node.args[1]))
            ):
                model.places.append(f"{where}:{line}")
            if (
                isinstance(node, ast.Compare)
                and "models" not in rel.parts[:2]
                and isinstance(node.left, ast.Attribute)
                and node.left.attr == "kind"
                and "model" in ast.unparse(node.left.value).lower()
            ):
                model.places.append(f"{where}:{line}")
            if (
                not in_face
                and isinstance(node, ast.Constant)
                and isinstance(node.value, str)
                and id(node) not in docs
                and FLAG.search(node.value)
            ):
                flags.places.append(f"{where}:{line} {FLAG.search(node.value).group(0)}")  # type: ignore[union-attr]
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = (node.end_lineno or node.lineno) - node.lineno + 1
                if n > 80:
                    why = _long_reason(text, node)
                    long_fns.places.append(
                        f"{where}:{node.lineno} {node.name} ({n} lines; "
                        + (f"long: {why})" if why else "no reason given)")
                    )
                target = "compiled " if jit else ""
                if WRAP_DEF.match(node.name):
                    wrap.places.append(f"{target}{where}:{line} def {node.name}")
                if UNWRAP_DEF.match(node.name):
                    unwrap.places.append(f"{target}{where}:{line} def {node.name}")
                if STEP_DEF.match(node.name):
                    step.places.append(f"{target}{where}:{line} def {node.name}")
                if not node.name.startswith("_") and _is_public_module(rel):
                    doc = ast.get_docstring(node) or ""
                    if "Raises" in doc or "raises" in doc:
                        raises.places.append(f"{where}:{line} {node.name}")
            if isinstance(node, ast.Call) and _is_wrap_inline(node):
                wrap.places.append(f"inline {where}:{line}")
            if isinstance(node, ast.Call) and _name_of(node.func) == "sinc":
                step.places.append(f"inline sinc {where}:{line}")
        for node in ast.walk(tree):  # the name in code and in quoted annotations, not in prose
            if (isinstance(node, ast.Name) and node.id == "Any") or (
                isinstance(node, ast.Attribute) and node.attr == "Any"
            ):
                anys.places.append(f"{where}:{node.lineno}")
            elif (
                isinstance(node, ast.Constant)
                and isinstance(node.value, str)
                and id(node) not in docs
                and re.fullmatch(r"[\w\[\], .|]*\bAny\b[\w\[\], .|]*", node.value)
            ):
                anys.places.extend(
                    f"{where}:{node.lineno}" for _ in re.finditer(r"\bAny\b", node.value)
                )
    # compiled twins are counted apart: the goal is one plain copy each
    for fig in (wrap, unwrap, step):
        fig.value = sum(1 for p in fig.places if not p.startswith("compiled "))
    return [
        motion,
        model,
        flags,
        wrap,
        unwrap,
        step,
        _circles(),
        long_fns,
        anys,
        *([_duplicates()] if with_duplicates else []),
        raises,
    ]


def _model_classes() -> set[str]:
    """The classes defined in the models package (a kind, or a protocol every kind follows)."""
    home = next(p for p in (SRC / "core" / "models", SRC / "models") if p.is_dir())
    return {
        node.name
        for path in home.glob("*.py")
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
        if isinstance(node, ast.ClassDef)
    }


def _class_names(node: ast.AST) -> list[str]:
    if isinstance(node, ast.Tuple):
        return [n for e in node.elts for n in _class_names(e)]
    return [_name_of(node)]


def _is_public_module(rel: Path) -> bool:
    return not any(part.startswith("_") and part != "__init__.py" for part in rel.parts)


def _circles() -> Figure:
    fig = Figure("import circles", "0")
    try:
        import grimp
    except ImportError:  # pragma: no cover - import-linter brings grimp
        fig.places.append("not measured: grimp is not installed")
        fig.value = -1
        return fig
    sys.path.insert(0, str(SRC.parent))
    graph = grimp.build_graph("odolab", exclude_type_checking_imports=True, cache_dir=None)
    modules = sorted(graph.modules)
    edges = {m: graph.find_modules_directly_imported_by(m) for m in modules}
    for group in _strongly_connected(modules, edges):
        if len(group) > 1:
            fig.places.append(" <-> ".join(sorted(group)))
    return fig


def _strongly_connected(nodes: list[str], edges: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's algorithm, iterative (the graph is a few hundred modules)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    counter = 0
    for root in nodes:
        if root in index:
            continue
        work = [(root, iter(sorted(edges.get(root, ()))))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            v, it = work[-1]
            for w in it:
                if w not in edges:
                    continue
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(edges[w]))))
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    group = []
                    while True:
                        w = stack.pop()
                        on_stack.discard(w)
                        group.append(w)
                        if w == v:
                            break
                    out.append(group)
    return out


def _duplicates() -> Figure:
    fig = Figure("duplicate pairs in src", "<= 50")
    tool = shutil.which("duplicates")
    if tool is None:
        fig.places.append("not measured: the duplicates tool is not on PATH")
        fig.value = -1
        return fig
    out = subprocess.run(
        [tool, "--seconds", "300", "--most", "200"],
        cwd=SRC.parent,
        capture_output=True,
        text=True,
        check=False,
    ).stdout
    first = out.splitlines()[0] if out else ""
    m = re.match(r"(\d+) pairs", first)
    fig.value = int(m.group(1)) if m else (0 if first.startswith("no duplicates") else -1)
    fig.places.extend(line for line in out.splitlines()[1:] if line.startswith("D"))
    return fig


def main(argv: list[str]) -> int:
    figures = measure()
    width = max(len(f.name) for f in figures)
    for f in figures:
        shown = "not measured" if f.count < 0 else str(f.count)
        print(f"{f.name:<{width}}  {shown:>5}   goal {f.goal}")
        if "--list" in argv:
            for p in f.places:
                print(f"    {p}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
