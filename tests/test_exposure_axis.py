"""Exposure on an axis: the display pass exposes each cell, floor and all, by its column's (or
row's) EV. Every column of such a chart is the plain chart rendered at that exposure, pixel for
pixel, whole or in tiles; the HDR is the same as without the axis (exposure comes after it)."""
import numpy as np
import pytest

from sdfpbr.errors import SpecError
from sdfpbr.shading.plan import chart_frame
from sdfpbr.spec.chart_spec import make_spec

KW = dict(rows=2, cols=3, size="192x128", labels=False, roughness=(0.4, 0.4), y_axis="metallic")
VALUES = (-1.0, 0.5, 2.0)


@pytest.mark.parametrize("tile", [None, 44])   # 44: tiles that cut through the cells
def test_each_column_is_the_chart_at_its_exposure(session, sibling, tile):
    spec = make_spec(**KW, x_axis="exposure", x_values=VALUES, exposure=0.25)
    runner = session if tile is None else sibling(tile=tile)
    got = runner.render(spec)
    grid = chart_frame(spec).grid
    means = []
    for col, ev in enumerate(VALUES):
        plain = session.render(make_spec(**KW, x_axis="roughness", exposure=ev))
        columns = slice(grid.left + col * grid.cell_width, grid.left + (col + 1) * grid.cell_width)
        # The same float product up to one rounding of 2^EV: at most one 8-bit step.
        assert np.abs(got.image[:, columns].astype(int) - plain.image[:, columns]).max() <= 1
        np.testing.assert_array_equal(got.hdr[:, columns], plain.hdr[:, columns])
        means.append(got.image[:, columns, :3].mean())
    assert means[0] < means[1] < means[2]   # the columns do differ


def test_exposure_down_the_rows_centres_on_the_specs_exposure():
    spec = make_spec(rows=5, cols=2, y_axis="exposure", x_axis="roughness", exposure=1.0)
    assert spec.axis_values("y") == [-1.0, 0.0, 1.0, 2.0, 3.0]
    assert {m.metallic for row in spec.cell_materials() for m in row} == {0.0}


def test_exposure_on_an_axis_of_the_shared_stage_is_refused():
    with pytest.raises(SpecError, match="exposure on an axis needs the cells stage"):
        make_spec(x_axis="exposure", stage="shared")
