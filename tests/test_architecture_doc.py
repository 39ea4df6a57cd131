"""docs/architecture.md stays true to the import contract it describes (issue 42)."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "architecture.md"
PACKAGE = ROOT / "src" / "demcal"


def _contract_layers() -> list[str]:
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]
    layers = [c for c in config["contracts"] if c["type"] == "layers"]
    assert len(layers) == 1, "one layers contract is what the page describes"
    return [_normal(layer) for layer in layers[0]["layers"]]


def _normal(layer: str) -> str:
    return " | ".join(part.strip() for part in layer.split("|"))


def _doc_layers(text: str) -> list[str]:
    floors = text[text.index("## The floors"):]
    block = re.search(r"```text\n(.*?)```", floors, flags=re.S)
    assert block, "the floors are listed in a ```text block under '## The floors'"
    return [_normal(line) for line in block.group(1).splitlines() if line.strip()]


def test_the_floors_are_the_import_contract_in_its_order():
    assert _doc_layers(DOC.read_text()) == _contract_layers()


def test_every_folder_is_on_a_floor_and_has_a_room():
    text = DOC.read_text()
    on_floors = {name.strip().removeprefix("demcal.")
                 for layer in _contract_layers() for name in layer.split("|")}
    folders = {p.parent.name for p in PACKAGE.glob("*/__init__.py")}
    assert folders <= on_floors, f"folders outside the contract: {folders - on_floors}"
    for folder in folders:
        assert f"| `{folder}/` |" in text, f"docs/architecture.md has no row for {folder}/"


def test_every_top_level_module_is_named():
    text = DOC.read_text()
    for module in PACKAGE.glob("*.py"):
        if module.name not in ("__init__.py", "__main__.py"):
            assert f"`{module.name}`" in text, f"docs/architecture.md does not name {module.name}"
