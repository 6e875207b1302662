"""What a docs build may read: `sdfpbr build ENTRIES` reads inside the entries folder, the Sphinx
directive inside the docs source tree. A path that leads out (an entry file, a [compare] a/b
file, an env / texture / glTF an entry or its a/b file names, a [sweep] value; through '..', an
absolute path or a symlink) is refused in one line, in the same words whether or not the
outside file exists; special files (a FIFO, /dev/zero) are refused without hanging."""
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sdfpbr.errors import SpecError
from sdfpbr.features.gallery.entries import collect

TINY = 'size = "32x32"\nrows = 1\ncols = 1\nlabels = false\n'


def cli(*args, env=None, timeout=120):
    return subprocess.run([sys.executable, "-m", "sdfpbr", *map(str, args)], capture_output=True, text=True,
                          env={**os.environ, **(env or {})}, timeout=timeout)


def plant(tmp_path: Path, case: str) -> tuple[Path, Path]:
    """(entries folder, the outside file the case names) for one way out."""
    charts = tmp_path / "tree" / "charts"
    (charts / "specs").mkdir(parents=True)
    (charts / "good.toml").write_text(TINY)
    outside_toml, outside_env = tmp_path / "outside.toml", tmp_path / "outside.npy"
    if case == "compare ..":
        (charts / "specs" / "x.toml").write_text('tonemap = "aces"\n')
        (charts / "ab.toml").write_text('[compare]\na = "specs/x.toml"\nb = "../../outside.toml"\n[spec]\n' + TINY)
        return charts, outside_toml
    if case == "env absolute":
        (charts / "lit.toml").write_text(TINY + f'env = "{outside_env}"\n')
        return charts, outside_env
    if case == "env symlink":
        (charts / "env.npy").symlink_to(outside_env)
        (charts / "lit.toml").write_text(TINY + 'env = "env.npy"\n')
        return charts, outside_env
    if case == "entry symlink":
        (charts / "evil.toml").symlink_to(outside_toml)
        return charts, outside_toml
    if case == "a/b file names env ..":   # a spec file inside the tree, naming a file outside it
        (charts / "specs" / "x.toml").write_text('env = "../../../outside.npy"\n')
        (charts / "specs" / "y.toml").write_text('tonemap = "neutral"\n')
        (charts / "ab.toml").write_text('[compare]\na = "specs/x.toml"\nb = "specs/y.toml"\n[spec]\n' + TINY)
        return charts, outside_env
    if case == "sweep env ..":
        (charts / "sw.toml").write_text('[sweep]\nfield = "env"\nvalues = ["studio", "../../outside.npy"]\n'
                                        '[spec]\n' + TINY)
        return charts, outside_env
    raise ValueError(case)


CASES = ["compare ..", "env absolute", "env symlink", "entry symlink", "a/b file names env ..", "sweep env .."]


def make_outside(path: Path) -> None:
    if path.suffix == ".npy":
        np.save(path, np.ones((4, 8, 3), np.float32))
    else:
        path.write_text(TINY)


@pytest.mark.parametrize("case", CASES)
def test_a_path_out_of_the_entries_folder_is_refused_alike_whether_it_exists(tmp_path, case):
    charts, outside = plant(tmp_path, case)
    messages = []
    for exists in (True, False):
        if exists:
            make_outside(outside)
        else:
            outside.unlink()
        with pytest.raises(SpecError) as err:
            collect(charts)
        messages.append(str(err.value))
    assert messages[0] == messages[1]
    assert "outside the folder" in messages[0] and str(charts) in messages[0] and "\n" not in messages[0]

    make_outside(outside)                        # the CLI: exit 2, one line, nothing written
    out, cache = tmp_path / "out", tmp_path / "cache"
    r = cli("build", charts, "-o", out, env={"SDFPBR_CACHE_DIR": str(cache)})
    assert r.returncode == 2 and r.stderr == f"sdfpbr: error: {messages[0]}\n", r.stderr
    assert not out.exists() and not cache.exists()


def test_paths_inside_the_tree_are_read_wherever_they_are_named_from(tmp_path):
    """'..' that stays inside, a symlink to a file inside, an a/b file naming its env
    relative to its own folder: all read as before."""
    charts = tmp_path / "charts"
    (charts / "specs").mkdir(parents=True)
    np.save(charts / "env.npy", np.ones((4, 8, 3), np.float32))
    (charts / "alias.npy").symlink_to(charts / "env.npy")
    (charts / "specs" / "x.toml").write_text('env = "../env.npy"\n')
    (charts / "specs" / "y.toml").write_text('env = "../alias.npy"\n')
    (charts / "ab.toml").write_text('[compare]\na = "specs/x.toml"\nb = "specs/../specs/y.toml"\n[spec]\n' + TINY)
    (charts / "sw.toml").write_text('[sweep]\nfield = "env"\nvalues = ["studio", "env.npy"]\n[spec]\n' + TINY)
    items = {item.name: item for item in collect(charts)}
    a, b = items["ab"].specs
    assert Path(a.env).resolve() == Path(b.env).resolve() == (charts / "env.npy").resolve()
    assert Path(items["sw"].sweep_values[1]).resolve() == (charts / "env.npy").resolve()
    # A folder above the entries may be named as the tree they read from.
    (tmp_path / "shared.npy").write_bytes((charts / "env.npy").read_bytes())
    (charts / "up.toml").write_text(TINY + 'env = "../shared.npy"\n')
    with pytest.raises(SpecError, match="outside the folder"):
        collect(charts)
    assert Path(collect(charts, root=tmp_path)[-1].specs[0].env).resolve() == (tmp_path / "shared.npy").resolve()


@pytest.mark.parametrize("special", ["fifo", "/dev/zero"])
def test_a_special_file_an_entry_names_is_refused_without_hanging(tmp_path, special):
    charts = tmp_path / "charts"
    charts.mkdir()
    (charts / "specs").mkdir()
    (charts / "specs" / "y.toml").write_text('tonemap = "neutral"\n')
    if special == "fifo":
        os.mkfifo(charts / "specs" / "x.toml")
        os.mkfifo(charts / "env.npy")
        (charts / "lit.toml").write_text(TINY + 'env = "env.npy"\n')
    else:
        (charts / "specs" / "x.toml").symlink_to("/dev/zero")
    (charts / "ab.toml").write_text('[compare]\na = "specs/x.toml"\nb = "specs/y.toml"\n[spec]\n' + TINY)
    r = cli("build", charts, "-o", tmp_path / "out", timeout=60, env={"SDFPBR_CACHE_DIR": str(tmp_path / "cache")})
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "Traceback" not in r.stderr, r.stderr
    assert ("not a regular file" if special == "fifo" else "outside the folder") in r.stderr


# ---- the Sphinx directive ---------------------------------------------------------------------

def sphinx_build(src: Path, out: Path, cache: Path):
    return subprocess.run([sys.executable, "-m", "sphinx", "-b", "html", "-q", str(src), str(out)],
                          capture_output=True, text=True, timeout=120,
                          env={**os.environ, "SDFPBR_CACHE_DIR": str(cache)})


def directive_errors(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if "sdfpbr-chart:" in line]


DIRECTIVES = {
    "up": ".. sdfpbr-chart:: ../outside.toml",                      # relative to the document: out
    "rooted": ".. sdfpbr-chart:: //{outside}",                      # '/x' is srcdir/x; '//x' absolute
    "deep": ".. sdfpbr-chart:: ../../../../../../../../../../dev/zero",
    "symlink to /dev/zero": ".. sdfpbr-chart:: zero.toml",
    "fifo": ".. sdfpbr-chart:: fifo.toml",
    "inline env": ".. sdfpbr-chart::\n\n   env = \"../outside.npy\"\n   " + TINY.replace("\n", "\n   "),
}


@pytest.mark.requires_extra("sphinx")
def test_the_directive_reads_only_inside_the_source_tree(tmp_path):
    src = tmp_path / "src"
    src.mkdir()
    (src / "conf.py").write_text('extensions = ["sdfpbr.sphinxext"]\nproject = "charts"\n')
    (src / "zero.toml").symlink_to("/dev/zero")
    os.mkfifo(src / "fifo.toml")
    outside_toml, outside_env = tmp_path / "outside.toml", tmp_path / "outside.npy"
    body = "\n\n".join(d.format(outside=outside_toml) for d in DIRECTIVES.values())
    (src / "index.rst").write_text("Charts\n======\n\n" + body + "\n")
    runs = []
    for exists in (True, False):
        if exists:
            make_outside(outside_toml)
            make_outside(outside_env)
        else:
            outside_toml.unlink()
            outside_env.unlink()
        r = sphinx_build(src, tmp_path / f"html-{exists}", tmp_path / "cache")
        assert "Traceback" not in r.stderr and "MemoryError" not in r.stderr, r.stderr
        runs.append(directive_errors(r.stderr))
    assert runs[0] == runs[1]                                   # the same words, existing or not
    errors = runs[0]
    assert len(errors) == len(DIRECTIVES), "\n".join(errors)
    for (case, _), line in zip(DIRECTIVES.items(), errors):
        want = "not a regular file" if case == "fifo" else "outside the folder"
        assert want in line and "index.rst" in line, (case, line)
    assert not (tmp_path / "cache" / "build").exists()         # nothing rendered
