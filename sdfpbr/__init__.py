"""sdfpbr: physically based material charts rendered headless with OpenGL.

``sdfpbr.chart(...)`` renders on the process's default GL session (created on first use);
``sdfpbr.Session(backend=...)`` makes one to hand to ``chart(..., session=s)``. GL and image
modules load on first use, so ``import sdfpbr`` stays cheap."""
__version__ = "0.1.0"


def chart(spec=None, **options):
    """Render a labeled chart; see sdfpbr.api.chart."""
    from .api import chart as render_chart
    return render_chart(spec, **options)


# Public names resolved when first used: the spec needs numpy, the rest GL or the image stack
# (a command such as a gallery build with nothing to do loads neither).
# The errors too: the ``sdfpbr`` command's first line (sdfpbr.cli.entry) runs after this
# package's, and a Ctrl-C before it would be a traceback.
_LAZY = {**{name: "sdfpbr.errors" for name in ("SdfpbrError", "SpecError", "OutputError", "GLUnavailable",
                                              "ShaderCompileError")},
         "ChartSpec": "sdfpbr.spec.chart_spec", "Light": "sdfpbr.spec.chart_spec",
         "load_spec": "sdfpbr.spec.chart_spec", "make_spec": "sdfpbr.spec.chart_spec",
         "Chart": "sdfpbr.api", "Session": "sdfpbr.gpu.session", "default_session": "sdfpbr.gpu.session",
         "render_reference": "sdfpbr.features.reference"}


def __getattr__(name):
    if name in _LAZY:
        import importlib
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'sdfpbr' has no attribute {name!r}")


__all__ = ["Chart", "ChartSpec", "Light", "Session", "chart", "default_session", "load_spec", "make_spec",
           "render_reference", "SdfpbrError", "SpecError", "OutputError", "GLUnavailable", "ShaderCompileError",
           "__version__"]
