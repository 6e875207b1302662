"""The cells stage's layout in the image: rows x cols cells of whole pixels (so cells are
shifted copies of one another) and how large each cell's sphere appears. Read by the camera,
the plan (the bounce plate's grid), the renderer and the labels."""
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


def cell_sphere_radius_px(spec: ChartSpec) -> float:
    """About how many pixels the cells stage's sphere's radius spans on the image: CELL_FILL of
    the cell's half side, less as the camera backs off."""
    grid = cell_grid(spec)
    return CELL_FILL * min(grid.cell_width, grid.cell_height) / 2 / spec.camera_distance_scale
