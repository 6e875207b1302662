"""Errors users can act on. The CLI prints their message as one line and exits with
``exit_status`` (2 for bad input, 3 when no OpenGL is available), never with a traceback."""


class SdfpbrError(Exception):
    exit_status = 1


class SpecError(SdfpbrError, ValueError):
    """Invalid chart specification: a bad option, value, key or file."""
    exit_status = 2


class OutputError(SdfpbrError):
    """An output location that cannot be written."""
    exit_status = 2


class GLUnavailable(SdfpbrError):
    """No headless OpenGL context could be created."""
    exit_status = 3


class ShaderCompileError(SdfpbrError):
    exit_status = 4
