"""The house: no import circle among the project's modules, counting the imports inside
functions and under ``TYPE_CHECKING`` (a circle dodged by a late import is still a
circle), and no folder of the packages holding more than ``MAX_MODULES`` modules."""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("fem", "identify", "designer", "studies", "benchmarks")
#: Modules (``__init__`` included) one folder of fem, identify or designer may hold directly.
MAX_MODULES = 16


def project_modules(root: Path = ROOT, packages=PACKAGES) -> dict[str, tuple[Path, bool]]:
    """Dotted module name -> (file, is a package's ``__init__``)."""
    modules = {}
    for package in packages:
        for path in (root / package).rglob("*.py"):
            parts = list(path.relative_to(root).with_suffix("").parts)
            is_package = parts[-1] == "__init__"
            modules[".".join(parts[:-1] if is_package else parts)] = (path, is_package)
    return modules


def import_graph(modules) -> dict[str, set[str]]:
    """Module -> the project modules it imports anywhere in its file (``from P import m``
    counts as importing ``P.m`` when ``m`` is a module, else ``P``)."""

    def known(name: str) -> str | None:
        while name and name not in modules:
            name = name.rpartition(".")[0]
        return name or None

    graph = {}
    for name, (path, is_package) in modules.items():
        here = name.split(".") if is_package else name.split(".")[:-1]
        targets = set()
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                targets |= {known(alias.name) for alias in node.names}
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    base = ".".join(
                        here[: len(here) - node.level + 1] + ([node.module] if node.module else [])
                    )
                targets |= {
                    known(f"{base}.{alias.name}") if f"{base}.{alias.name}" in modules else known(base)
                    for alias in node.names
                }
        graph[name] = targets - {None, name}
    return graph


def cycles(graph) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while not component or component[-1] != v:
                component.append(stack.pop())
                on_stack.discard(component[-1])
            if len(component) > 1:
                found.append(sorted(component))

    for v in graph:
        if v not in index:
            visit(v)
    return found


def test_the_walk_sees_a_circle():
    """The detector finds a circle that only a function-level import closes."""
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert cycles(graph) == [["a", "b", "c"]]


def test_the_graph_counts_late_and_relative_imports(tmp_path):
    """A circle closed by a relative import inside a function of a subpackage is found."""
    (tmp_path / "pkg" / "sub").mkdir(parents=True)
    for name in ("pkg/__init__.py", "pkg/sub/__init__.py", "pkg/c.py"):
        (tmp_path / name).write_text("")
    (tmp_path / "pkg" / "a.py").write_text("from .sub import b\n")
    (tmp_path / "pkg" / "sub" / "b.py").write_text(
        "def f():\n    from .. import a\n    from pkg.c import x\n"
    )
    graph = import_graph(project_modules(tmp_path, ("pkg",)))
    assert graph["pkg.sub.b"] == {"pkg.a", "pkg.c"}
    assert cycles(graph) == [["pkg.a", "pkg.sub.b"]]


def test_no_import_circles():
    found = cycles(import_graph(project_modules()))
    assert not found, "import circles: " + "; ".join(" <-> ".join(c) for c in found)


def test_no_folder_holds_more_than_max_modules():
    sizes = {
        str(init.parent.relative_to(ROOT)): len(list(init.parent.glob("*.py")))
        for package in ("fem", "identify", "designer")
        for init in (ROOT / package).rglob("__init__.py")
    }
    assert len(sizes) >= 10 and all(sizes.values())
    assert {folder: n for folder, n in sizes.items() if n > MAX_MODULES} == {}
