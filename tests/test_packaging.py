"""What `pip install .` ships: every Python package of the source tree and the shader modules.
pyproject.toml lists packages by hand (the shaders are a data package mapped from shaders/), so
a new subpackage must be added there; this test names the one that was not."""
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_every_package_in_the_tree_is_listed_in_pyproject():
    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    in_tree = {".".join(p.parent.relative_to(ROOT).parts) for p in (ROOT / "sdfpbr").rglob("__init__.py")}
    assert in_tree | {"sdfpbr.shaders"} == listed, "add to or remove from [tool.setuptools] packages"


def test_no_package_sits_in_a_folder_git_ignores():
    """A package named like an ignored folder (build/, dist/) would be missing from a clone."""
    ignored = {line.strip().strip("/") for line in (ROOT / ".gitignore").read_text().splitlines()
               if line.strip() and not line.startswith(("#", "!"))}
    for init in (ROOT / "sdfpbr").rglob("__init__.py"):
        assert not set(init.parent.relative_to(ROOT).parts) & ignored, init
