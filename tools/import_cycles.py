"""The package's import cycles, from its source: every `import` and `from ... import` of a depthimpostor
module, at any depth in a file (a lazy import inside a function is still a cycle, only hidden), but
not those under `if TYPE_CHECKING:`, which never run, nor those of a module's own packages, which
Python imports before the module whatever it says. Prints each cycle; exits 1 if there is one.

    python3 tools/import_cycles.py
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "depthimpostor"


def module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path, known: set[str]) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    here = module_name(path).split(".")
    package = here if path.name == "__init__.py" else here[:-1]
    skipped: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skipped.update(id(child) for statement in node.body for child in ast.walk(statement))
    found: set[str] = set()
    for node in ast.walk(tree):
        if id(node) in skipped:
            continue
        if isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            target = ".".join(base + (node.module.split(".") if node.module else []))
            submodules = {f"{target}.{alias.name}" for alias in node.names} & known
            found.update(submodules)
            if len(submodules) < len(node.names):  # names defined by the module itself
                found.add(target)
        elif isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
    return found


def strong_components(graph: dict[str, list[str]]) -> dict[str, int]:
    """Each module's strongly connected component (Tarjan's algorithm)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    component: dict[str, int] = {}

    def connect(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        for target in graph[node]:
            if target not in index:
                connect(target)
                low[node] = min(low[node], low[target])
            elif target not in component:  # on the stack
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            while True:
                member = stack.pop()
                component[member] = index[node]
                if member == node:
                    break

    for name in graph:
        if name not in index:
            connect(name)
    return component


def main() -> int:
    modules = {module_name(path): path for path in PACKAGE.rglob("*.py")}
    # A module's own packages are imported before it whatever it imports: an edge to one is no cycle.
    graph = {name: sorted(m for m in imports(path, set(modules)) if m in modules and not name.startswith(m + "."))
             for name, path in modules.items()}
    # A cycle lies within one strongly connected component: the walk below follows the edges inside
    # one alone (it finds the same cycles; over every edge it walks every path of an acyclic graph
    # up to 12 long, which took 10 s of the tests' time).
    component = strong_components(graph)
    inside = {name: [m for m in targets if component[m] == component[name]] for name, targets in graph.items()}
    cycles: set[tuple[str, ...]] = set()

    def visit(node: str, stack: list[str]) -> None:
        for target in inside[node]:
            if target in stack:
                cycle = stack[stack.index(target):]
                turn = cycle.index(min(cycle))
                cycles.add(tuple(cycle[turn:] + cycle[:turn]))
            elif len(stack) < 12:
                visit(target, [*stack, target])

    for name in graph:
        visit(name, [name])
    for cycle in sorted(cycles):
        print(" -> ".join([*cycle, cycle[0]]))
    print(f"{len(cycles)} import cycles")
    return 1 if cycles else 0


if __name__ == "__main__":
    sys.exit(main())
