"""Every public function, method and class of tmakit carries a numpydoc docstring with its sections.

Issue 10 item 9: a docstring on everything public; a ``Parameters`` section naming every
parameter (for a class: those of its ``__init__``, or its dataclass / named-tuple fields as
``Parameters`` or ``Attributes``); a ``Returns`` (or ``Yields``) section when the annotated
return is not ``None``. The walk is over the source with :mod:`ast`, so a new undocumented
public function fails here before review.

Public means (issue 27 item 2): exported by the ``__all__`` of ``tmakit`` or of one of its
packages, or a method without a leading underscore of an exported class; functions nested in
functions are locals and not public.  The CLI's public face is the ``tma`` command (its help and
docs/), so ``cli/``'s helpers are private too.  Everything else is a private helper, whose
docstring may be its one-line summary. Properties are
documented as attributes (their one-line summary), so they need no ``Returns``; setters and
``@overload`` stubs are documented on the property / the implementation.  Private ``_name``
parameters and ``init=False`` / ``ClassVar`` fields are not part of the public signature.

An override of a base-class method may leave its sections to the base, but only when the
base method (found by name among tmakit's classes) is itself complete.

``Raises``: an exception class a public function raises itself (a ``raise`` in its own body,
not caught there by an enclosing ``try``) is named in its ``Raises`` section.

``References``: every module that docs/references.md credits with taking something from one
of the papers cites it (author, year, section / equation) in its module docstring or in the
``References`` section of a definition (private helpers keep theirs), so the citation sits
where the paper is implemented.
"""

from __future__ import annotations

import ast
import functools
import importlib.util
import pkgutil
import re
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "tmakit"

#: Explicit exemptions, ``"path:qualname"`` → reason. Keep it short.
EXEMPT: dict[str, str] = {}

SECTION_RE = re.compile(r"^(\s*)([A-Z][A-Za-z ]+)\n\1-{3,}\s*$", re.MULTILINE)


def sections(doc: str) -> dict[str, str]:
    """Numpydoc sections of ``doc``: title → body text."""
    found = list(SECTION_RE.finditer(doc))
    out: dict[str, str] = {}
    for i, m in enumerate(found):
        end = found[i + 1].start() if i + 1 < len(found) else len(doc)
        out[m.group(2).strip()] = doc[m.end():end]
    return out


def documented_names(body: str) -> set[str]:
    """Names listed in a Parameters / Attributes section (``a, b : float`` lines)."""
    lines = [ln for ln in body.splitlines() if ln.strip()]
    if not lines:
        return set()
    indent = min(len(ln) - len(ln.lstrip()) for ln in lines)
    names: set[str] = set()
    for ln in lines:
        if len(ln) - len(ln.lstrip()) != indent:
            continue
        head = ln.split(" : ")[0] if " : " in ln else ln.rstrip(":")
        for name in head.split(","):
            names.add(name.strip().lstrip("*"))
    return names


def is_none(annotation: ast.expr | None) -> bool:
    """Whether a return annotation says the function returns nothing."""
    if annotation is None:
        return True  # ruff's ANN rules require annotations on public functions
    text = ast.unparse(annotation).strip("'\"")
    return text in {"None", "NoReturn", "Never", "typing.NoReturn"}


def decorator_names(node: ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef) -> set[str]:
    """Bare names of a node's decorators (``@dataclass(frozen=True)`` → ``dataclass``)."""
    names = set()
    for d in node.decorator_list:
        target = d.func if isinstance(d, ast.Call) else d
        names.add(ast.unparse(target).split(".")[-1])
    return names


def parameters(fn: ast.FunctionDef | ast.AsyncFunctionDef, method: bool) -> list[str]:
    """Parameter names of ``fn``, less ``self`` / ``cls`` and private ``_name`` ones."""
    a = fn.args
    names = [x.arg for x in (*a.posonlyargs, *a.args, *a.kwonlyargs)]
    names += [x.arg for x in (a.vararg, a.kwarg) if x is not None]
    if method and names and names[0] in {"self", "cls"} and "staticmethod" not in (
            decorator_names(fn)):
        names = names[1:]
    return [n for n in names if not n.startswith("_")]


@dataclass
class Item:
    """One public definition to check."""

    where: str  # "path:qualname"
    node: ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef
    cls: ast.ClassDef | None  # the class a method belongs to


def public_module(path: Path) -> bool:
    """Whether a file is a public module: no ``_name`` part (``__init__`` is the package)."""
    parts = path.relative_to(SRC).with_suffix("").parts
    return not any(p.startswith("_") and p != "__init__" for p in parts)


#: Modules (not packages) whose ``__all__`` is public API: docs/ teaches importing from them.
PUBLIC_MODULES = ["tmakit.batch.manoeuvre"]


def exported() -> set[str]:
    """``path:qualname`` of every tmakit object a package's ``__all__`` exports."""
    import tmakit

    packages = ["tmakit"] + [m.name for m in pkgutil.walk_packages(tmakit.__path__, "tmakit.")
                             if m.ispkg] + PUBLIC_MODULES
    out: set[str] = set()
    installed = Path(tmakit.__file__).resolve().parent
    for name in packages:
        try:
            package = importlib.import_module(name)
        except ImportError:   # an optional extra (interop) not installed
            continue
        for attr in getattr(package, "__all__", ()):
            obj = getattr(package, attr, None)
            module, qual = getattr(obj, "__module__", None), getattr(obj, "__qualname__", None)
            if isinstance(module, str) and module.startswith("tmakit") and isinstance(qual, str):
                origin = Path(importlib.util.find_spec(module).origin)
                # relative to the package imported: an installed copy, or src/ itself
                out.add(f"{origin.relative_to(installed).as_posix()}:{qual}")
    return out


def walk(path: Path, tree: ast.Module, public: set[str]) -> list[Item]:
    """Public functions, classes and methods of one module."""
    rel = path.relative_to(SRC).as_posix()
    items: list[Item] = []

    def visit(body: list[ast.stmt], prefix: str, cls: ast.ClassDef | None) -> None:
        for node in body:
            if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                continue
            if node.name.startswith("_"):
                continue
            where = f"{rel}:{prefix}{node.name}"
            if cls is None and where not in public:
                continue
            items.append(Item(where, node, cls))
            if isinstance(node, ast.ClassDef):
                visit(node.body, f"{prefix}{node.name}.", node)

    visit(tree.body, "", None)
    return items


@functools.cache
def parsed() -> dict[Path, ast.Module]:
    """Every module of the package, parsed once a process (the tests only read the trees)."""
    return {path: ast.parse(path.read_text(), filename=str(path))
            for path in sorted(SRC.rglob("*.py"))}


@functools.cache
def load() -> tuple[list[Item], dict[str, list[ast.ClassDef]]]:
    """All public items, and every tmakit class by name (for base-class look-up).

    Walked once a process: three tests read it.
    """
    items: list[Item] = []
    classes: dict[str, list[ast.ClassDef]] = {}
    public = exported()
    for path, tree in parsed().items():
        for node in ast.walk(tree):
            if isinstance(node, ast.ClassDef):
                classes.setdefault(node.name, []).append(node)
        if public_module(path):
            items.extend(walk(path, tree, public))
    return items, classes


def class_fields(node: ast.ClassDef) -> list[str] | None:
    """Public init fields of a dataclass / NamedTuple / TypedDict, else None."""
    bases = {ast.unparse(b).split(".")[-1] for b in node.bases}
    if not ("dataclass" in decorator_names(node) or bases & {"NamedTuple", "TypedDict"}):
        return None
    fields = []
    for stmt in node.body:
        if (isinstance(stmt, ast.AnnAssign) and isinstance(stmt.target, ast.Name)
                and not stmt.target.id.startswith("_")
                and "ClassVar" not in ast.unparse(stmt.annotation)
                and "init=False" not in ast.unparse(stmt.value or ast.Constant(None))):
            fields.append(stmt.target.id)
    return fields


def method(cls: ast.ClassDef, name: str) -> ast.FunctionDef | ast.AsyncFunctionDef | None:
    """The method ``name`` defined in the body of ``cls``."""
    for stmt in cls.body:
        if isinstance(stmt, ast.FunctionDef | ast.AsyncFunctionDef) and stmt.name == name:
            return stmt
    return None


#: Raised for control flow, not an error a caller handles.
CONTROL_FLOW = {"SystemExit", "Exit", "NotImplementedError", "StopIteration"}
_SCOPES = (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda, ast.ClassDef)


def raised_here(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> set[str]:
    """Exception classes ``fn`` raises in its own body and does not catch itself."""
    found: set[str] = set()

    def visit(node: ast.AST, caught: frozenset[str]) -> None:
        if isinstance(node, _SCOPES):  # a nested function raises when it runs, not here
            return
        if isinstance(node, ast.Raise) and node.exc is not None:
            target = node.exc.func if isinstance(node.exc, ast.Call) else node.exc
            name = ast.unparse(target).split(".")[-1]
            if name[:1].isupper() and not caught & {name, "*", "Exception"}:
                found.add(name)
        if isinstance(node, ast.Try):
            names = set()
            for h in node.handlers:
                types = h.type.elts if isinstance(h.type, ast.Tuple) else [h.type]
                names |= {"*" if t is None else ast.unparse(t).split(".")[-1] for t in types}
            for stmt in node.body:
                visit(stmt, caught | names)
            for stmt in (*node.handlers, *node.orelse, *node.finalbody):
                visit(stmt, caught)
            return
        for child in ast.iter_child_nodes(node):
            visit(child, caught)

    for stmt in fn.body:
        visit(stmt, frozenset())
    return found - CONTROL_FLOW


def function_problems(fn: ast.FunctionDef | ast.AsyncFunctionDef, is_method: bool) -> list[str]:
    """What the docstring of a function or method is missing."""
    decos = decorator_names(fn)
    if decos & {"setter", "deleter", "overload"}:
        return []  # documented on the property / the implementation
    doc = ast.get_docstring(fn)
    if not doc:
        return ["no docstring"]
    if decos & {"property", "cached_property"}:
        return []
    secs = sections(doc)
    problems = []
    params = parameters(fn, is_method)
    if params:
        missing = set(params) - documented_names(secs.get("Parameters", ""))
        if missing:
            problems.append(f"Parameters section lacks {sorted(missing)}")
    if not is_none(fn.returns) and not ({"Returns", "Yields"} & secs.keys()):
        problems.append("no Returns/Yields section")
    unnamed = {e for e in raised_here(fn) if e not in secs.get("Raises", "")}
    if unnamed:
        problems.append(f"Raises section lacks {sorted(unnamed)}")
    return problems


def class_problems(node: ast.ClassDef) -> list[str]:
    """What the docstring of a class is missing."""
    doc = ast.get_docstring(node)
    if not doc:
        return ["no docstring"]
    secs = sections(doc)
    init = method(node, "__init__")
    if init is not None:
        params = parameters(init, True)
        init_doc = sections(ast.get_docstring(init) or "")
        have = documented_names(secs.get("Parameters", "")) | documented_names(
            init_doc.get("Parameters", ""))
    else:
        params = class_fields(node) or []
        have = documented_names(secs.get("Parameters", "")) | documented_names(
            secs.get("Attributes", ""))
    missing = set(params) - have
    return [f"Parameters/Attributes lack {sorted(missing)}"] if missing else []


def base_documents(item: Item, classes: dict[str, list[ast.ClassDef]], seen: set[str]) -> bool:
    """Whether a tmakit base class of ``item.cls`` has a complete docstring for the method."""
    assert item.cls is not None
    for base in item.cls.bases:
        name = ast.unparse(base).split("[")[0].split(".")[-1]
        if name in seen:
            continue
        seen.add(name)
        for cand in classes.get(name, []):
            fn = method(cand, item.node.name)
            if fn is not None and not function_problems(fn, True):
                return True
            if base_documents(Item(item.where, item.node, cand), classes, seen):
                return True
    return False


def audit() -> list[str]:
    """Every problem found, as ``path:qualname: problem`` lines."""
    items, classes = load()
    out = []
    for item in items:
        if item.where in EXEMPT:
            continue
        if isinstance(item.node, ast.ClassDef):
            problems = class_problems(item.node)
        else:
            problems = function_problems(item.node, item.cls is not None)
            if problems and item.cls is not None and base_documents(item, classes, set()):
                problems = []
        out += [f"{item.where}: {p}" for p in problems]
    return out


def test_every_public_definition_has_numpydoc_sections():
    problems = audit()
    assert not problems, f"{len(problems)} docstring gaps:\n" + "\n".join(problems)


def test_the_walk_sees_the_public_api():
    # a broken walk (wrong root, everything deemed private) would pass the audit vacuously
    items, _ = load()
    wheres = {i.where for i in items}
    assert len(items) > 400
    assert {"bounds/fim.py:crlb", "filters/ekf.py:ExtendedKalmanFilter",
            "data.py:MeasurementSet.take", "cli/__init__.py:main"} <= wheres
    assert "cli/track.py:parse_q" not in wheres  # a CLI helper is private
    assert not any(":_" in w or "._" in w for w in wheres)
    assert all(public_module(SRC / w.split(":")[0]) for w in wheres)


PAPER_AUTHORS = re.compile(r"Gu et al\.|lecture notes|H(ö|oe)rst|Chen & Sun|Hurtado|Tichavsk")


def paper_modules() -> set[str]:
    """Modules docs/references.md credits with something taken from one of the papers."""
    text = (ROOT / "docs" / "references.md").read_text().split("## Methods cited")[0]
    mods = set()
    for line in text.splitlines():
        if line.startswith("| `"):
            mods |= set(re.findall(r"`([a-z_0-9/]+\.py)`", line.split("|")[1]))
    return {m for m in mods if (SRC / m).exists()}


def test_paper_modules_carry_references_sections():
    cited: set[str] = set()
    for path, tree in parsed().items():
        refs = [ast.get_docstring(tree) or ""] + [
            sections(ast.get_docstring(node) or "").get("References", "")
            for node in ast.walk(tree)
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef)]
        if any(PAPER_AUTHORS.search(text) for text in refs):
            cited.add(path.relative_to(SRC).as_posix())
    modules = paper_modules()
    assert len(modules) > 25  # the table was read
    missing = sorted(modules - cited)
    assert not missing, f"no citation of the paper in: {missing}"


def test_exemptions_still_exist():
    items, _ = load()
    wheres = {i.where for i in items}
    assert set(EXEMPT) <= wheres, set(EXEMPT) - wheres


@pytest.mark.parametrize("source, expected", [
    ("def f(x: float) -> float:\n    '''Do.'''\n    return x\n",
     ["Parameters section lacks ['x']", "no Returns/Yields section"]),
    ("def f(x: float, y: int) -> None:\n    '''Do.\n\n    Parameters\n    ----------\n"
     "    x, y : float\n        Metres.\n    '''\n", []),
    ("def f() -> int:\n    pass\n", ["no docstring"]),
    ("def f() -> None:\n    \"\"\"Do.\"\"\"\n    raise ValueError('x')\n",
     ["Raises section lacks ['ValueError']"]),
    ("def f() -> None:\n    \"\"\"Do.\"\"\"\n    try:\n        raise KeyError\n"
     "    except KeyError:\n        raise TypeError from None\n",
     ["Raises section lacks ['TypeError']"]),
])
def test_audit_catches_a_new_undocumented_function(source, expected):
    fn = ast.parse(source).body[0]
    assert isinstance(fn, ast.FunctionDef)
    assert function_problems(fn, False) == expected
