"""sdfpbr: physically based material charts rendered headless with OpenGL."""
__version__ = "0.1.0"

from .errors import GLUnavailable, OutputError, SdfpbrError, ShaderCompileError, SpecError  # noqa: E402
from .spec.chart_spec import ChartSpec, Light, load_spec, make_spec  # noqa: E402


def chart(spec=None, **options):
    """Render a labeled chart; see sdfpbr.chart.chart."""
    from .api import chart as _chart
    return _chart(spec, **options)


__all__ = ["ChartSpec", "Light", "chart", "load_spec", "make_spec", "SdfpbrError", "SpecError",
           "OutputError", "GLUnavailable", "ShaderCompileError", "__version__"]
