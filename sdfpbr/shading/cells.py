"""The cells stage's layout in the image: rows x cols cells of whole pixels (so cells are
shifted copies of one another) and how large each cell's sphere appears. The plan resolves a
spec's grid here once (shading/plan.py chart_frame); everything else takes that grid."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..spec.chart_spec import ChartSpec

CELL_FILL = 0.62   # the sphere's radius over the cell's half height (or half width if narrower)

@dataclass(frozen=True)
class CellGrid:
    """Where the cells lie in the image: whole pixels each, so cells are shifted copies."""
    rows: int
    cols: int
    cell_width: int
    cell_height: int
    left: int          # pixels left of the grid
    top: int           # pixels above the grid

    def centers(self) -> np.ndarray:
        """(rows, cols, 2) pixel centres of the cells (x right, y down)."""
        x = self.left + (np.arange(self.cols) + 0.5) * self.cell_width
        y = self.top + (np.arange(self.rows) + 0.5) * self.cell_height
        return np.stack(np.broadcast_arrays(x[None, :], y[:, None]), axis=-1)

    def uniforms(self, image_height: int) -> dict:
        """The grid in GL pixel coordinates (y up from the bottom row of the image)."""
        bottom = image_height - self.top - self.rows * self.cell_height
        return {"u_cell_size": (self.cell_width, self.cell_height), "u_grid_origin": (self.left, bottom)}


def cell_grid(spec: ChartSpec) -> CellGrid:
    w, h = max(spec.width // spec.cols, 1), max(spec.height // spec.rows, 1)
    return CellGrid(spec.rows, spec.cols, w, h, (spec.width - spec.cols * w) // 2,
                    (spec.height - spec.rows * h) // 2)


def cell_sphere_radius_px(grid: CellGrid, distance_scale: float) -> float:
    """About how many pixels the cells stage's sphere's radius spans on the image: CELL_FILL of
    the cell's half side, less as the camera backs off (``distance_scale``)."""
    return CELL_FILL * min(grid.cell_width, grid.cell_height) / 2 / distance_scale


# Each cell is its own view of the stage, so where one cell's near floor meets the next cell's
# far floor the floor steps (up to 9 of 255 in 8 bits on the default chart, 1-3 across columns).
# An opaque image frames every cell in the chart's page colour instead: panes, not a floor with
# seams. Every cell gets the same border (cells stay identical); the image's margins beyond the
# grid take the page colour too. A transparent or backdrop image needs none: its floor is a
# shadow catcher that fades out before the cell's edge.
CELL_BORDER_PER_PX = 1 / 100    # border per pixel of a cell's shorter side (>= 1 px): 2 px at 204 px, a 4-px gutter
CELL_BORDER_MIN_CELL = 16       # cells smaller than this get none: it would be much of the cell


def cell_border_px(grid: CellGrid, framed: bool) -> int:
    """The page-colour border round each cell of ``grid``, in pixels (0: none); ``framed``: the
    chart frames its cells (an opaque cells-stage image whose spec keeps cell_borders)."""
    side = min(grid.cell_width, grid.cell_height)
    if not framed or side < CELL_BORDER_MIN_CELL:
        return 0
    return max(1, round(side * CELL_BORDER_PER_PX))


def cell_border_mask(grid: CellGrid, border: int, width: int, height: int, rows: slice = slice(None)) -> np.ndarray:
    """(rows, width) bool, image rows top first: the pixels a ``border`` px wide frame round each
    cell covers, the margins beyond the grid included (what shaders/cell_border.glsl paints),
    over ``rows`` of the ``width`` x ``height`` image."""
    y = np.arange(height)[rows][:, None]
    if border == 0:
        return np.zeros((len(y), width), bool)
    x = np.arange(width)[None, :] - grid.left
    y = y - grid.top

    def framed(at, cell, count):
        local = at % cell
        return (at < 0) | (at >= count * cell) | (local < border) | (local >= cell - border)
    return framed(x, grid.cell_width, grid.cols) | framed(y, grid.cell_height, grid.rows)


def prepass_frame(grid: CellGrid, width: int, height: int) -> tuple[tuple[int, int], tuple[int, int]]:
    """Where the cells stage's prepasses lie in a cell's frame (GL pixels, y up): the origin and
    size of one cell of ``grid`` plus the margins of the ``width`` x ``height`` image beyond it
    (the outer cells' pixels there see the floor further out)."""
    bottom = height - grid.top - grid.rows * grid.cell_height
    right = width - grid.left - grid.cols * grid.cell_width
    return (-grid.left, -bottom), (grid.left + grid.cell_width + right, bottom + grid.cell_height + grid.top)


# ---- the sphere prepass ------------------------------------------------------------------------
# Every cell shows the same sphere under the same camera, and a sphere's light is linear in its
# metallic (glTF's mix(dielectric, metal, metallic), lobes and layers alike). Cells whose
# materials differ only in metallic (a roughness x metallic chart's columns) share one "slot":
# the prepass shades each slot's sphere once per cell pixel as a dielectric and as a metal
# (stage_sphere_main.glsl) and each cell mixes the two by its own metallic (chart_main.glsl).
# Used where it saves shading (2 x slots < cells) and the prepass is small enough.
SPHERE_PREPASS_MAX_BYTES = 128 << 20   # RGBA float texels
GL_MIN_MAX_TEXTURE_SIZE = 16384      # the largest texture side every GL 4.5 driver allows


@dataclass(frozen=True)
class SpherePrepass:
    """Which slot each cell reads and how the prepass's tiles (one per slot and end, each over
    prepass_frame: a cell's pixels and the image's margins) are laid out: tile 2 k + e (e = 0
    dielectric, 1 metal) of slot k sits at (tile % tiles_x, tile // tiles_x)."""
    slots: np.ndarray                       # (rows, cols) int: each cell's slot
    slot_cells: tuple[tuple[int, int], ...]  # a (col, row) of each slot: whose material it shades
    origin: tuple[int, int]                 # the cell pixel of a tile's texel (0, 0)
    tile: tuple[int, int]                   # texels (width, height) of a tile
    tiles_x: int
    tiles_y: int

    @property
    def size(self) -> tuple[int, int]:
        return self.tiles_x * self.tile[0], self.tiles_y * self.tile[1]


def sphere_prepass(spec: ChartSpec, prepass: tuple[tuple[int, int], tuple[int, int]]) -> SpherePrepass | None:
    """The sphere prepass's slots and layout for ``spec``'s cells, each tile over ``prepass``
    (prepass_frame), or None where it would not save shading or would not fit (then every sphere
    pixel is shaded where it is drawn)."""
    from .material_table import material_table
    table = material_table(spec.cell_materials())          # (cells, texels, 4) as the GPU reads it
    table[:, 0, 3] = 0.0                                   # metallic aside: the rest picks the slot
    first: dict[bytes, int] = {}     # a slot's material -> the index of its first cell
    for index, row in enumerate(table):
        first.setdefault(row.tobytes(), index)
    order = {key: slot for slot, key in enumerate(first)}
    slots = np.array([order[row.tobytes()] for row in table]).reshape(spec.rows, spec.cols)
    if 2 * len(first) >= spec.rows * spec.cols:
        return None
    origin, tile = prepass
    tiles = 2 * len(first)
    if tiles * tile[0] * tile[1] * 16 > SPHERE_PREPASS_MAX_BYTES:
        return None
    # Tiles in a near-square block (the longest side bounded by the texture limit).
    tiles_x = max(1, min(tiles, round(np.sqrt(tiles * tile[1] / tile[0]))))
    tiles_y = -(-tiles // tiles_x)
    if max(tiles_x * tile[0], tiles_y * tile[1]) > GL_MIN_MAX_TEXTURE_SIZE:
        return None
    slot_cells = tuple((index % spec.cols, index // spec.cols) for index in first.values())
    return SpherePrepass(slots, slot_cells, origin, tile, tiles_x, tiles_y)
