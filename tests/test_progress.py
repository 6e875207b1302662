"""Progress on long work: Progress counts units; Ticker says that one long step (a big chart, a
slow gallery image) is still going, and says nothing about a quick one."""
import io
import threading

from sdfpbr.progress import EVERY_S, Ticker


class Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_quick_step_says_nothing():
    for stream in (io.StringIO(), Tty()):
        with Ticker("chart", stream=stream):
            pass
        assert stream.getvalue() == ""
    lines = []
    with Ticker("chart", enabled=False, every_s=0.0, say=lines.append):
        pass
    assert lines == [] and EVERY_S >= 1.0


def test_a_long_step_says_its_time_then_that_it_is_done():
    """Lines come from the ticker's thread: the step waits for two of them (no wall-clock bound)."""
    lines, two = [], threading.Event()

    def say(line):
        lines.append(line)
        if len(lines) == 2:
            two.set()
    with Ticker("sdfpbr chart 4096x4096", every_s=0.01, say=say):
        assert two.wait(60)
    assert all(line.startswith("sdfpbr chart 4096x4096: ") and line.endswith(" s") for line in lines)
    assert lines[-1].startswith("sdfpbr chart 4096x4096: done in ")


def test_the_caller_may_say_the_end_itself_and_a_failed_step_has_no_end():
    lines, one = [], threading.Event()

    def say(line):
        lines.append(line)
        one.set()
    with Ticker("drawing x.png", every_s=0.01, say=say, end=False):
        assert one.wait(60)
    assert not any("done" in line for line in lines)
    lines.clear()
    one.clear()
    try:
        with Ticker("drawing y.png", every_s=0.01, say=say):
            assert one.wait(60)
            raise KeyboardInterrupt
    except KeyboardInterrupt:
        pass
    assert lines and not any("done" in line for line in lines)
