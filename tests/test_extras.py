"""A missing extra is one line, exit 2, naming a command that works for how sdfpbr was
installed: pip for the running interpreter, from the checkout when sdfpbr runs from one
(`pip install 'sdfpbr[exr]'` failed for an install made from a checkout)."""
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

import sdfpbr
from sdfpbr.extras import EXTRAS, install_command

from helpers import blocked

CHECKOUT = Path(sdfpbr.__file__).resolve().parents[1]


def test_the_command_installs_into_this_interpreter_from_this_checkout():
    if not (CHECKOUT / "pyproject.toml").is_file():
        pytest.skip("sdfpbr runs from an installed copy here, not a checkout")
    for extra in EXTRAS:
        words = shlex.split(install_command(extra))
        assert words[:4] == [sys.executable, "-m", "pip", "install"]
        assert words[4] == f"{CHECKOUT}[{extra}]"
        assert extra in (CHECKOUT / "pyproject.toml").read_text()   # an extra pyproject.toml declares


@pytest.mark.parametrize("args, module, extra", [
    (["chart", "--size", "32x32", "-o", "c.png", "--hdr", "c.exr"], "OpenEXR", "exr"),
    (["chart", "--size", "32x32", "--frames", "2", "-o", "c.mp4"], "imageio_ffmpeg", "video"),
    (["bench", "--scenes", "furnace", "--no-cold", "--plot", "p.png"], "matplotlib", "metrics"),   # before the run
])
def test_a_missing_extra_is_one_line_exit_2_with_a_working_command(tmp_path, args, module, extra):
    r = subprocess.run([sys.executable, "-m", "sdfpbr", *args], capture_output=True, text=True, cwd=tmp_path,
                       env=blocked(tmp_path, module), timeout=300)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1, r.stderr      # bench exited 1
    assert install_command(extra) in lines[0]
    assert not list(tmp_path.glob("c.*")) and not (tmp_path / "p.png").exists()
