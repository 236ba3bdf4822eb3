"""The package's layers (DESIGN.md, "Layout"): every import, function-level ones included, points down.

Read from the bottom: the underscore modules, films, doe, hertz and elastic; contact (what a film is and
records: film laws, imprint readings, roughness); fem and wheelrail (models that use contact, never each
other); campaign; surrogate; calibration; correction; study; report; commands and the CLI on top.
"""
from __future__ import annotations

import ast
from pathlib import Path

import filmcal

PACKAGE = Path(filmcal.__file__).resolve().parent

#: Floors from the bottom; modules on one floor may import their own package only.
FLOORS: list[tuple[str, ...]] = [
    ("filmcal._",),  # the private helpers (errors, io, json, validation, parallel, progress, versions)
    ("filmcal.films", "filmcal.doe", "filmcal.hertz", "filmcal.elastic", "filmcal.data"),
    ("filmcal.contact",),
    ("filmcal.fem", "filmcal.wheelrail"),
    ("filmcal.campaign",),
    ("filmcal.surrogate",),
    ("filmcal.calibration",),
    ("filmcal.correction",),
    ("filmcal.study",),
    ("filmcal.report",),
    ("filmcal.commands", "filmcal.cli"),  # one room: the command line
    ("filmcal",),  # the package's own __init__: the public API re-exported
]


def module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def room(module: str) -> tuple[int, str]:
    """(floor, room) of a module: the room is the entry of FLOORS it belongs to (cli and commands: one)."""
    best = None
    for floor, rooms in enumerate(FLOORS):
        for r in rooms:
            if module == r or module.startswith(r + ".") or (r.endswith("_") and module.startswith(r)):
                if best is None or len(r) > len(best[1]):
                    best = (floor, r)
    assert best is not None, f"{module} is on no floor of tests/test_layers.py: place it"
    return (best[0], "filmcal.commands") if best[1] == "filmcal.cli" else best


def imports_of(path: Path) -> list[tuple[int, str]]:
    """(line, module) of every filmcal import in a file, at any depth (functions, TYPE_CHECKING blocks)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    here = module_name(path)
    package = here if path.name == "__init__.py" else here.rpartition(".")[0]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names if a.name.split(".")[0] == "filmcal"]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                target = f"{base}.{node.module}" if node.module else base
            else:
                target = node.module or ""
            if target.split(".")[0] != "filmcal":
                continue
            # `from filmcal.x import y` may name a submodule y
            for a in node.names:
                out.append((node.lineno, f"{target}.{a.name}" if _is_module(f"{target}.{a.name}") else target))
    return out


def _is_module(name: str) -> bool:
    rel = Path(*name.split("."))
    return (PACKAGE.parent / rel).with_suffix(".py").is_file() or (PACKAGE.parent / rel / "__init__.py").is_file()


def _lazy_targets(path: Path) -> list[tuple[int, str]]:
    """Modules named in a `lazy_exports` table (imported on first use: an import like any other)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "lazy_exports":
            for arg in node.args:
                if isinstance(arg, ast.Dict):
                    out += [(k.lineno, k.value) for k in arg.keys if isinstance(k, ast.Constant)]
    return out


def all_edges() -> list[tuple[str, int, str]]:
    edges = []
    for path in sorted(PACKAGE.rglob("*.py")):
        here = module_name(path)
        for line, target in imports_of(path) + _lazy_targets(path):
            edges.append((here, line, target))
    return edges


def test_no_import_runs_back_up_a_floor():
    wrong = []
    for here, line, target in all_edges():
        (f_here, r_here), (f_to, r_to) = room(here), room(target)
        if f_to > f_here or (f_to == f_here and r_to != r_here and r_here != "filmcal"):
            wrong.append(f"{here}:{line} imports {target} (floor {f_here} {r_here} -> floor {f_to} {r_to})")
    assert not wrong, "imports that run back up (or across a floor):\n" + "\n".join(wrong)


def test_no_two_modules_import_each_other():
    edges = {(here, target) for here, _, target in all_edges() if here != target}
    mutual = sorted({tuple(sorted(e)) for e in edges if (e[1], e[0]) in edges})
    assert not mutual, f"modules that import each other: {mutual}"


def test_the_checker_sees_function_level_and_relative_imports(tmp_path, monkeypatch):
    """The walker must find an import hidden in a function (else the two tests above could not fail)."""
    code = "def f():\n    from filmcal.study import Study\n    from . import names\n"
    path = PACKAGE / "contact" / "film.py"
    monkeypatch.setattr(Path, "read_text", lambda self, encoding=None: code if self == path else
                        Path.read_bytes(self).decode())
    found = [t for _, t in imports_of(path)]
    assert "filmcal.study" in found and "filmcal.contact.names" in found
    assert room("filmcal.study")[0] > room("filmcal.contact.film")[0]
