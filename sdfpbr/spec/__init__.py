"""The chart spec: what a chart shows, from Python keywords, TOML files or CLI flags alike.

``fields`` holds the one table of fields; ``chart_spec`` the ChartSpec class and its readers;
``presets`` the named materials, qualities and lights; ``bugs`` the catalog of PBR mistakes."""
from .bugs import BUGS, Bug, get_bug
from .chart_spec import ChartSpec, bug_requirements, load_spec, make_spec, spec_from_mapping, with_bug
from .fields import (ENTRY_KEYS, FIELD_NAMES, FIELDS, Field, field_value, field_value_from_text, read_entry_document,
                     resolve_field, spec_to_flags, spec_to_toml, split_entry, sweep_defaults, sweep_values_from_text)
from .presets import (BACKENDS, BRDF_MODELS, CAMERAS, DEFAULT_LIGHTS, ENV_PRESETS, HDR_PRECISIONS, INTERSECT_METHODS,
                      MATERIAL_PRESETS, QUALITY_PRESETS, TEXTURE_MODES, TONEMAPPERS, Light, Quality)

__all__ = ["BUGS", "Bug", "get_bug", "ChartSpec", "load_spec", "make_spec", "spec_from_mapping", "ENTRY_KEYS",
           "FIELD_NAMES", "FIELDS", "Field", "field_value", "field_value_from_text", "read_entry_document",
           "resolve_field", "spec_to_flags", "spec_to_toml", "split_entry", "sweep_defaults",
           "sweep_values_from_text", "BACKENDS", "BRDF_MODELS", "CAMERAS", "DEFAULT_LIGHTS", "ENV_PRESETS",
           "HDR_PRECISIONS", "INTERSECT_METHODS", "MATERIAL_PRESETS", "QUALITY_PRESETS", "TEXTURE_MODES",
           "TONEMAPPERS", "Light", "Quality", "bug_requirements", "with_bug"]
