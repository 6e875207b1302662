"""Chart specifications: a frozen dataclass made from the field table, defaults users expect,
validation in one place.

A spec comes from Python keywords, a TOML file or CLI flags; all three go through ``make_spec``
and the field table (fields.py), so every path takes the same names and gets the same checks and
the same one-line messages.
"""
from __future__ import annotations

from dataclasses import field as dataclass_field
from dataclasses import fields, make_dataclass, replace
from pathlib import Path
from typing import Any, Mapping

from ..errors import SpecError
from .bugs import get_bug
from .checks import parse_color, parse_range, parse_size  # noqa: F401  (re-exported)
from .fields import (ENTRY_SECTIONS, FIELDS, STORED_FIELDS, attr_values, read_entry_document,
                     resolve_relative_files)
from .material import GLTF_OWNS, axis_values, cell_materials, check_axes, displaced_defaults, material_array
from .presets import (BACKENDS, BRDF_MODELS, CAMERAS, DEFAULT_LIGHTS, ENV_PRESETS, FILL_LIGHT,  # noqa: F401
                      HDR_PRECISIONS, INTERSECT_METHODS, KEY_LIGHT, LIGHT_KINDS, MATERIAL_PRESETS, MAX_GRID, MAX_SIZE,
                      NORMAL_METHODS, QUALITY_PRESETS, TEXTURE_MODES, TONEMAPPERS, Light, Quality)


def _check_gltf_owns(spec) -> None:
    defaults = ChartSpec()
    for attr in GLTF_OWNS:
        if getattr(spec, attr) != getattr(defaults, attr):
            key = "materials" if attr == "row_materials" else attr
            raise SpecError(f"gltf charts the asset's own materials, one per cell; {key} applies to charts "
                            f"without gltf (--material NAME,... picks the asset's materials)")


class _ChartSpecMethods:
    """What ChartSpec has beyond its fields: validation and derived values. What a render makes
    of them (the quality preset, the BRDF it forces, the bugs it implies) the plan resolves
    (shading/plan.py)."""

    def __post_init__(self):
        for f in STORED_FIELDS:   # each field's check, from the table; stored normalised
            object.__setattr__(self, f.attr, f.check(getattr(self, f.attr)))
        if self.gltf:   # first: what the asset decides would also clash with its grid below
            _check_gltf_owns(self)
        check_axes(self)
        if self.stage == "cells" and (self.width < self.cols or self.height < self.rows):
            # (Each cell is whole pixels: with fewer pixels than cells a cell would have none.)
            raise SpecError(f"a {self.width}x{self.height} chart has fewer pixels than its {self.rows}x{self.cols} "
                            f"cells on the cells stage; make it at least {self.cols} px wide and {self.rows} px "
                            f"high, or use fewer rows or cols")

    @property
    def materials(self) -> tuple[str, ...]:
        """The public name of ``row_materials`` (the attribute keeps its name: cache keys)."""
        return self.row_materials

    # Derived values, one definition each (sdfpbr.spec.material).
    def cell_materials(self):
        """Every cell's Material, row by row."""
        return cell_materials(self)

    def material_array(self, name: str):
        """One material parameter of every cell: (rows, cols[, 3]) float64."""
        return material_array(self, name)

    def axis_values(self, axis: str) -> list[float]:
        """The values across the columns ('x') or down the rows ('y')."""
        return axis_values(self, axis)

    def uses_textures(self) -> bool:
        if self.gltf:
            return any(self.gltf_maps().has_textures.values())
        return self.textures != "none" or any((self.base_color_texture, self.orm_texture, self.normal_texture))

    def gltf_maps(self):
        """The glTF asset's materials with their textures (spec.gltf.GltfMaterials)."""
        from .gltf import gltf_materials
        return gltf_materials(self.gltf, self.gltf_materials)

    def to_dict(self) -> dict[str, Any]:
        out = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name == "lights":
                v = [{k.name: getattr(l, k.name) for k in fields(l)} for l in v]
            elif isinstance(v, tuple):
                v = list(v)
            out[f.name] = v
        return out


# The attributes, in the table's order: to_dict() and so the build cache keys keep their keys.
ChartSpec = make_dataclass(
    "ChartSpec", [(f.attr, f.annotation, dataclass_field(default=f.default)) for f in STORED_FIELDS],
    bases=(_ChartSpecMethods,), frozen=True)
ChartSpec.__module__ = __name__
ChartSpec.__doc__ = ("A chart specification; fields, defaults and checks are sdfpbr.spec.fields.FIELDS. "
                     "Build one with make_spec (names, aliases, size) or load_spec (TOML).")


SPEC_KEYS = tuple(f.name for f in fields(ChartSpec))   # attribute names, as to_dict() writes them


def grid_size(rows: int, cols: int) -> tuple[int, int]:
    """The render size a grid gets when none is given: the default side on the longer edge and
    square cells, so a 1x5 strip is not a square of mostly empty floor."""
    side = ChartSpec().width
    if cols >= rows:
        return side, max(1, round(side * rows / cols))
    return max(1, round(side * cols / rows)), side


def _size_follows_grid(base: ChartSpec, values: dict, spec: ChartSpec) -> ChartSpec:
    """``spec`` (checked) with a size nobody chose following its grid: the base's size was its
    grid's and no size was given. A chosen size stays."""
    if {"width", "height"} & values.keys() or (base.width, base.height) != grid_size(base.rows, base.cols):
        return spec
    size = grid_size(spec.rows, spec.cols)
    return spec if size == (spec.width, spec.height) else replace(spec, width=size[0], height=size[1])


def _build(base: ChartSpec, values: dict) -> ChartSpec:
    """``base`` with ``values`` and the defaults that follow them (axes' parameters, the size)."""
    return _size_follows_grid(base, values, replace(base, **values, **displaced_defaults(base, values, ChartSpec())))


def make_spec(base: ChartSpec | None = None, **overrides) -> ChartSpec:
    """A validated spec: ``base`` (or the defaults) with ``overrides`` given by field name or alias
    (``size="256x256"``, ``materials=[...]``, ``row_materials=[...]``); unknown names are errors."""
    values = attr_values(overrides, "option")
    base = base or ChartSpec()
    try:
        return _build(base, values)
    except TypeError as exc:   # a wrongly typed value that the checks did not name
        raise SpecError(str(exc)) from None


def spec_from_mapping(data: Mapping[str, Any], base: ChartSpec | None = None, where: str = "spec") -> ChartSpec:
    """A spec from a TOML table (keys are field names or aliases)."""
    try:
        if not isinstance(data, Mapping):
            raise SpecError(f"a spec must be a table of settings, got {type(data).__name__}")
        base = base or ChartSpec()
        values = attr_values(data, "key")
        return _build(base, values)
    except SpecError as exc:
        raise SpecError(f"{where}: {exc}") from None


def entry_refusal(path: str | Path, entry: dict) -> SpecError | None:
    """Why a [compare] or [sweep] entry is no chart spec, naming the commands that read it
    (read as a spec, its [spec] base would be drawn as a plain chart and the rest dropped)."""
    from ..inputs import printable
    section = next((k for k in ENTRY_SECTIONS if k in entry), None)
    if section is None:
        return None
    name, folder = printable(path), printable(Path(path).parent)
    other = ("`sdfpbr sweep FIELD --values V,... --spec FILE` sweeps a spec file of its [spec] keys"
             if section == "sweep" else "`sdfpbr compare A.toml B.toml` compares two spec files (`--bug NAME` a bug)")
    return SpecError(f"{name} is a [{section}] gallery entry, not a chart spec: `sdfpbr build {folder} -o OUT` "
                     f"renders it (with the other entries in its folder); {other}")


def load_spec(path: str | Path, base: ChartSpec | None = None) -> ChartSpec:
    """The chart spec a TOML file describes: a spec file or a chart entry (``caption`` and the
    spec keys). A [compare] or [sweep] entry is refused in one line that names the commands
    which read it (``sdfpbr build``; the gallery reads its [spec] base itself). Files it names
    are found beside it first."""
    spec_mapping, entry = read_entry_document(path)
    refusal = entry_refusal(path, entry)
    if refusal is not None:
        raise refusal
    return spec_from_mapping(resolve_relative_files(spec_mapping, Path(path).parent), base, where=str(path))


def as_spec(spec: "ChartSpec | str | Path | None", what: str = "spec") -> ChartSpec:
    """A ChartSpec from a spec, a TOML path, or None (the default chart): what every public
    function that takes a spec accepts."""
    if spec is None:
        return ChartSpec()
    if isinstance(spec, (str, Path)):
        return load_spec(spec)
    if not isinstance(spec, ChartSpec):
        raise SpecError(f"{what} must be a ChartSpec or a TOML path, got {type(spec).__name__}")
    return spec


def with_bug(spec: ChartSpec, name: str) -> ChartSpec:
    """``spec`` with bug ``name`` switched on and made visible (see Bug.apply)."""
    return get_bug(name).apply(spec)


def bug_requirements(name: str) -> dict[str, Any]:
    """The spec overrides that make bug ``name`` visible (e.g. textured spheres)."""
    return dict(get_bug(name).requires)


__all__ = ["ChartSpec", "Light", "Quality", "FIELDS", "SPEC_KEYS", "as_spec", "make_spec", "spec_from_mapping",
           "load_spec", "parse_range", "parse_size", "parse_color", "MATERIAL_PRESETS", "QUALITY_PRESETS",
           "ENV_PRESETS", "TONEMAPPERS", "BRDF_MODELS", "CAMERAS", "INTERSECT_METHODS", "BACKENDS", "TEXTURE_MODES",
           "LIGHT_KINDS", "NORMAL_METHODS", "HDR_PRECISIONS", "DEFAULT_LIGHTS", "KEY_LIGHT", "FILL_LIGHT",
           "MAX_GRID", "MAX_SIZE", "with_bug", "bug_requirements"]
