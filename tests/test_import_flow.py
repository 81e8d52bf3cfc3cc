"""The package's imports flow one way (README, "Architecture"): grain -> fem -> law -> calibrate
(with universal, labtest) -> analyses -> report -> cli, on the ground of errors, files, figures and
schema. Read from the source (every import, also those inside functions), so an import added
against the flow fails here, not in a reviewer's reading."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "geocontact"

# tiers of the flow (README, "Architecture"): a module may import from its own tier and the tiers
# before it. The ground (errors, files, figures, schema, _version) is tier 0; the grain (material,
# Hertz, force histories) tier 1; the law sits below calibration, which evaluates it to fit it.
TIERS = {
    "_version": 0, "errors": 0, "files": 0, "figures": 0, "schema": 0,
    "grain": 1,
    "fem": 2, "verification": 2,
    "law": 3,
    "calibrate": 4, "universal": 4, "labtest": 4,
    "analyses": 5,
    "report": 6,
    "cli": 7,
}
# the top of the package holds the ground only (issue 38: at most six modules)
TOP_LEVEL = {"__init__", "_version", "errors", "files", "figures", "schema"}


def _imports(path: Path, root: Path = PACKAGE) -> set[str]:
    """Top-level geocontact subpackages/modules that ``path`` imports (absolute or relative)."""
    rel = path.relative_to(root.parent).with_suffix("").parts
    package = rel if path.name == "__init__.py" else rel[:-1]
    package = package[:-1] if package[-1] == "__init__" else package
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = list(package[:len(package) - (node.level - 1)])
                target = base + (node.module.split(".") if node.module else [])
            else:
                target = (node.module or "").split(".")
            if target[0] != "geocontact":
                continue
            if len(target) > 1:
                found.add(target[1])
            else:
                found.update(a.name for a in node.names)
        elif isinstance(node, ast.Import):
            found.update(a.name.split(".")[1] for a in node.names
                         if a.name.startswith("geocontact."))
    return found


def _violations(root: Path = PACKAGE) -> list[str]:
    bad = []
    for path in sorted(root.rglob("*.py")):
        name = path.relative_to(root).with_suffix("").parts[0]
        tier = TIERS.get(name)
        if tier is None:
            continue
        for target in sorted(_imports(path, root)):
            other = TIERS.get(target)
            if other is not None and other > tier:
                bad.append(f"{path.relative_to(root)} ({name}) imports {target}")
    return bad


def test_imports_flow_one_way():
    assert _violations() == []


def test_every_module_has_a_tier_and_the_top_holds_the_ground_only():
    top = {p.stem for p in PACKAGE.glob("*.py")}
    assert top == TOP_LEVEL
    folders = {p.name for p in PACKAGE.iterdir() if (p / "__init__.py").exists()}
    assert folders <= set(TIERS), folders - set(TIERS)


def test_no_module_only_re_exports_another():
    """A module whose whole body is imports (a docstring aside) exists only to re-export: none."""
    only_imports = []
    for path in PACKAGE.rglob("*.py"):
        body = ast.parse(path.read_text()).body
        if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
            body = body[1:]
        if body and all(isinstance(n, (ast.Import, ast.ImportFrom)) for n in body):
            only_imports.append(str(path.relative_to(PACKAGE)))
    assert only_imports == []


def test_the_old_module_names_still_import_the_moved_modules():
    """geocontact.MOVED: an old name is the new module itself, with a DeprecationWarning."""
    import importlib
    import sys

    import geocontact

    for old, new in geocontact.MOVED.items():
        sys.modules.pop(old, None)
        with pytest.warns(DeprecationWarning, match="moved to"):
            module = importlib.import_module(old)
        assert module is importlib.import_module(new)
        assert module.__spec__.name == new and module.__package__ == module.__spec__.parent


def test_calibrate_uses_the_shared_figure_record():
    """calibrate draws its acceptance figures with geocontact.figures, the record the report
    re-exports (one class, not a copy)."""
    from geocontact import figures, report

    assert report.Figure is figures.Figure
    assert report.save_figure is figures.save_figure
    assert "figures" in _imports(PACKAGE / "calibrate" / "acceptance.py")


@pytest.mark.parametrize("source, target", [
    ("from ...report import Figure\n", "report"),
    ("from geocontact.analyses import cycles\n", "analyses"),
    ("def f():\n    from ...cli import main\n", "cli"),
])
def test_the_check_sees_an_import_against_the_flow(tmp_path, source, target):
    """The checker would fail: an import of a later tier written into calibrate is reported."""
    fake = tmp_path / "geocontact"
    (fake / "calibrate" / "deep").mkdir(parents=True)
    (fake / "calibrate" / "deep" / "x.py").write_text(source)
    assert _violations(fake) == [f"calibrate/deep/x.py (calibrate) imports {target}"]
