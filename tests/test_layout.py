"""Tests for sdfpbr.layout: chart composition around a synthetic render."""

import numpy as np
import pytest

from sdfpbr.image import chart_labels
from sdfpbr.image.layout import (DEFAULT_COLUMN_AXIS_TITLE, Cell, compose_chart, forget_layouts, label_text,
                                 render_area_offset)
from sdfpbr.spec.chart_spec import make_spec

TITLE = "Material chart"
FOOTER = "ACES filmic · exposure +0.0 EV · environment: studio"


def synthetic_render(height, width, n_rows, n_cols, background_alpha=255):
    """Dark, slightly textured background with filled white discs on an n_rows x n_cols grid."""
    rng = np.random.default_rng(1)
    img = np.zeros((height, width, 4), np.uint8)
    img[..., :3] = rng.integers(20, 40, (height, width, 3), dtype=np.uint8)
    img[..., 3] = background_alpha
    yy, xx = np.mgrid[:height, :width]
    cells = []
    for r in range(n_rows):
        for c in range(n_cols):
            # Slightly irregular centres, so a label placed on the column/row centre of a
            # uniform grid (instead of on the cells) would be caught.
            cx = (c + 0.5) * width / n_cols + 3 * c
            cy = (r + 0.5) * height / n_rows - 2 * r
            radius = 0.35 * min(width / n_cols, height / n_rows)
            img[(xx - cx) ** 2 + (yy - cy) ** 2 <= radius**2] = 255
            cells.append(Cell(r, c, cx, cy, radius))
    return img, cells


def runs(mask_1d):
    """(start, stop) index ranges of consecutive True values."""
    padded = np.concatenate([[False], mask_1d, [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    return list(zip(edges[::2], edges[1::2]))


def ink(chart, background):
    return np.any(chart != np.asarray(background, np.uint8), axis=-1)


def column_label_centres(chart, offset, render_shape, cells, n_cols, background):
    """Horizontal ink centre of each column label (last text line above the render area)."""
    x0, y0 = offset
    top = ink(chart[:y0], background)
    line = runs(top.any(axis=1))[-1]  # the text line nearest the render area
    band = top[line[0]:line[1]]
    cxs = [np.mean([c.cx for c in cells if c.col == i]) + x0 for i in range(n_cols)]
    bounds = [0] + [(a + b) / 2 for a, b in zip(cxs, cxs[1:])] + [chart.shape[1]]
    centres = []
    for i in range(n_cols):
        xs = np.flatnonzero(band.any(axis=0))
        xs = xs[(xs >= bounds[i]) & (xs < bounds[i + 1])]
        assert xs.size, f"no label ink for column {i}"
        centres.append((xs.min() + xs.max() + 1) / 2)
    return np.array(centres), np.array(cxs), line


def row_label_centres(chart, offset, render_shape, cells, n_rows, background):
    """Vertical ink centre of each row label (right-most ink block left of the render area)."""
    x0, y0 = offset
    h = render_shape[0]
    left = ink(chart[y0:y0 + h, :x0], background)
    block = runs(left.any(axis=0))[-1]
    strip = left[:, block[0]:block[1]]
    cys = [np.mean([c.cy for c in cells if c.row == i]) for i in range(n_rows)]
    bounds = [0] + [(a + b) / 2 for a, b in zip(cys, cys[1:])] + [h]
    centres = []
    for i in range(n_rows):
        ys = np.flatnonzero(strip.any(axis=1))
        ys = ys[(ys >= bounds[i]) & (ys < bounds[i + 1])]
        assert ys.size, f"no label ink for row {i}"
        centres.append((ys.min() + ys.max() + 1) / 2 + y0)
    return np.array(centres), np.array(cys) + y0, block


@pytest.fixture(scope="module")
def chart_2x3():
    img, cells = synthetic_render(360, 540, 2, 3)
    chart = compose_chart(img, cells, [0, 0.5, 1], [0, 1], TITLE, FOOTER)
    offset = render_area_offset(img.shape, 2, 3, TITLE, FOOTER)
    return img, cells, chart, offset


def test_output_type_and_size(chart_2x3):
    img, _, chart, _ = chart_2x3
    assert chart.dtype == np.uint8 and chart.ndim == 3 and chart.shape[2] == 4
    assert chart.shape[0] > img.shape[0] and chart.shape[1] > img.shape[1]
    assert (chart[..., 3] == 255).all()  # opaque mode


def test_render_pasted_pixel_exact(chart_2x3):
    img, _, chart, (x0, y0) = chart_2x3
    h, w = img.shape[:2]
    assert x0 > 0 and y0 > 0 and x0 + w < chart.shape[1] and y0 + h < chart.shape[0]
    np.testing.assert_array_equal(chart[y0:y0 + h, x0:x0 + w], img)  # also: no text ink on the render


def test_column_labels_centred_on_columns(chart_2x3):
    img, cells, chart, offset = chart_2x3
    found, expected, _ = column_label_centres(chart, offset, img.shape, cells, 3, chart[0, 0])
    np.testing.assert_allclose(found, expected, atol=2.0)


def test_row_labels_centred_on_rows(chart_2x3):
    img, cells, chart, offset = chart_2x3
    found, expected, block = row_label_centres(chart, offset, img.shape, cells, 2, chart[0, 0])
    np.testing.assert_allclose(found, expected, atol=2.0)
    assert block[1] < offset[0]  # labels stop before the render area


def test_text_in_all_margins(chart_2x3):
    img, _, chart, (x0, y0) = chart_2x3
    h, w = img.shape[:2]
    bg = chart[0, 0]
    top_lines = runs(ink(chart[:y0], bg).any(axis=1))
    assert len(top_lines) == 3  # title, column axis title, column labels
    assert ink(chart[y0 + h:], bg).any()  # footer
    left_blocks = runs(ink(chart[y0:y0 + h, :x0], bg).any(axis=0))
    assert len(left_blocks) == 2  # rotated row axis title, row labels
    rotated = ink(chart[:, left_blocks[0][0]:left_blocks[0][1]], bg)
    ys = np.flatnonzero(rotated.any(axis=1))
    assert ys.max() - ys.min() > rotated.shape[1]  # taller than wide: it is rotated


def test_label_text():
    assert label_text(0) == "0"
    assert label_text(1) == "1"
    assert label_text(0.25) == "0.25"
    assert label_text(1 / 3) == "0.33"
    assert label_text(0.5) == "0.5"
    assert label_text(0.125) == "0.13"
    assert label_text(2 / 3) == "0.67"
    assert label_text(-0.001) == "0"


def test_row_names_and_offset_consistency():
    img, cells = synthetic_render(300, 300, 2, 2)
    names = ["dielectric", "gold"]
    chart = compose_chart(img, cells, [0, 1], [0, 1], TITLE, FOOTER, row_names=names)
    plain = render_area_offset(img.shape, 2, 2, TITLE, FOOTER)
    x0, y0 = render_area_offset(img.shape, 2, 2, TITLE, FOOTER, row_values=[0, 1], row_names=names)
    assert x0 > plain[0]  # wider row labels widen the left margin
    np.testing.assert_array_equal(chart[y0:y0 + 300, x0:x0 + 300], img)
    blocks = runs(ink(chart[y0:y0 + 300, :x0], chart[0, 0]).any(axis=0))
    assert blocks[-1][1] - blocks[1][0] > 60  # after the axis title: "0 · dielectric", not just "0"


def test_transparent_mode():
    img, cells = synthetic_render(300, 450, 2, 3, background_alpha=0)
    chart = compose_chart(img, cells, [0, 0.5, 1], [0, 1], TITLE, FOOTER, transparent=True)
    x0, y0 = render_area_offset(img.shape, 2, 3, TITLE, FOOTER)
    np.testing.assert_array_equal(chart[y0:y0 + 300, x0:x0 + 450], img)  # render alpha kept
    for corner in (chart[0, 0], chart[0, -1], chart[-1, 0], chart[-1, -1]):
        assert corner[3] == 0
    labels = chart[:y0, x0:x0 + 450]
    opaque = labels[labels[..., 3] == 255]
    assert len(opaque) > 0
    assert (opaque[:, :3].min(axis=1) > 180).any()  # light text ...
    assert (opaque[:, :3].max(axis=1) < 60).any()  # ... with a dark outline
    transparent_bg = np.zeros(4, np.uint8)
    found, expected, _ = column_label_centres(chart, (x0, y0), img.shape, cells, 3, transparent_bg)
    np.testing.assert_allclose(found, expected, atol=2.0)


def _contrast(a, b):
    def luminance(rgb):
        c = np.asarray(rgb[:3], float) / 255
        return (np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4) @ [0.2126, 0.7152, 0.0722])
    la, lb = sorted((luminance(a), luminance(b)))
    return (lb + 0.05) / (la + 0.05)


@pytest.mark.parametrize("page", [(1.0, 1.0, 1.0), (0.95, 0.93, 0.85), (0.2, 0.3, 0.6), (0.0, 0.0, 0.0)])
def test_labels_laid_onto_a_page_colour(page):
    """A render laid onto a backdrop puts its labels on that page too: opaque margins of the
    page's colour (transparent or not), plain text that reads on it (WCAG contrast of the title
    and the value labels at least 4.5, no outline: every text pixel lies between the page and
    the text colour)."""
    img, cells = synthetic_render(300, 450, 2, 3)
    page8 = np.round(255 * np.array(page)).astype(np.uint8)
    for transparent in (False, True):
        chart = compose_chart(img, cells, [0, 0.5, 1], [0, 1], TITLE, FOOTER, transparent=transparent, page_srgb=page)
        x0, y0 = render_area_offset(img.shape, 2, 3, TITLE, FOOTER)
        np.testing.assert_array_equal(chart[y0:y0 + 300, x0:x0 + 450], img)
        for corner in (chart[0, 0], chart[0, -1], chart[-1, 0], chart[-1, -1]):
            np.testing.assert_array_equal(corner, [*page8, 255])
        margin = chart[:y0, x0:x0 + 450].reshape(-1, 4).astype(int)
        text = margin[np.abs(margin[:, :3] - page8).max(1) > 0]
        farthest = text[np.abs(text[:, :3] - page8).sum(1).argmax()]
        assert _contrast(farthest, page8) >= 4.5 and (text[:, 3] == 255).all()
        # Anti-aliased text mixes page and ink: each channel on one side of the page's.
        side = np.sign(farthest[:3] - page8.astype(int))
        assert ((text[:, :3] - page8) * side >= 0).all()
        found, expected, _ = column_label_centres(chart, (x0, y0), img.shape, cells, 3, np.array([*page8, 255]))
        np.testing.assert_allclose(found, expected, atol=2.0)
        # The hierarchy of the chart's own ground kept as far as the page allows: each piece of
        # text's ink has at least the contrast the next less prominent one has.
        from sdfpbr.image.layout import label_boxes
        boxes = dict(label_boxes(img.shape, cells, [0, 0.5, 1], [0, 1], TITLE, FOOTER))
        order = [TITLE, "0.5", DEFAULT_COLUMN_AXIS_TITLE, FOOTER]      # title, label, axis, footer
        contrasts = []
        for name in order:
            left, top, right, bottom = (int(round(v)) for v in boxes[name])
            ink = chart[top:bottom, left:right].reshape(-1, 4).astype(int)
            contrasts.append(max(_contrast(p, page8) for p in ink[np.abs(ink[:, :3] - page8).sum(1) > 0][::7]))
        assert all(a >= b - 0.05 for a, b in zip(contrasts, contrasts[1:])) and contrasts[-1] >= 3.0, contrasts


@pytest.mark.parametrize("shape", [(300, 400), (128, 128)])
def test_a_long_title_wraps_instead_of_widening_the_chart(shape):
    """A title wider than the chart's other text wraps at its spaces to that width (a word
    wider than it is cut with an ellipsis): the canvas is as wide as with no title at all, and
    every line lies inside it."""
    from sdfpbr.image.layout import label_boxes
    img, cells = synthetic_render(*shape, 2, 3)
    words = "Roughness and metallic of a measured gold under the studio environment, ACES at +1 EV"
    for title in (words, "x" * 300):
        chart = compose_chart(img, cells, [0, 0.5, 1], [0, 1], title, FOOTER)
        untitled = compose_chart(img, cells, [0, 0.5, 1], [0, 1], "", FOOTER)
        assert chart.shape[1] == untitled.shape[1]
        boxes = label_boxes(img.shape, cells, [0, 0.5, 1], [0, 1], title, FOOTER)
        lines = []
        for text, box in boxes:          # the title's lines come first
            if not (text in title or text.endswith("…")):
                break
            lines.append((text, box))
        assert all(0 <= b[0] and b[2] <= chart.shape[1] for _, b in lines)
        if title == words:
            assert len(lines) > 1 and " ".join(t for t, _ in lines) == words
        else:
            assert len(lines) == 1 and lines[0][0].endswith("…")


def test_a_title_keeps_its_own_line_breaks_and_control_characters_are_spaces():
    """A title's newline starts a line of it (it crashed the font's layout); tabs and carriage
    returns read as spaces there and in every other label."""
    from sdfpbr.image.layout import label_boxes
    img, cells = synthetic_render(200, 200, 2, 2)
    boxes = label_boxes(img.shape, cells, [0, 1], [0, 1], "Line one\nline\ttwo", FOOTER)
    assert [t for t, _ in boxes[:2]] == ["Line one", "line two"] and boxes[0][1][3] < boxes[1][1][1]
    chart = compose_chart(img, cells, [0, 1], [0, 1], "Line one\nline\ttwo", "a\nb", cell_names=["x\ny"] * 4)
    assert chart.shape[0] > img.shape[0]


def test_small_render_still_labeled():
    img, cells = synthetic_render(256, 256, 3, 3)
    values = [0, 0.5, 1]
    chart = compose_chart(img, cells, values, values, TITLE, FOOTER)
    offset = render_area_offset(img.shape, 3, 3, TITLE, FOOTER)
    x0, y0 = offset
    np.testing.assert_array_equal(chart[y0:y0 + 256, x0:x0 + 256], img)
    bg = chart[0, 0]
    found, expected, line = column_label_centres(chart, offset, img.shape, cells, 3, bg)
    np.testing.assert_allclose(found, expected, atol=2.0)
    assert line[1] - line[0] >= 7  # digits of an ~11 px font, not a tiny bitmap font
    found, expected, _ = row_label_centres(chart, offset, img.shape, cells, 3, bg)
    np.testing.assert_allclose(found, expected, atol=2.0)


def test_large_render_font_scales():
    img, cells = synthetic_render(1024, 1024, 2, 2)
    chart = compose_chart(img, cells, [0, 1], [0, 1], TITLE, FOOTER)
    offset = render_area_offset(img.shape, 2, 2, TITLE, FOOTER)
    _, _, line = column_label_centres(chart, offset, img.shape, cells, 2, chart[0, 0])
    assert 13 <= line[1] - line[0] <= 24  # ~22 px font: digits about 15 px tall


def test_rejects_non_rgba():
    with pytest.raises(ValueError):
        compose_chart(np.zeros((10, 10, 3), np.uint8), [], [0], [0], TITLE, FOOTER)


def test_default_title_says_what_the_chart_shows():
    assert chart_labels.default_title(make_spec()) == "Roughness × metallic — 5 rows × 5 columns"
    assert (chart_labels.default_title(make_spec(materials=["gold", "copper"]))
            == "Roughness × measured metals — 2 rows × 5 columns")
    assert chart_labels.default_title(make_spec(metallic=(1, 1), rows=1)) == "Roughness, metallic 1 — 1 row × 5 columns"
    assert (chart_labels.default_title(make_spec(roughness=(0.3, 0.3), metallic=(0, 0)))
            == "Roughness 0.3, metallic 0 — 5 rows × 5 columns")
    # Parameters by their own names in running text, as on their axes.
    assert (chart_labels.default_title(make_spec(x_axis="ior", y_axis="specular"))
            == "IOR × specular — 5 rows × 5 columns")
    assert (chart_labels.default_title(make_spec(x_axis="base_color_hue", rows=1))
            == "Base colour hue, metallic 0 — 1 row × 5 columns")


def test_a_kept_layout_labels_every_render_alike_and_is_not_changed_by_its_charts():
    """The text canvas is drawn once per layout: a second render with the same layout gets the
    same margins, its own pixels inside, and writing into a returned chart changes no later one."""
    cells = [Cell(r, c, 20.0 + 40 * c, 20.0 + 40 * r, 15.0) for r in range(2) for c in range(3)]
    a = np.zeros((80, 120, 4), np.uint8) + np.array([200, 0, 0, 255], np.uint8)
    b = np.zeros((80, 120, 4), np.uint8) + np.array([0, 0, 200, 255], np.uint8)
    first = compose_chart(a, cells, [0, 0.5, 1], [0, 1], TITLE, FOOTER)
    first[:] = 7                                                    # scribble on a returned chart
    second = compose_chart(b, cells, [0, 0.5, 1], [0, 1], TITLE + " ", FOOTER)   # another layout: drawn anew
    third = compose_chart(b, cells, [0, 0.5, 1], [0, 1], TITLE, FOOTER)          # the first layout, kept
    x0, y0 = render_area_offset(b.shape, 2, 3, TITLE, FOOTER)
    inside = np.zeros(third.shape[:2], bool)
    inside[y0:y0 + 80, x0:x0 + 120] = True
    np.testing.assert_array_equal(third[inside].reshape(80, 120, 4), b)
    assert (third[~inside] != 7).any() and second.shape == third.shape
    forget_layouts()
    fresh = compose_chart(a, cells, [0, 0.5, 1], [0, 1], TITLE, FOOTER)     # drawn anew
    np.testing.assert_array_equal(fresh[~inside], third[~inside])  # the same margins, text and all


def test_a_label_drawn_once_serves_every_layout_that_shows_it():
    """Text patches are kept by all that decides their pixels: a chart whose title alone differs
    takes its axis values from the kept patches, pixel for pixel what drawing them from nothing
    gives, and a kept patch cannot be written into."""
    from sdfpbr.image import layout
    cells = [Cell(r, c, 20.0 + 40 * c, 20.0 + 40 * r, 15.0) for r in range(2) for c in range(3)]
    render = np.zeros((80, 120, 4), np.uint8) + np.array([30, 60, 90, 255], np.uint8)
    forget_layouts()
    compose_chart(render, cells, [0, 0.5, 1], [0, 1], TITLE, FOOTER)
    drawn = len(layout._text_patches)
    kept = compose_chart(render, cells, [0, 0.5, 1], [0, 1], "Another title", FOOTER)
    assert len(layout._text_patches) == drawn + 1                  # the new title alone was drawn
    forget_layouts()
    fresh = compose_chart(render, cells, [0, 0.5, 1], [0, 1], "Another title", FOOTER)
    np.testing.assert_array_equal(kept, fresh)
    style = layout._styles(120)["label"]
    patch = layout._text_patch(style, "0.5", 0, (30, 20), (2.0, 15.0))
    assert patch[..., 3].any() and not patch.flags.writeable


def _overlap(a, b):
    return min(a[2], b[2]) > max(a[0], b[0]) and min(a[3], b[3]) > max(a[1], b[1])


@pytest.mark.parametrize("size", [(128, 128), (1024, 128), (128, 1024), (300, 200), (1024, 1024), (2048, 512)])
def test_no_two_labels_collide_for_any_grid_up_to_64x64(size):
    """Column and row labels thin out (every k-th, both ends kept) before they collide; the
    titles, footer and rotated axis title keep their own lines. Cells come from the chart's
    own camera, as on a render of that grid."""
    from sdfpbr.image.chart_labels import chart_cells, footer_text, default_title
    from sdfpbr.image.layout import label_boxes
    from sdfpbr.shading.plan import chart_frame
    width, height = size
    for rows in (1, 2, 5, 11, 20, 33, 64):
        for cols in (1, 3, 7, 16, 24, 40, 64):
            spec = make_spec(rows=rows, cols=cols, width=width, height=height)
            frame = chart_frame(spec)
            cells = chart_cells(frame)
            columns, row_values = spec.axis_values("x"), spec.axis_values("y")
            boxes = label_boxes((height, width), cells, columns, row_values, default_title(spec), footer_text(frame))
            for i, (ta, a) in enumerate(boxes):
                for tb, b in boxes[i + 1:]:
                    assert not _overlap(a, b), (rows, cols, size, ta, a, tb, b)
            texts = [t for t, _ in boxes]
            # Both ends of each axis stay labelled.
            for values in (columns, row_values):
                assert label_text(values[0]) in texts and label_text(values[-1]) in texts, (rows, cols, size)


@pytest.mark.parametrize("transparent", [False, True])
@pytest.mark.parametrize("shape,grid", [((360, 540), (2, 3)), ((128, 1024), (1, 11)), ((1500, 1100), (6, 4))])
def test_every_label_is_drawn_inside_its_own_box(shape, grid, transparent):
    """Each label is drawn on its own patch (an 8192² chart holds no chart-sized text layer):
    every pixel of the margins that is not background lies in some label's ink box (from the
    font's metrics, not from the drawing, which they bound), and every box has ink."""
    from sdfpbr.image.layout import label_boxes
    img, cells = synthetic_render(*shape, *grid)
    columns, rows = list(np.linspace(0, 1, grid[1])), list(np.linspace(0, 1, grid[0]))
    chart = compose_chart(img, cells, columns, rows, TITLE, FOOTER, transparent=transparent)
    x0, y0 = render_area_offset(img.shape, *grid, TITLE, FOOTER, row_values=rows)
    background = (0, 0, 0, 0) if transparent else (24, 24, 24, 255)
    marked = ink(chart, background)
    marked[y0:y0 + shape[0], x0:x0 + shape[1]] = False
    covered = np.zeros_like(marked)
    for text, (left, top, right, bottom) in label_boxes(img.shape, cells, columns, rows, TITLE, FOOTER):
        box = (slice(max(int(np.floor(top)), 0), int(np.ceil(bottom))),
               slice(max(int(np.floor(left)), 0), int(np.ceil(right))))
        covered[box] = True
        assert marked[box].any(), f"no ink for {text!r}"
    assert not (marked & ~covered).any(), "ink outside every label's box"


@pytest.mark.parametrize("size", [160, 320, 640])
def test_cell_names_in_a_row_share_one_baseline(size):
    """Names with and without ascenders and descenders ("Hd", "ace", "gem") sit on one
    baseline under their spheres: the ink of the two without descenders ends on the same row
    and "gem"'s 'g' hangs below it (centring each name's own ink put "ace" higher)."""
    from sdfpbr.image.layout import name_cells
    blank = np.zeros((size, 3 * size // 2, 4), np.uint8)
    blank[..., 3] = 255
    cells = [Cell(0, c, (c + 0.5) * size / 2, size / 2, size / 5) for c in range(3)]
    named = name_cells(blank, cells, ["Hd", "ace", "gem"], (0, 0), blank.shape[:2])
    ink = named[..., :3].max(-1) > 128
    bottoms = [np.nonzero(ink[:, int(c.cx - size / 5):int(c.cx + size / 5)].any(1))[0].max() for c in cells]
    assert bottoms[0] == bottoms[1] < bottoms[2]


REFERENCE_FOOTER_PARTS = ["tone map aces", "exposure +0 EV", "env studio", "BRDF gltf",
                          "path-traced reference, 16 spp, 32 bounces, rel. stderr 8.66%"]


@pytest.mark.parametrize("side", [128, 256, 512, 1024])
def test_a_long_footer_wraps_and_the_row_axis_title_stays_by_its_labels(side):
    """A footer wider than the rest of the chart wraps between its parts instead of widening
    the canvas (the reference's footer under a 256² render set a 702-px canvas), in its parts'
    order, each line inside the chart; and the rotated row axis title sits beside the row
    labels whatever widens the margins (it stood 200 px off them)."""
    from sdfpbr.image.layout import FOOTER_SEPARATOR, label_boxes
    img, cells = synthetic_render(side, side, 5, 5)
    values = list(np.linspace(0, 1, 5))
    footer = FOOTER_SEPARATOR.join(REFERENCE_FOOTER_PARTS)
    without = compose_chart(img, cells, values, values, TITLE, "")
    chart = compose_chart(img, cells, values, values, TITLE, footer)
    boxes = label_boxes(img.shape, cells, values, values, TITLE, footer)
    lines = [(t, b) for t, b in boxes if any(p in t for p in REFERENCE_FOOTER_PARTS)]
    assert FOOTER_SEPARATOR.join(t for t, _ in lines) == footer
    assert all(0 <= b[0] and b[2] <= chart.shape[1] for _, b in lines)
    widest_part = max([b[2] - b[0] for t, b in lines if FOOTER_SEPARATOR not in t], default=0)
    if widest_part < without.shape[1] - 2 * 16:          # each part fits the chart as it is
        assert chart.shape[1] == without.shape[1], (side, chart.shape, without.shape)
    assert len(lines) > 1 or side >= 1024

    def title_to_labels(footer_text):
        boxes = label_boxes(img.shape, cells, values, values, TITLE, footer_text)
        x0 = render_area_offset(img.shape, 5, 5, TITLE, footer_text)[0]
        (title,) = [b for t, b in boxes if t == "metallic"]
        rows = [b for t, b in boxes if t in {label_text(v) for v in values} and b[2] < x0]
        return min(b[0] for b in rows) - title[2]
    assert title_to_labels(footer) == title_to_labels("") > 0


# A still chart's labels in a new process: the canvas's digest, where the render goes, and
# whether Pillow was imported to make it.
NEW_PROCESS_CANVAS = """
import hashlib, sys
from sdfpbr.image.chart_labels import labelled_canvas
from sdfpbr.shading.plan import chart_frame
from sdfpbr.spec.chart_spec import make_spec
spec = make_spec(rows=2, cols=3, width=240, height=160)
canvas, origin = labelled_canvas(spec, chart_frame(spec))
print(hashlib.sha256(canvas.tobytes()).hexdigest(), canvas.shape, origin, "PIL" in sys.modules)
"""


def _canvas_in_a_new_process(cache_dir):
    import os
    import subprocess
    import sys
    r = subprocess.run([sys.executable, "-c", NEW_PROCESS_CANVAS],
                       env={**os.environ, "SDFPBR_CACHE_DIR": str(cache_dir)},
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    *canvas, pillow = r.stdout.split()
    return " ".join(canvas), pillow == "True", r.stderr


def _system_font():
    from sdfpbr.image.text import SYSTEM_FONTS
    import os
    if not os.path.isfile(SYSTEM_FONTS[0]):
        pytest.skip(f"labels are kept on disk only in the system font, absent here: {SYSTEM_FONTS[0]} "
                    "(Debian's fonts-dejavu-core)")
    return SYSTEM_FONTS[0]


def test_a_still_charts_labels_are_read_back_in_a_new_process_without_pillow(tmp_path):
    """The first process draws the labels with Pillow and keeps them in the disk cache; the next
    reads them, imports no Pillow, and gets the same canvas byte for byte. An entry that does
    not verify is reported, dropped and drawn again, to the same bytes."""
    _system_font()
    drawn, drawn_with_pillow, _ = _canvas_in_a_new_process(tmp_path)
    read, read_with_pillow, _ = _canvas_in_a_new_process(tmp_path)
    assert drawn_with_pillow and not read_with_pillow
    assert read == drawn
    (entry,) = (tmp_path / "labels").glob("*.npz")
    entry.write_bytes(entry.read_bytes()[:200])                       # truncated
    again, again_with_pillow, stderr = _canvas_in_a_new_process(tmp_path)
    assert again == drawn and again_with_pillow and "is bad" in stderr


def test_labels_are_kept_on_disk_only_for_the_font_file_they_were_drawn_in(tmp_path, monkeypatch):
    """The key holds the font file's identity: the same path with another file under it (a
    font package updated) keys other entries; a font that is not the system file (Pillow's own,
    where DejaVu is absent) keeps nothing on disk; an animation's labels (not on_disk) neither."""
    import os
    import shutil
    from sdfpbr.image import layout, text
    font = tmp_path / "font.ttf"
    shutil.copy(_system_font(), font)
    monkeypatch.setenv("SDFPBR_CACHE_DIR", str(tmp_path / "cache"))
    cells = [Cell(r, c, 20.0 + 40 * c, 20.0 + 40 * r, 15.0) for r in range(2) for c in range(3)]
    args = ((80, 120), cells, [0, 0.5, 1], [0, 1], TITLE, FOOTER)

    def kept_entries(fonts, on_disk=True):
        monkeypatch.setattr(text, "SYSTEM_FONTS", fonts)
        monkeypatch.setattr(layout, "SYSTEM_FONTS", fonts)
        for cached in (layout._drawing_identity, text.load_font):
            cached.cache_clear()
        forget_layouts()
        layout.chart_canvas(*args, on_disk=on_disk)
        return sorted(p.name for p in (tmp_path / "cache" / "labels").glob("*.npz"))

    try:
        first = kept_entries((str(font),))
        assert len(first) == 1
        assert kept_entries((str(font),)) == first                     # read back: nothing new
        os.utime(font, ns=(0, 10**18))                                 # the file replaced in place
        second = kept_entries((str(font),))
        assert len(second) == 2 and set(first) < set(second)
        assert kept_entries((str(tmp_path / "absent.ttf"),)) == second  # Pillow's own font: not kept
        os.utime(font, ns=(0, 2 * 10**18))
        assert kept_entries((str(font),), on_disk=False) == second     # an animation frame's: not kept
    finally:
        monkeypatch.undo()
        for cached in (layout._drawing_identity, text.load_font):
            cached.cache_clear()
        forget_layouts()


def test_measured_metal_rows_are_named_without_their_shared_value():
    """A metals chart labelled each row '1 · gold': the metallic value all rows share is said
    once, in the row axis's title; rows with values of their own keep them."""
    from sdfpbr.image import chart_labels
    from sdfpbr.image.layout import row_label_texts
    assert row_label_texts([1.0, 1.0], ["gold", "copper"]) == ["gold", "copper"]
    assert row_label_texts([0.0, 1.0], ["gold", "copper"]) == ["0 · gold", "1 · copper"]
    metals = make_spec(materials=["gold", "copper"])
    assert chart_labels.row_names(metals) == ["gold", "copper"]
    assert chart_labels.row_axis_title(metals) == "measured metals, metallic 1"
    assert chart_labels.row_axis_title(make_spec(metals, metallic=(0.0, 1.0))) == "metallic"
    assert chart_labels.row_axis_title(make_spec()) == "metallic"


def test_a_chart_without_axes_sits_centred_on_its_page():
    """A glTF chart names its cells and has no axes: its grid sat 87 px from the left and 27 from
    the right (room kept for row labels it has not). Now the margins match."""
    from pathlib import Path

    from sdfpbr.image import chart_labels
    from sdfpbr.shading.plan import chart_frame
    spec = make_spec(gltf=str(Path(__file__).parents[1] / "charts" / "materials.glb"), size="768x512")
    canvas, (x, y) = chart_labels.labelled_canvas(spec, chart_frame(spec))
    left, right = x, canvas.shape[1] - x - spec.width
    assert left == right, (left, right)
    plain = make_spec(size="768x512")
    canvas, (x, _) = chart_labels.labelled_canvas(plain, chart_frame(plain))
    assert x > canvas.shape[1] - x - plain.width       # a chart with row labels keeps their room
