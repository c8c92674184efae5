"""Static code-structure metrics of a Python package (standard library only; ast based).

Usage: python scripts/code_metrics.py [--package DIR] [--tests DIR] [--json] [--check]

The package is never imported: every number comes from parsing its files. Exit status 0, or
with --check 1 when there is an import cycle or a cross-module private import (the tests' ones
too when --tests is given); 2 when --package is not a folder.

Counting conventions:

* Modules: every ``*.py`` file under the package folder (``__init__.py`` and ``__main__.py``
  included; ``__pycache__`` and dot-folders skipped); ``pkg/__init__.py`` is module ``pkg``, a
  folder without ``__init__.py`` is a namespace package. Lines are physical lines (``wc -l``).
  A file that does not parse is listed and left out of every metric but the line counts.
* Import graph: every ``import``/``from ... import`` statement anywhere in a module (module
  level, in functions and methods, under ``if TYPE_CHECKING:``), relative imports resolved.
  ``from P import n`` is an edge to ``P.n`` when that is a module or subpackage of the package,
  else to ``P`` itself (its ``__init__``); ``import a.b.c`` is an edge to ``a.b.c`` only. The
  parent packages Python imports on the way are NOT edges (with them every submodule importing
  a sibling would share a cycle with its package ``__init__``), so a submodule is in a cycle
  with its package only when it imports a name from that ``__init__`` (``from . import
  __version__``) while the ``__init__`` imports it, directly or not. Edges are tagged
  module-level, deferred (in a function) or type-checking. ``importlib.import_module()`` calls
  are not statements and are not counted. Package imports that resolve to no file are listed.
* Cycles: strongly connected components of size > 1 (Tarjan). "import-time" marks a cycle that
  exists with module-level runtime edges alone; the others close only through deferred or
  TYPE_CHECKING imports.
* Private imports: ``from X import _n``, and ``m._n`` where ``m`` is bound by an import to a
  package module (``import a.b as m``, ``from a import b`` with ``b`` a module, ``import a``
  then ``a.b._n``); ``_n`` starts with ``_`` and is not a dunder, and ``X`` is not the importer.
  A private *module* name is allowed (``from . import _cli_shape``, ``jaxstiff._io.x``): only a
  name that is not a module counts. Aliases are per file, not per scope. Every alias of a
  statement and every attribute access is one occurrence; "distinct" counts each (importer,
  module, name) once. String access (``monkeypatch.setattr(m, "_n")``, ``getattr``) is not seen.
* Long functions: ``def``/``async def`` at any depth (methods and nested functions too), from
  the ``def`` line to ``end_lineno``, decorators excluded; listed when over 80 lines.
* Long modules: over 400 physical lines.
* Annotated parameters: positional-only, regular, keyword-only, ``*args`` and ``**kwargs`` of
  every ``def`` (lambdas excluded); the first parameter of a function defined directly in a
  class body is skipped when named ``self`` or ``cls`` (not for a ``@staticmethod``). Return
  annotations are not counted.

Against the figures reported earlier for the base (bb7511f), this script gives:

* 4 cycles, the same four; the shaping <-> solvers.trajectory one also holds ``jaxstiff``
  (``__init__``), since shaping imports ``__version__`` from it and the ``__init__`` imports
  shaping. None of the four is import-time: each closes through a deferred import.
* 38 private occurrences (37 distinct) for 32: the 32 are exactly the ``from X import _n``
  names; the other 6 are attribute reads (``csc._STATUS_NAMES`` in _cli_csc, ``_pgd._Ops``,
  ``_finish``, ``_clip`` twice, ``_pad`` in solvers.trajectory).
* 15 functions of >= 100 lines for 13: the two more are nested ``run`` closures
  (``_add_csc.run``, ``_add_shape.run``); without nested functions it is 13. (18 are over 80.)
* 9 modules over 500 lines for 7 (13 over 400): csc, sweep_config, shaping, solvers.pgd,
  sweep, stiffness, solvers.problem, results (518), plots (509). No line convention tried gives
  7 (non-blank lines give 5, code lines without comments and docstrings 4); leaving the
  solvers subpackage out does, so the earlier count probably covered top-level modules only.
* 12,834 lines in 38 modules, and 813 of 1,500 parameters annotated (54.2%): the same.
"""

from __future__ import annotations

import argparse
import ast
import json
import sys
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

LONG_FUNCTION = 80
LONG_MODULE = 400
EARLIER_LONG_FUNCTION = 100  # the threshold of the earlier figures, shown for comparison
EARLIER_LONG_MODULE = 500

KIND_MODULE = "module-level"
KIND_DEFERRED = "deferred"
KIND_TYPE_CHECKING = "type-checking"


# ------------------------------------------------------------------------------------ data
@dataclass
class SourceFile:
    """One parsed Python file."""

    name: str  # dotted module name; a package's __init__.py is the package itself
    path: Path
    is_package: bool
    lines: int
    tree: ast.Module | None
    error: str | None = None


@dataclass(frozen=True)
class Edge:
    """One import statement (alias) from a module to a module of the package."""

    importer: str
    target: str
    line: int
    kind: str


@dataclass(frozen=True)
class PrivateUse:
    """A private name of another package module, imported or read as an attribute."""

    importer: str
    module: str
    name: str
    line: int
    via: str  # "import" or "attribute"


@dataclass(frozen=True)
class FunctionInfo:
    """Size and parameter annotation counts of one function definition."""

    module: str
    qualname: str
    line: int
    lines: int
    params: int
    annotated: int
    nested: bool  # defined inside another function


@dataclass
class FileScan:
    """What the import scan of one file found."""

    edges: list[Edge] = field(default_factory=list)
    private: list[PrivateUse] = field(default_factory=list)
    unresolved: list[str] = field(default_factory=list)
    bindings: dict[str, str] = field(default_factory=dict)  # local name -> package module


# ------------------------------------------------------------------------------- discovery
def count_lines(text: str) -> int:
    """Physical lines, as ``wc -l`` counts them for a newline-terminated file."""
    return text.count("\n") + (1 if text and not text.endswith("\n") else 0)


def module_name(root: str, rel: Path) -> tuple[str, bool]:
    """Dotted module name of a file at ``rel`` inside package ``root``, and whether a package."""
    parts = [root, *rel.with_suffix("").parts]
    is_package = parts[-1] == "__init__"
    if is_package:
        parts = parts[:-1]
    return ".".join(parts), is_package


def read_source(path: Path, name: str, is_package: bool) -> SourceFile:
    """Read and parse one file; a file that does not parse keeps its line count and error."""
    text = path.read_text(encoding="utf-8", errors="replace")
    try:
        tree: ast.Module | None = ast.parse(text, filename=str(path))
        error = None
    except SyntaxError as exc:
        tree, error = None, f"{exc.msg} (line {exc.lineno})"
    return SourceFile(name, path, is_package, count_lines(text), tree, error)


def python_files(folder: Path) -> Iterator[Path]:
    """The ``*.py`` files under ``folder``, sorted, without caches and dot-folders."""
    for path in sorted(folder.rglob("*.py")):
        parts = path.relative_to(folder).parts
        if not any(p == "__pycache__" or p.startswith(".") for p in parts[:-1]):
            yield path


def discover(package_dir: Path) -> dict[str, SourceFile]:
    """All modules of the package, by dotted name."""
    root = package_dir.name
    found: dict[str, SourceFile] = {}
    for path in python_files(package_dir):
        name, is_package = module_name(root, path.relative_to(package_dir))
        found[name] = read_source(path, name, is_package)
    return found


# ------------------------------------------------------------------------- import scanning
def is_private(name: str) -> bool:
    """True for ``_x`` and ``__x`` names, false for dunders such as ``__version__``."""
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def is_type_checking(test: ast.expr) -> bool:
    """True for ``TYPE_CHECKING`` and ``<anything>.TYPE_CHECKING`` conditions."""
    if isinstance(test, ast.Name):
        return test.id == "TYPE_CHECKING"
    return isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"


class ImportCollector(ast.NodeVisitor):
    """Collects every import statement with its kind (module-level, deferred, type-checking)."""

    def __init__(self) -> None:
        """Start at module level, outside any ``if TYPE_CHECKING:``."""
        self.found: list[tuple[ast.Import | ast.ImportFrom, str]] = []
        self._depth = 0
        self._type_checking = 0

    def _kind(self) -> str:
        if self._type_checking:
            return KIND_TYPE_CHECKING
        return KIND_DEFERRED if self._depth else KIND_MODULE

    def visit_FunctionDef(self, node: ast.FunctionDef | ast.AsyncFunctionDef) -> None:
        """Imports in a function body run when it is called: deferred."""
        self._depth += 1
        self.generic_visit(node)
        self._depth -= 1

    def visit_AsyncFunctionDef(self, node: ast.AsyncFunctionDef) -> None:
        """The same as for ``def``."""
        self.visit_FunctionDef(node)

    def visit_If(self, node: ast.If) -> None:
        """The body of ``if TYPE_CHECKING:`` holds type-checking imports; its else does not."""
        if not is_type_checking(node.test):
            self.generic_visit(node)
            return
        self._type_checking += 1
        for stmt in node.body:
            self.visit(stmt)
        self._type_checking -= 1
        for stmt in node.orelse:
            self.visit(stmt)

    def visit_Import(self, node: ast.Import) -> None:
        """Record an ``import`` statement."""
        self.found.append((node, self._kind()))

    def visit_ImportFrom(self, node: ast.ImportFrom) -> None:
        """Record a ``from ... import`` statement."""
        self.found.append((node, self._kind()))


@dataclass(frozen=True)
class Context:
    """Where a file sits: its name for reports, its package for relative imports."""

    importer: str  # dotted module name (package files) or a path (test files)
    package: str | None  # package that relative imports start from; None: not the package's
    root: str  # the scanned package's top-level name
    modules: frozenset[str]  # the package's modules and folders, by dotted name


def from_base(node: ast.ImportFrom, ctx: Context) -> str | None:
    """The dotted module a ``from`` statement reads from, or None when it is not the package's."""
    if node.level == 0:
        mod = node.module or ""
        return mod if mod == ctx.root or mod.startswith(ctx.root + ".") else None
    if ctx.package is None:
        return None
    parts = ctx.package.split(".")
    if node.level - 1 >= len(parts):
        return None
    base = ".".join(parts[: len(parts) - (node.level - 1)])
    return f"{base}.{node.module}" if node.module else base


def scan_from(node: ast.ImportFrom, kind: str, ctx: Context, out: FileScan) -> None:
    """Edges, bindings and private names of one ``from ... import`` statement."""
    base = from_base(node, ctx)
    if base is None:
        if node.level and ctx.package is not None:  # more dots than the package is deep
            out.unresolved.append(
                f"{ctx.importer}:{node.lineno} from {'.' * node.level}"
                f"{node.module or ''} import ... (above the top package)"
            )
        return
    for alias in node.names:
        sub = f"{base}.{alias.name}"
        if alias.name != "*" and sub in ctx.modules:
            out.edges.append(Edge(ctx.importer, sub, node.lineno, kind))
            out.bindings[alias.asname or alias.name] = sub
        elif base in ctx.modules:
            out.edges.append(Edge(ctx.importer, base, node.lineno, kind))
            if is_private(alias.name) and base != ctx.importer:
                out.private.append(PrivateUse(ctx.importer, base, alias.name, node.lineno, "import"))
        else:
            out.unresolved.append(
                f"{ctx.importer}:{node.lineno} from {'.' * node.level}{node.module or ''} import {alias.name}"
            )


def scan_import(node: ast.Import, kind: str, ctx: Context, out: FileScan) -> None:
    """Edges and bindings of one ``import a.b.c [as m]`` statement."""
    for alias in node.names:
        name = alias.name
        if name != ctx.root and not name.startswith(ctx.root + "."):
            continue
        if name not in ctx.modules:
            out.unresolved.append(f"{ctx.importer}:{node.lineno} import {name}")
            continue
        out.edges.append(Edge(ctx.importer, name, node.lineno, kind))
        if alias.asname:
            out.bindings[alias.asname] = name
        else:
            out.bindings[ctx.root] = ctx.root


def attribute_chain(node: ast.Attribute) -> tuple[str, list[str]] | None:
    """``a.b.c`` -> ("a", ["b", "c"]); None when the chain does not start at a plain name."""
    attrs: list[str] = []
    cur: ast.expr = node
    while isinstance(cur, ast.Attribute):
        attrs.append(cur.attr)
        cur = cur.value
    if not isinstance(cur, ast.Name):
        return None
    return cur.id, attrs[::-1]


def scan_attributes(tree: ast.Module, ctx: Context, out: FileScan) -> None:
    """Private attributes read through names bound to package modules (``m._x``)."""
    inner = {id(n.value) for n in ast.walk(tree) if isinstance(n, ast.Attribute)}
    for node in ast.walk(tree):
        if not isinstance(node, ast.Attribute) or id(node) in inner:
            continue
        chain = attribute_chain(node)
        if chain is None or chain[0] not in out.bindings:
            continue
        cur = out.bindings[chain[0]]
        for attr in chain[1]:
            if f"{cur}.{attr}" in ctx.modules:
                cur = f"{cur}.{attr}"
                continue
            if is_private(attr) and cur != ctx.importer:
                out.private.append(PrivateUse(ctx.importer, cur, attr, node.lineno, "attribute"))
            break


def scan_file(tree: ast.Module, ctx: Context) -> FileScan:
    """Import edges, private-name uses and unresolved package imports of one file."""
    collector = ImportCollector()
    collector.visit(tree)
    out = FileScan()
    for node, kind in collector.found:
        if isinstance(node, ast.ImportFrom):
            scan_from(node, kind, ctx, out)
        else:
            scan_import(node, kind, ctx, out)
    scan_attributes(tree, ctx, out)
    return out


def known_names(modules: dict[str, SourceFile]) -> frozenset[str]:
    """Module names plus every folder on the way (namespace folders without __init__)."""
    names: set[str] = set()
    for name in modules:
        parts = name.split(".")
        names.update(".".join(parts[:i]) for i in range(1, len(parts) + 1))
    return frozenset(names)


# ---------------------------------------------------------------------------------- cycles
def tarjan(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components (Tarjan's algorithm, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []
    for start in sorted(graph):
        if start in index:
            continue
        work: list[tuple[str, Iterator[str]]] = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is None:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    components.append(pop_component(node, stack, on_stack))
            elif child not in index:
                index[child] = low[child] = len(index)
                stack.append(child)
                on_stack.add(child)
                work.append((child, iter(sorted(graph.get(child, ())))))
            elif child in on_stack:
                low[node] = min(low[node], index[child])
    return components


def pop_component(node: str, stack: list[str], on_stack: set[str]) -> list[str]:
    """Pop one finished component off Tarjan's stack."""
    component: list[str] = []
    while True:
        top = stack.pop()
        on_stack.discard(top)
        component.append(top)
        if top == node:
            return sorted(component)


def cycles_of(edges: Sequence[Edge], nodes: Sequence[str]) -> list[list[str]]:
    """The components of size > 1, largest first."""
    graph: dict[str, set[str]] = {n: set() for n in nodes}
    for e in edges:
        graph.setdefault(e.importer, set()).add(e.target)
        graph.setdefault(e.target, set())
    found = [c for c in tarjan(graph) if len(c) > 1]
    return sorted(found, key=lambda c: (-len(c), c))


def describe_cycle(members: list[str], edges: Sequence[Edge], eager: list[list[str]]) -> dict[str, Any]:
    """A cycle's members, whether it exists at import time, and its internal edges."""
    inside = set(members)
    links: dict[tuple[str, str], list[str]] = {}
    for e in edges:
        if e.importer in inside and e.target in inside and e.importer != e.target:
            where = links.setdefault((e.importer, e.target), [])
            if f"{e.kind} L{e.line}" not in where:
                where.append(f"{e.kind} L{e.line}")
    return {
        "members": members,
        "eager": any(set(c) <= inside for c in eager),
        "edges": [{"from": a, "to": b, "where": w} for (a, b), w in sorted(links.items())],
    }


# ------------------------------------------------------------------------------- functions
def is_staticmethod(node: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    """True when decorated with ``staticmethod`` (its first parameter is a real one)."""
    names = [
        d.id if isinstance(d, ast.Name) else d.attr if isinstance(d, ast.Attribute) else "" for d in node.decorator_list
    ]
    return "staticmethod" in names


class DefVisitor(ast.NodeVisitor):
    """Collects size and parameter annotation counts of every function definition."""

    def __init__(self, module: str) -> None:
        """Collect the definitions of module ``module``."""
        self.module = module
        self.found: list[FunctionInfo] = []
        self._names: list[str] = []
        self._in_class: list[bool] = [False]
        self._depth = 0  # enclosing functions

    def visit_ClassDef(self, node: ast.ClassDef) -> None:
        """Functions directly in a class body are methods."""
        self._names.append(node.name)
        self._in_class.append(True)
        self.generic_visit(node)
        self._in_class.pop()
        self._names.pop()

    def visit_FunctionDef(self, node: ast.FunctionDef | ast.AsyncFunctionDef) -> None:
        """Record one function, then its nested definitions."""
        args = node.args
        params = [*args.posonlyargs, *args.args, *args.kwonlyargs]
        params += [a for a in (args.vararg, args.kwarg) if a is not None]
        positional = [*args.posonlyargs, *args.args]
        if self._in_class[-1] and positional and positional[0].arg in ("self", "cls") and not is_staticmethod(node):
            params.remove(positional[0])
        qualname = ".".join([*self._names, node.name])
        lines = (node.end_lineno or node.lineno) - node.lineno + 1
        annotated = sum(p.annotation is not None for p in params)
        nested = self._depth > 0
        self.found.append(FunctionInfo(self.module, qualname, node.lineno, lines, len(params), annotated, nested))
        self._names.append(node.name)
        self._in_class.append(False)
        self._depth += 1
        self.generic_visit(node)
        self._depth -= 1
        self._in_class.pop()
        self._names.pop()

    def visit_AsyncFunctionDef(self, node: ast.AsyncFunctionDef) -> None:
        """The same as for ``def``."""
        self.visit_FunctionDef(node)


# --------------------------------------------------------------------------------- metrics
def package_imports(modules: dict[str, SourceFile], root: str) -> FileScan:
    """The import scan of every module of the package, merged."""
    names = known_names(modules)
    total = FileScan()
    for name, src in modules.items():
        if src.tree is None:
            continue
        package = name if src.is_package else name.rpartition(".")[0]
        scan = scan_file(src.tree, Context(name, package or None, root, names))
        total.edges += list(dict.fromkeys(scan.edges))  # one per statement and target
        total.private += scan.private
        total.unresolved += scan.unresolved
    return total


def private_report(uses: Sequence[PrivateUse]) -> dict[str, Any]:
    """Occurrences (sorted) and the number of distinct (importer, module, name) triples."""
    ordered = sorted(uses, key=lambda u: (u.importer, u.line, u.module, u.name))
    distinct = {(u.importer, u.module, u.name) for u in uses}
    return {"count": len(ordered), "distinct": len(distinct), "occurrences": [asdict(u) for u in ordered]}


def function_metrics(modules: dict[str, SourceFile]) -> dict[str, Any]:
    """Long functions and the share of annotated parameters."""
    infos: list[FunctionInfo] = []
    for name, src in modules.items():
        if src.tree is not None:
            visitor = DefVisitor(name)
            visitor.visit(src.tree)
            infos += visitor.found
    long = sorted((f for f in infos if f.lines > LONG_FUNCTION), key=lambda f: (-f.lines, f.module, f.line))
    params = sum(f.params for f in infos)
    annotated = sum(f.annotated for f in infos)
    return {
        "functions": len(infos),
        "long_functions": [asdict(f) for f in long],
        "long_function_count": len(long),
        "functions_at_least_earlier_threshold": sum(f.lines >= EARLIER_LONG_FUNCTION for f in infos),
        "not_nested_at_least_earlier_threshold": sum(f.lines >= EARLIER_LONG_FUNCTION and not f.nested for f in infos),
        "parameters": {
            "total": params,
            "annotated": annotated,
            "percent": round(100.0 * annotated / params, 1) if params else None,
        },
    }


def import_metrics(modules: dict[str, SourceFile], root: str) -> dict[str, Any]:
    """Cycles, type-checking imports, unresolved imports and private imports of the package."""
    scan = package_imports(modules, root)
    nodes = sorted(modules)
    cycles = cycles_of(scan.edges, nodes)
    eager = cycles_of([e for e in scan.edges if e.kind == KIND_MODULE], nodes)
    kinds = {k: sum(e.kind == k for e in scan.edges) for k in (KIND_MODULE, KIND_DEFERRED, KIND_TYPE_CHECKING)}
    tc_edges = [e for e in scan.edges if e.kind == KIND_TYPE_CHECKING]
    graph: dict[str, set[str]] = {n: set() for n in nodes}
    for e in scan.edges:
        graph.setdefault(e.importer, set()).add(e.target)
    return {
        "import_edges": kinds,
        "import_graph": {n: sorted(t) for n, t in sorted(graph.items())},
        "cycles": [describe_cycle(c, scan.edges, eager) for c in cycles],
        "eager_cycle_count": len(eager),
        "type_checking_imports": [f"{e.importer}:{e.line} -> {e.target}" for e in tc_edges],
        "unresolved_imports": sorted(scan.unresolved),
        "private_imports": private_report(scan.private),
    }


def tests_private(tests_dir: Path, root: str, modules: dict[str, SourceFile]) -> dict[str, Any]:
    """Private names of the package imported (or read as attributes) by the test files."""
    names = known_names(modules)
    uses: list[PrivateUse] = []
    errors: list[str] = []
    for path in python_files(tests_dir):
        label = str(path.relative_to(tests_dir.parent))
        src = read_source(path, label, False)
        if src.tree is None:
            errors.append(f"{label}: {src.error}")
            continue
        uses += scan_file(src.tree, Context(label, None, root, names)).private
    return {**private_report(uses), "parse_errors": errors}


def collect(package_dir: Path, tests_dir: Path | None) -> dict[str, Any]:
    """Every metric of the package (and of the tests' private imports when asked)."""
    modules = discover(package_dir)
    root = package_dir.name
    sizes = sorted(((s.lines, n) for n, s in modules.items()), key=lambda t: (-t[0], t[1]))
    report: dict[str, Any] = {
        "package": str(package_dir),
        "modules": len(modules),
        "total_lines": sum(s.lines for s in modules.values()),
        "parse_errors": [f"{n}: {s.error}" for n, s in sorted(modules.items()) if s.error],
        **import_metrics(modules, root),
        **function_metrics(modules),
        "long_modules": [{"module": n, "lines": k} for k, n in sizes if k > LONG_MODULE],
        "modules_over_earlier_threshold": sum(k > EARLIER_LONG_MODULE for k, _ in sizes),
    }
    if tests_dir is not None:
        report["tests_private_imports"] = tests_private(tests_dir, root, modules)
    return report


# ---------------------------------------------------------------------------------- output
def cycle_lines(report: dict[str, Any]) -> list[str]:
    """The table section for import cycles and the import edges behind them."""
    cycles = report["cycles"]
    out = [
        (
            f"Import cycles (SCCs > 1; a package name stands for its __init__): {len(cycles)}   "
            f"(import-time, module-level edges only: {report['eager_cycle_count']})"
        )
    ]
    for i, cyc in enumerate(cycles, 1):
        tag = "import-time" if cyc["eager"] else "closed only by deferred/TYPE_CHECKING imports"
        out.append(f"  {i}. [{len(cyc['members'])}] {' <-> '.join(cyc['members'])}  ({tag})")
        out += [f"       {e['from']} -> {e['to']}: {', '.join(e['where'])}" for e in cyc["edges"]]
    edges = report["import_edges"]
    out.append("Import edges: " + ", ".join(f"{k} {v}" for k, v in edges.items()))
    tc = report["type_checking_imports"]
    out.append(f"TYPE_CHECKING imports (counted in the graph): {len(tc)}")
    out += [f"  {t}" for t in tc]
    unresolved = report["unresolved_imports"]
    out.append(f"Unresolved package imports: {len(unresolved)}")
    out += [f"  {u}" for u in unresolved]
    return out


def private_lines(title: str, section: dict[str, Any]) -> list[str]:
    """The table section for one list of cross-module private imports."""
    out = [f"{title}: {section['count']} occurrences, {section['distinct']} distinct"]
    for u in section["occurrences"]:
        out.append(f"  {u['importer']}:{u['line']} -> {u['module']}.{u['name']}  ({u['via']})")
    return out


def size_lines(report: dict[str, Any]) -> list[str]:
    """The table sections for long functions, long modules and annotated parameters."""
    out = [
        (
            f"Functions longer than {LONG_FUNCTION} lines: {report['long_function_count']} "
            f"(>= {EARLIER_LONG_FUNCTION} lines: {report['functions_at_least_earlier_threshold']}, "
            f"{report['not_nested_at_least_earlier_threshold']} of them not nested; "
            f"{report['functions']} functions in all)"
        )
    ]
    out += [f"  {f['lines']:5d}  {f['module']}:{f['line']} {f['qualname']}" for f in report["long_functions"]]
    out.append(
        f"Modules longer than {LONG_MODULE} lines: {len(report['long_modules'])} "
        f"(> {EARLIER_LONG_MODULE} lines: {report['modules_over_earlier_threshold']})"
    )
    out += [f"  {m['lines']:5d}  {m['module']}" for m in report["long_modules"]]
    p = report["parameters"]
    percent = "n/a" if p["percent"] is None else f"{p['percent']}%"
    out.append(f"Annotated parameters: {p['annotated']} / {p['total']} ({percent})")
    return out


def format_table(report: dict[str, Any]) -> str:
    """The whole report as plain text."""
    out = [f"Package: {report['package']}", f"Modules: {report['modules']}   Lines (physical): {report['total_lines']}"]
    if report["parse_errors"]:
        out.append(f"Files that do not parse (skipped): {len(report['parse_errors'])}")
        out += [f"  {e}" for e in report["parse_errors"]]
    out += cycle_lines(report)
    out += private_lines("Cross-module private imports", report["private_imports"])
    out += size_lines(report)
    if "tests_private_imports" in report:
        out += private_lines("Tests' private imports from the package", report["tests_private_imports"])
    return "\n".join(out)


def check_failures(report: dict[str, Any]) -> list[str]:
    """What ``--check`` fails on: cycles and cross-module private imports (tests' too, if given)."""
    failures = [f"import cycle: {' <-> '.join(c['members'])}" for c in report["cycles"]]
    sections = [report["private_imports"], report.get("tests_private_imports", {"occurrences": []})]
    for section in sections:
        failures += [
            f"private import: {u['importer']}:{u['line']} -> {u['module']}.{u['name']}" for u in section["occurrences"]
        ]
    return failures


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    """Command-line options."""
    default = Path(__file__).resolve().parent.parent / "jaxstiff"
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--package", type=Path, default=default, help=f"package folder (default {default})")
    parser.add_argument("--tests", type=Path, default=None, help="tests folder: report its private imports")
    parser.add_argument("--json", action="store_true", help="print the metrics as JSON")
    parser.add_argument(
        "--check", action="store_true", help="exit 1 when there is an import cycle or a cross-module private import"
    )
    return parser.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Print the metrics; with --check, exit 1 on cycles or private imports."""
    args = parse_args(argv)
    package = args.package.resolve()
    if not package.is_dir():
        print(f"not a folder: {package}", file=sys.stderr)
        return 2
    report = collect(package, args.tests.resolve() if args.tests else None)
    print(json.dumps(report, indent=2) if args.json else format_table(report))
    if not args.check:
        return 0
    failures = check_failures(report)
    for failure in failures:
        print(f"check: {failure}", file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
