"""The shape of the house (docs/architecture.md), checked so that a wrong arrow fails CI.

- the layers contract of ``pyproject.toml`` holds (``import-linter``);
- no import cycles between tmakit modules;
- no module imports another module's private (``_underscore``) name;
- functions stay under 80 lines, except the listed compiled kernels (a module is sized by its
  idea, not by a cap: docs/architecture.md).
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import grimp

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "tmakit"
MAX_FUNCTION_LINES = 80

#: Functions allowed over the limit, each with the reason.
LONG_FUNCTION_EXCEPTIONS: dict[str, str] = {}


def module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def python_files() -> list[Path]:
    return sorted(SRC.rglob("*.py"))


def test_layers_contract_is_kept():
    from importlinter.cli import lint_imports

    sys.path.insert(0, str(SRC.parent))
    assert lint_imports(config_filename=str(ROOT / "pyproject.toml")) == 0


def strongly_connected(edges: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components with more than one member."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in edges:
        if v not in index:
            visit(v)
    return found


def test_strongly_connected_finds_a_cycle():
    assert strongly_connected({"a": {"b"}, "b": {"a"}, "c": {"a"}}) == [["a", "b"]]
    assert strongly_connected({"a": {"b"}, "b": set()}) == []


def test_no_import_cycles():
    graph = grimp.build_graph("tmakit")
    edges = {m: set(graph.find_modules_directly_imported_by(m)) for m in graph.modules}
    assert strongly_connected(edges) == []


def private_imports(path: Path) -> list[str]:
    """``from X import _name`` where X is another tmakit module (relative or absolute)."""
    own = module_name(path)
    package = own if path.name == "__init__.py" else own.rpartition(".")[0]
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if not target.startswith("tmakit") or target == own:
                continue
            for alias in node.names:
                if alias.name.startswith("_") and not alias.name.startswith("__"):
                    found.append(f"{own}:{node.lineno} imports {alias.name} from {target}")
            if any(part.startswith("_") and not part.startswith("__")
                   for part in target.split(".")):
                found.append(f"{own}:{node.lineno} imports from private module {target}")
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("tmakit") and any(
                        p.startswith("_") and not p.startswith("__")
                        for p in alias.name.split(".")):
                    found.append(f"{own}:{node.lineno} imports private module {alias.name}")
    return found


def test_private_import_check_catches_one(tmp_path, monkeypatch):
    fake = SRC / "batch" / "ml.py"
    probe = tmp_path / "probe.py"
    probe.write_text("from .solver import _hidden\nfrom .solver import public\n")
    monkeypatch.setattr(sys.modules[__name__], "module_name", lambda p: "tmakit.batch.ml")
    found = private_imports(probe)
    assert found == ["tmakit.batch.ml:1 imports _hidden from tmakit.batch.solver"]
    assert fake.exists()


def test_no_cross_module_import_of_private_names():
    found = [f for path in python_files() for f in private_imports(path)]
    assert found == []


def long_functions(path: Path) -> list[tuple[str, int]]:
    rel = path.relative_to(SRC).as_posix()
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            first = min([node.lineno, *(d.lineno for d in node.decorator_list)])
            length = node.end_lineno - first + 1
            if length > MAX_FUNCTION_LINES:
                out.append((f"{rel}:{node.name}", length))
    return out


def test_function_size():
    found = [(name, n) for path in python_files() for name, n in long_functions(path)
             if name not in LONG_FUNCTION_EXCEPTIONS]
    assert found == [], "functions over the limit: " + ", ".join(f"{n} ({k})" for n, k in found)


def test_long_function_exceptions_are_still_needed():
    present = {name for path in python_files() for name, _ in long_functions(path)}
    stale = sorted(set(LONG_FUNCTION_EXCEPTIONS) - present)
    assert stale == [], f"no longer long, remove from the list: {stale}"


def test_public_face_is_complete_and_lazy():
    """Every public name resolves; the namespace holds the public names only (no ``Any``,
    ``annotations`` or ``import_module`` of its own); importing the package loads none of the
    numerical core (checked in a fresh interpreter)."""
    import subprocess
    import types

    import tmakit

    assert sorted(dir(tmakit)) == sorted(tmakit.__all__)
    for name in tmakit.__all__:
        assert getattr(tmakit, name) is not None
    for name in ("Any", "TYPE_CHECKING", "annotations", "import_module"):
        assert not hasattr(tmakit, name)
    own = [k for k, v in vars(tmakit).items() if not k.startswith("_")
           and k not in tmakit.__all__ and not isinstance(v, types.ModuleType)]
    assert own == [], f"tmakit's namespace has names not in its one list: {own}"
    assert (SRC / "py.typed").exists()
    code = ("import sys, tmakit; heavy = [m for m in ('numpy', 'scipy', 'pandas', 'pydantic') "
            "if m in sys.modules]; print(','.join(heavy))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, env={"PYTHONPATH": str(SRC.parent), "PATH": ""})
    assert out.stdout.strip() == ""
