"""The package's layers (oftimg.LAYERS): each module imports only from its own layer or
lower ones, lazy imports inside functions included, and no modules import each other
round a circle of any length."""

import ast
from pathlib import Path

import oftimg

PACKAGE = Path(oftimg.__file__).parent


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path, name: str | None = None) -> set[str]:
    """Every oftimg module (or package) a file imports, anywhere in it; ``name``: the
    module's dotted name (default: from where the file is)."""
    name = name or _module_name(path)
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.startswith("oftimg")}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = ".".join(base[: len(base) - node.level + 1])
                target = f"{base}.{node.module}" if node.module else base
            elif (node.module or "").startswith("oftimg"):
                target = node.module
            else:
                continue
            for alias in node.names:  # from . import module
                sub = f"{target}.{alias.name}"
                found.add(sub if _exists(sub) else target)
    return found


def _exists(module: str) -> bool:
    rel = Path(*module.split(".")[1:])
    return (PACKAGE / rel).with_suffix(".py").exists() or (PACKAGE / rel).is_dir()


def _layer(module: str) -> int:
    parts = module.split(".")
    if len(parts) == 1:
        return -1  # the package's own __init__
    for k, names in enumerate(oftimg.LAYERS):
        if parts[1] in names:
            return k
    raise AssertionError(f"{module} is in no layer of oftimg.LAYERS")


def _all_imports() -> dict[str, set[str]]:
    return {_module_name(p): _imports(p) for p in PACKAGE.rglob("*.py")}


def test_every_module_is_in_a_layer_and_imports_only_downwards():
    wrong = []
    for module, imported in _all_imports().items():
        if module == "oftimg":
            continue
        for other in imported:
            if _layer(other) > _layer(module):
                wrong.append(f"{module} imports {other}")
    assert not wrong, "\n".join(sorted(wrong))


def import_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of imports among the modules of ``graph`` (module -> what it imports),
    of any length, as the modules around it; None when there is none."""
    from graphlib import CycleError, TopologicalSorter

    try:
        TopologicalSorter(
            {a: {b for b in targets if b in graph and b != a} for a, targets in graph.items()}
        ).prepare()
    except CycleError as exc:
        return exc.args[1]
    return None


def test_no_modules_import_each_other_round_a_circle():
    """Not two modules importing each other, nor a longer circle (export -> figures ->
    report -> export was one): each module's imports are below it."""
    cycle = import_cycle(_all_imports())
    assert cycle is None, " -> ".join(cycle)


def test_a_circle_of_three_is_found():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a", "d"}, "d": set()}
    assert sorted(set(import_cycle(graph))) == ["a", "b", "c"]
    assert import_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None


def test_a_module_importing_upwards_is_found(tmp_path):
    """The check itself: a mesh module that imports the pipeline in a function, and
    one that imports a figure module by its full name, are seen to import upwards."""
    fake = tmp_path / "fake.py"
    fake.write_text(
        "def f():\n    from ..analysis.pipeline import analyse_dataset\n"
        "import oftimg.output.figures\nfrom . import grid\n"
    )
    imported = _imports(fake, "oftimg.mesh.fake")
    assert imported == {"oftimg.analysis.pipeline", "oftimg.output.figures", "oftimg.mesh.grid"}
    assert [m for m in imported if _layer(m) > _layer("oftimg.mesh.fake")] != []
    assert _layer("oftimg.cli") == len(oftimg.LAYERS) - 1 and _layer("oftimg.errors") == 0
