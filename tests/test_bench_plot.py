"""The bench's time-error plot: its log axes are labelled in plain numbers that never overlap
(matplotlib's default labels minor ticks over a short range, "2x10^1 3x10^1 ...", and they did)."""
import pytest


@pytest.mark.requires_extra("matplotlib")
@pytest.mark.parametrize("lo, hi", [(12.0, 45.0), (6.0, 19.0), (3.0, 8000.0), (0.0018, 0.35), (0.027, 0.062)])
def test_log_axis_labels_are_plain_and_apart(lo, hi):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sdfpbr.devtools.bench.report import plain_log_ticks
    fig, ax = plt.subplots(figsize=(8, 5.5), dpi=110)   # the plot's size
    try:
        ax.scatter([lo, hi], [lo, hi])
        ax.set_xscale("log")
        ax.set_yscale("log")
        plain_log_ticks(ax.xaxis)
        plain_log_ticks(ax.yaxis)
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        for axis, gap in ((ax.xaxis, 0), (ax.yaxis, 1)):
            labels = [t for t in axis.get_ticklabels(which="both") if t.get_visible() and t.get_text()]
            assert len(labels) >= 2
            assert all("10^" not in t.get_text() and "times" not in t.get_text() for t in labels)
            boxes = sorted((t.get_window_extent(renderer) for t in labels), key=lambda b: (b.x0, b.y0)[gap])
            for a, b in zip(boxes, boxes[1:]):
                assert (a.x1 <= b.x0) if gap == 0 else (a.y1 <= b.y0), [t.get_text() for t in labels]
    finally:
        plt.close(fig)
