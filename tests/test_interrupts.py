"""Ctrl-C at any moment of a command: one line, "sdfpbr: interrupted", exit status 130, no
traceback from the command or its workers. The interrupt is sent at exact moments (an import
hook sends it when a given module starts to load) instead of after a guessed delay, so each
case is reached every run. Python's own start-up, before sdfpbr's first line runs, is not
covered: no code of sdfpbr's can run there."""
from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import textwrap

import pytest

# Sends SIGINT to ``target`` ("self" or "group") when module ``name`` starts to load in a
# process that ``who`` selects ("main": the command's process; "worker": a spawned worker).
HOOK = textwrap.dedent("""
    import os, signal, sys
    NAME, TARGET = os.environ["HOOK_MODULE"], os.environ["HOOK_TARGET"]
    WHO, ONCE = os.environ["HOOK_WHO"], os.environ["HOOK_ONCE"]
    worker = any("multiprocessing" in a for a in sys.orig_argv)
    class Hook:
        def find_spec(self, name, path=None, target=None):
            if name == NAME and worker == (WHO == "worker"):
                try:
                    os.close(os.open(ONCE, os.O_CREAT | os.O_EXCL))   # one interrupt per run
                except FileExistsError:
                    return None
                try:
                    if TARGET == "group":
                        os.killpg(os.getpgrp(), signal.SIGINT)
                    else:
                        os.kill(os.getpid(), signal.SIGINT)
                except KeyboardInterrupt:
                    if os.environ.get("HOOK_CONVERT"):   # as numpy's import does
                        raise ImportError("the interrupt, turned into another error") from None
                    raise
            return None
    sys.meta_path.insert(0, Hook())
    if os.environ.get("HOOK_AT_EXIT") and not worker:   # registered first, so it runs last at exit
        import atexit
        def at_exit():
            os.close(os.open(ONCE, os.O_CREAT))
            os.kill(os.getpid(), signal.SIGINT)
        atexit.register(at_exit)
""")


def run_interrupted(tmp_path, args, module, who="main", target="self", convert=False, at_exit=False):
    site = tmp_path / "site"
    site.mkdir(exist_ok=True)
    (site / "sitecustomize.py").write_text(HOOK)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(site), os.environ.get("PYTHONPATH", "")]),
           "HOOK_MODULE": module, "HOOK_TARGET": target, "HOOK_WHO": who, "HOOK_ONCE": str(tmp_path / "once"),
           "SDFPBR_CACHE_DIR": str(tmp_path / "cache"), **({"HOOK_CONVERT": "1"} if convert else {}),
           **({"HOOK_AT_EXIT": "1"} if at_exit else {})}
    # A test run started in the background inherits SIGINT ignored: give the command the
    # default a terminal's foreground job has, in a process group of its own.
    p = subprocess.run([sys.executable, "-m", "sdfpbr", *args], env=env, capture_output=True, text=True,
                       timeout=300, cwd=tmp_path, start_new_session=True,
                       preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    assert (tmp_path / "once").exists(), f"the hook never saw {module} load: the case was not reached"
    return p


@pytest.mark.parametrize("module", [
    "sdfpbr.errors",     # the first module the package loads (lazily, after the entry's line)
    "sdfpbr.cli.main",   # while the command's own modules load, before main() runs
    "argparse",
    "numpy",
    "moderngl",
    "PIL",
])
def test_ctrl_c_while_a_command_loads_is_one_line(tmp_path, module):
    p = run_interrupted(tmp_path, ["chart", "--size", "32x32", "-o", "c.png"], module)
    assert p.returncode == 130, p.stderr
    assert p.stderr.strip() == "sdfpbr: interrupted", p.stderr
    assert not (tmp_path / "c.png").exists()


def test_an_interrupt_a_library_turns_into_its_own_error_is_still_an_interrupt(tmp_path):
    """numpy turns a KeyboardInterrupt inside its extension's import into an ImportError: that
    printed an ImportError traceback ("a bad install") for a Ctrl-C."""
    p = run_interrupted(tmp_path, ["chart", "--size", "32x32", "-o", "c.png"], "numpy", convert=True)
    assert p.returncode == 130 and p.stderr.strip() == "sdfpbr: interrupted", p.stderr


def test_ctrl_c_while_the_interpreter_exits_is_one_line(tmp_path):
    """After the work (the chart written), during the interpreter's exit hooks: one line."""
    p = run_interrupted(tmp_path, ["chart", "--size", "32x32", "-o", "c.png"], "no module", at_exit=True)
    assert p.returncode == 130 and p.stderr.strip() == "sdfpbr: interrupted", p.stderr
    assert (tmp_path / "c.png").exists()        # what was done stays done


def test_ctrl_c_while_a_parallel_build_starts_its_workers_is_one_line(tmp_path):
    """The group's Ctrl-C lands while a worker imports (before it could ignore SIGINT): 4 of 10
    tries printed the worker's KeyboardInterrupt traceback. Workers now start with SIGINT
    held, and ignore it once they run."""
    charts = tmp_path / "charts"
    charts.mkdir()
    for i in range(3):
        (charts / f"c{i}.toml").write_text(f'size = "32x32"\nroughness = [0.{i + 1}, 1.0]\n')
    p = run_interrupted(tmp_path, ["build", str(charts), "-o", str(tmp_path / "out"), "-j", "2", "--force"],
                        "sdfpbr.workers", who="worker", target="group")
    assert p.returncode == 130, p.stderr
    assert "Traceback" not in p.stderr and p.stderr.strip().endswith("sdfpbr: interrupted"), p.stderr


# Any module the command loads, drawn with the fuzz's seed (tests/test_hostile_fuzz.py).
MODULES = ["sdfpbr.errors", "sdfpbr.cli.main", "argparse", "numpy", "moderngl", "glcontext", "PIL",
           "sdfpbr.spec.fields", "sdfpbr.gpu.session", "sdfpbr.gpu.render", "sdfpbr.image.io",
           "sdfpbr.image.png_stream", "sdfpbr.shading.plan", "sdfpbr.image.layout"]
SEED = int(os.environ.get("SDFPBR_FUZZ_SEED", "0"))


@pytest.mark.parametrize("case", range(2))
def test_ctrl_c_while_any_module_loads_is_one_line(tmp_path, case):
    module = random.Random(f"{SEED}:signals:{case}").choice(MODULES)
    p = run_interrupted(tmp_path, ["chart", "--size", "32x32", "-o", "c.png"], module)
    assert p.returncode == 130 and p.stderr.strip() == "sdfpbr: interrupted", (module, SEED, p.stderr)
