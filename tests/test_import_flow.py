"""The package's imports flow one way (README, "Layout"): material -> hertz -> fem -> calibrate ->
law -> analyses -> report -> cli. Read from the source (every import, also those inside
functions), so an import added against the flow fails here, not in a reviewer's reading."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "geocontact"

# tiers of the flow: a module may import from its own tier and the tiers before it. The shared
# ground (top-level modules such as errors, io, schema, figures, cyclic_fit) is tier 0; the old
# module names kept as aliases (cycles, histories, ...) re-export a later tier and are not listed.
TIERS = {
    "material": 0, "hertz": 0, "errors": 0, "io": 0, "schema": 0, "resolution": 0,
    "force_history": 0, "figures": 0, "_version": 0, "lammps_plugin": 0,
    "fem": 1, "verification": 1, "calibrate": 1, "law": 1, "cyclic_fit": 1,
    "analyses": 2,
    "report": 3,
    "cli": 4, "demo": 4,
}


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


def test_calibrate_uses_the_shared_figure_record():
    """calibrate draws its acceptance figures with geocontact.figures, the record the report
    re-exports (one class, not a copy)."""
    from geocontact import figures, report
    from geocontact.report import html

    assert report.Figure is figures.Figure and html.Figure is figures.Figure
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
