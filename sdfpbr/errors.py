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


def did_you_mean(word, choices) -> str:
    """' (did you mean 'x'?)' for the closest of ``choices``, or '' when none is close: the one
    suggestion helper every message uses."""
    import difflib
    match = difflib.get_close_matches(str(word), [str(c) for c in choices], n=1)
    return f" (did you mean {match[0]!r}?)" if match else ""
