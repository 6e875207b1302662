"""The cells stage's cell borders (shading/cells.py cell_border_px, shaders/cell_border.glsl):
each cell of an opaque image framed in the chart's page colour, so one cell's near floor never
meets the next cell's far floor in a seam; nothing framed where the floor fades out by itself
(transparent, backdrop) or where there is one view (the shared stage)."""
import numpy as np
import pytest

from sdfpbr.image.layout import BACKGROUND
from sdfpbr.shading.plan import chart_frame, render_plan
from sdfpbr.spec.chart_spec import make_spec


def border_mask(spec) -> np.ndarray:
    """Where the border and the margins beyond the grid are (image rows, top first), from the
    grid's geometry: a pixel is a cell's when it is ``border`` pixels or more inside it."""
    frame = chart_frame(spec)
    grid, border = frame.grid, frame.cell_border
    ys, xs = np.mgrid[:spec.height, :spec.width]
    x, y = xs - grid.left, ys - grid.top
    in_grid = (x >= 0) & (y >= 0) & (x < grid.cols * grid.cell_width) & (y < grid.rows * grid.cell_height)
    cx, cy = x % grid.cell_width, y % grid.cell_height
    interior = (in_grid & (cx >= border) & (cx < grid.cell_width - border)
                & (cy >= border) & (cy < grid.cell_height - border))
    return ~interior


@pytest.mark.parametrize("shape", [
    dict(),                                   # the default chart: 204-px cells, 2-px borders
    dict(size="163x127", rows=2, cols=3),     # margins beyond the grid: 1/0 and 1/2 px
    dict(size="600x260", rows=2, cols=5),     # wide cells
])
def test_each_cell_is_framed_in_the_page_colour(session, shape):
    spec = make_spec(labels=False, **shape)
    assert chart_frame(spec).cell_border >= 1
    image = session.render(spec, aovs=False, hdr=False).image
    mask = border_mask(spec)
    page = np.array(BACKGROUND, np.uint8)
    assert (image[mask] == page).all()
    shown = (image[~mask] != page).any(axis=1)
    assert shown.mean() > 0.999   # inside, the render: floor and sphere, never the page colour


def test_borders_cross_tiles_whole(session, monkeypatch):
    """The display pass draws tile by tile: each tile finds its cells' borders from its origin."""
    spec = make_spec(size="163x127", rows=2, cols=3, labels=False)
    whole = session.render(spec, aovs=False, hdr=False).image
    monkeypatch.setattr(session, "tile", 36)
    np.testing.assert_array_equal(session.render(spec, aovs=False, hdr=False).image, whole)


@pytest.mark.parametrize("change", [
    dict(transparent=True),          # a shadow catcher, faded out before the cell's edge
    dict(backdrop=(1.0, 1.0, 1.0)),  # the same laid onto a page
    dict(stage="shared"),            # one view: no seams to hide
    dict(cell_borders=False),
    dict(size="150x150", rows=10, cols=10),   # 15-px cells
])
def test_no_borders_where_the_image_has_no_seams_or_no_room(session, change):
    spec = make_spec(labels=False, **change)
    assert chart_frame(spec).cell_border == 0
    assert dict(render_plan(spec).display.options).get("CELL_BORDER") is False
    if change != dict(cell_borders=False):
        plain = make_spec(labels=False, **change, cell_borders=False)
        np.testing.assert_array_equal(session.render(spec, aovs=False, hdr=False).image,
                                      session.render(plain, aovs=False, hdr=False).image)
